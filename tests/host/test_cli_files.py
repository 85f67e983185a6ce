"""The CLI's file rules, end to end (issue 15 items 2, 3 and 9).

- Output files (15.9): every command refuses an existing output file unless
  ``--force`` (one line, exit status 2, the file untouched, nothing done),
  and writes atomically.
- Input files (15.2): a deeply nested TOML/JSON file ends in one line and
  exit status 2, never a traceback.
- ``--timeout`` (15.3): a value out of range ends in one line and exit status 2.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from aacmm.commands import exitcodes
from aacmm.commands.sim import SimProcess
from clihelp import AACMM, cli_env, one_error_line, read_only_dir, run, sim_fixture

pytestmark = pytest.mark.timeout(120)
sim = sim_fixture("--seed", "5")

NOWHERE = "serial:///nonexistent/aacmm-port"


def no_temp_files(directory: Path) -> bool:
    return not [p for p in directory.iterdir() if p.name.endswith(".tmp")]


# ------------------------------------------------------------------ outputs (15.9)


def test_params_get_refuses_existing_output(sim: SimProcess, tmp_path: Path) -> None:
    out = tmp_path / "arm.toml"
    out.write_text("# mine\n")
    p = run("params", "get", "-o", str(out), "--port", sim.url)
    one_error_line(p, exitcodes.USAGE, str(out), "exists", "--force")
    assert out.read_text() == "# mine\n"
    # refused before the device is opened: a missing port would be status 3
    p = run("params", "get", "-o", str(out), "--port", NOWHERE)
    one_error_line(p, exitcodes.USAGE, "exists")
    p = run("params", "get", "-o", str(out), "--force", "--port", sim.url)
    assert p.returncode == 0, p.stderr
    assert "l_mm" in tomllib.loads(out.read_text())
    p = run("params", "get", "-o", str(tmp_path / "new.json"), "--port", sim.url)
    assert p.returncode == 0, p.stderr
    assert "l_mm" in json.loads((tmp_path / "new.json").read_text())
    assert no_temp_files(tmp_path)
    p = run("params", "get", "-o", str(tmp_path / "no" / "dir.toml"), "--port", sim.url)
    one_error_line(p, exitcodes.USAGE, "does not exist")


# ------------------------------------------------------------------ --timeout (15.3)


TIMEOUT_CASES = [(["info"], v) for v in ("inf", "1e10", "nan", "0", "-1", "3600.5")] + [
    (cmd, "inf") for cmd in (["measure"], ["params", "get"], ["params", "save"], ["log", "x.csv"])
]


@pytest.mark.parametrize(("command", "value"), TIMEOUT_CASES)
def test_timeout_out_of_range(
    sim: SimProcess, tmp_path: Path, command: list[str], value: str
) -> None:
    """inf and 1e10 ended in an OverflowError traceback (exit 1)."""
    p = run(*command, "--timeout", value, "--port", sim.url, cwd=tmp_path)
    one_error_line(p, exitcodes.USAGE, "--timeout must be in (0, 3600] seconds")
    assert list(tmp_path.iterdir()) == []  # the log wrote nothing


def test_timeout_at_the_maximum_works(sim: SimProcess) -> None:
    p = run("info", "--timeout", "3600", "--port", sim.url)
    assert p.returncode == 0, p.stderr


# ------------------------------------------------------------------ deep nesting (15.2)

DEEP_TOML = "l_mm = " + "[" * 1200 + "]" * 1200 + "\n"  # the 1,200 levels
DEEP_JSON = "[" * 100_000  # the 100,000 brackets


def small_log(directory: Path) -> Path:
    """A log CSV as `aacmm log` writes it (three samples)."""
    from aacmm.commands.log import COLUMNS

    rows = [",".join(COLUMNS)]
    for i in range(3):
        counts = [str((i + 1) * 1000 * (j + 1)) for j in range(6)]
        rows.append(
            ",".join([str(i), str(1000 * i), f"{1.7e9 + i:.6f}", *counts, "1.0", "2.0", "3.0", "1"])
        )
    path = directory / "run.csv"
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("deep.toml", DEEP_TOML),
        ("deep.json", DEEP_JSON),
        ("inline.toml", "a = " + "{b = " * 1200 + "1" + "}" * 1200),
    ],
)
def test_params_set_deeply_nested_file(tmp_path: Path, name: str, text: str) -> None:
    """RecursionError traceback, exit 1, before; --check reads the file the same way."""
    path = tmp_path / name
    path.write_text(text)
    for extra in (["--check"], ["--port", NOWHERE]):  # refused before any port is opened
        p = run("params", "set", str(path), *extra)
        one_error_line(p, exitcodes.USAGE, name, "nested too deeply")


def test_uncertainty_deeply_nested_spec(tmp_path: Path) -> None:
    path = tmp_path / "spec.toml"
    path.write_text("[nominal]\nl_mm = " + "[" * 1200 + "]" * 1200 + "\n")
    p = run("uncertainty", str(path), "--trials", "100")
    one_error_line(p, exitcodes.USAGE, "spec.toml", "nested too deeply")


@pytest.mark.parametrize("command", [["summary"], ["mc", "--log"]])
def test_log_readers_deeply_nested_sidecar(tmp_path: Path, command: list[str]) -> None:
    log = small_log(tmp_path)
    sidecar = log.with_name(log.name + ".json")
    sidecar.write_text(DEEP_JSON)
    p = run(*command, str(log))
    one_error_line(p, exitcodes.USAGE, "run.csv.json", "nested too deeply")
    sidecar.write_text('{"status": "complete"}')  # the same log with a sane sidecar works
    p = run(*command, str(log))
    assert p.returncode == 0, p.stderr


# ------------------------------------------------------------------ analysis outputs (15.9)


def test_mc_outputs_follow_the_rule(tmp_path: Path) -> None:
    """Before: mc --csv/--json/--png replaced existing files silently."""
    outs = {s: tmp_path / f"mc.{s}" for s in ("csv", "json", "png")}
    for path in outs.values():
        path.write_text("mine")
    for suffix, path in outs.items():
        p = run("mc", "-n", "100000000", "--seed", "1", f"--{suffix}", str(path))
        one_error_line(p, exitcodes.USAGE, str(path), "exists", "--force")
        assert p.stdout == ""  # refused before any work (10^8 poses take long)
        assert path.read_text() == "mine"
    args = [a for s, path in outs.items() for a in (f"--{s}", str(path))]
    p = run("mc", "-n", "2000", "--seed", "1", "-q", *args, "--force")
    assert p.returncode == 0, p.stderr
    assert outs["csv"].read_text().startswith("axis,parameter")
    assert json.loads(outs["json"].read_text())["n"] == 2000
    assert outs["png"].read_bytes()[:4] == b"\x89PNG"
    assert no_temp_files(tmp_path) and not list(tmp_path.glob(".*"))
    p = run("mc", "-n", "10", "--csv", str(tmp_path / "a.csv"), "--json", str(tmp_path / "a.csv"))
    one_error_line(p, exitcodes.USAGE, "twice")


def test_uncertainty_json_follows_the_rule(tmp_path: Path) -> None:
    out = tmp_path / "u.json"
    out.write_text("mine")
    p = run("uncertainty", "example", "--trials", "1000", "--workspace", "2", "--json", str(out))
    one_error_line(p, exitcodes.USAGE, "u.json", "exists", "--force")
    assert p.stdout == "" and out.read_text() == "mine"
    p = run(
        "uncertainty", "example", "--trials", "1000", "--workspace", "2", "--json", str(out), "-f"
    )
    assert p.returncode == 0, p.stderr
    assert isinstance(json.loads(out.read_text()), dict)


def test_demo_refuses_a_folder_in_use(tmp_path: Path) -> None:
    """The demo's outputs follow the rule too: a non-empty --out is refused at once."""
    (tmp_path / "params.toml").write_text("mine")
    p = subprocess.run(
        [sys.executable, "-m", "aacmm.commands.demo", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert p.returncode == exitcodes.USAGE, p
    assert p.stderr.strip() == f"demo: {tmp_path} is not empty: give a new --out folder"
    assert [f.name for f in tmp_path.iterdir()] == ["params.toml"]


# Every command that reads a TOML/JSON file, given a hostile one: {toml} is the
# issue's 1,200-level TOML, {session} a session folder whose session.json is
# 100,000 '[' (the plan, session, truth and spec readers of every role).
READERS = [
    ["params", "set", "{toml}", "--check"],
    ["uncertainty", "{toml}"],
    ["tolerance", "{toml}"],
    ["plan", "check", "{toml}"],
    ["capture", "{toml}", "-o", "{tmp}/new-session", "--port", NOWHERE],
    ["sim", "--truth", "{toml}"],
    ["calibrate", "{session}", "-o", "{tmp}/p.toml"],
    ["verify", "{session}"],
    ["summary", "{session}"],
    ["export", "{session}", "--format", "csv", "-o", "{tmp}/x.csv"],
    ["fit", "{session}", "sphere"],
]


@pytest.mark.parametrize("command", READERS, ids=lambda c: " ".join(c[:2]))
def test_every_reader_refuses_deep_nesting(tmp_path: Path, command: list[str]) -> None:
    toml = tmp_path / "deep.toml"
    toml.write_text(DEEP_TOML)
    session = tmp_path / "session"
    session.mkdir()
    (session / "session.json").write_text(DEEP_JSON)
    args = [a.format(toml=toml, session=session, tmp=tmp_path) for a in command]
    p = run(*args, timeout=60)
    one_error_line(p, exitcodes.USAGE, "nested too deeply")
    assert {f.name for f in tmp_path.iterdir()} == {"deep.toml", "session"}  # nothing written


def test_command_line_start_up_imports_nothing_heavy() -> None:
    """Every aacmm command builds the whole parser first: a command module that
    imports python-can, cantools, pyserial, numpy, ... at module level makes every
    command (and `aacmm --help`) start slowly. They import them when they run."""
    heavy = ("can", "cantools", "isotp", "serial", "numpy", "scipy", "matplotlib", "cffi")
    code = (
        "import sys, aacmm.cli\n"
        "aacmm.cli.build_parser()\n"
        f"print(' '.join(m for m in {heavy!r} if m in sys.modules))\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == [], "imported while building the parser"


def test_top_level_help_names_every_command_once_by_task() -> None:
    """`aacmm --help` ends with the commands grouped by task: every command is in
    exactly one group, and no group names a command that does not exist."""
    import argparse

    from aacmm.cli import EPILOG, build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    commands = set(sub.choices)
    groups = EPILOG.split("\n\n")[0].splitlines()[1:]
    named = [w for g in groups for w in re.sub(r"\([^)]*\)", "", g[17:]).replace(",", " ").split()]
    assert sorted(named) == sorted(commands), (sorted(named), sorted(commands))


# ---------------------------------------------- issue 29: outputs, signals, pipes

PLAN = "probe-calibration"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A session of a shipped plan and a log with its trigger file (written the
    way the commands write them), for the commands that read them."""
    from aacmm.core import Params
    from calib_synth import plan_session

    d = tmp_path_factory.mktemp("inputs")
    plan_session(d / "session", PLAN, Params(), 5)
    log = small_log(d)
    return {"session": d / "session", "log": log}


def _tree(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): (p.read_bytes() if p.is_file() else b"<dir>")
        for p in sorted(root.rglob("*"))
    }


def _one_refusal(p: subprocess.CompletedProcess[str], *words: str) -> str:
    """Exit status 2 and one line on stderr (``aacmm CMD: error: ...`` or ``demo: ...``)."""
    assert p.returncode == exitcodes.USAGE, (p.returncode, p.stdout, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    assert lines[0].startswith(("aacmm ", "demo: ")), lines
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


# Every command that writes files, each output in a folder that takes no file.
# {ro}: that folder; {tmp}: a writable one; {session}, {log}: inputs.
READ_ONLY_OUTPUTS = [
    ["params", "get", "-o", "{ro}/arm.toml", "--port", NOWHERE],
    ["log", "{ro}/run.csv", "--port", NOWHERE],
    ["log", "{tmp}/run.csv", "--triggers", "{ro}/t.csv", "--port", NOWHERE],
    ["capture", PLAN, "-o", "{ro}/s", "--port", NOWHERE],
    ["capture", PLAN, "-o", "{ro}/s", "--from-log", "{log}"],
    ["calibrate", "{session}", "-o", "{ro}/c.toml"],
    ["calibrate", "{session}", "-o", "{tmp}/c.toml", "--report", "{ro}/sub/rep"],  # the issue's
    ["verify", "{session}", "--report", "{ro}/rep"],
    ["verify", "{session}", "--json", "{ro}/v.json"],
    ["fit", "{session}", "point", "--json", "{ro}/f.json"],
    ["fit", "{session}", "point", "--json", "{tmp}/f.json", "--csv", "{ro}/f.csv"],
    ["export", "{session}", "-o", "{ro}/p.ply"],
    ["sim", "--truth", "nominal", "--truth-out", "{ro}/truth.toml"],
    ["sim", "--scenario", PLAN, "--truth-out", "{tmp}/t.toml", "--report", "{ro}/op.json"],
    ["sim", "--link", "{ro}/port"],
    ["sim", "--storage", "{ro}/arm.bin"],
    ["mc", "-n", "100", "--json", "{tmp}/m.json", "--png", "{ro}/m.png"],
    ["uncertainty", "example", "--trials", "100", "--csv", "{ro}/u.csv"],
    ["tolerance", "example", "--trials", "0", "--json", "{tmp}/t.json", "--csv", "{ro}/t.csv"],
    ["dbc", "-o", "{ro}/arm.dbc"],
    ["dbc", "--all", "-o", "{ro}"],
    ["plan", "example", PLAN, "-o", "{ro}/plan.toml"],
    ["model", "example", "gao2013", "-o", "{ro}/model.toml"],
    ["demo", "--out", "{ro}/demo"],
    ["demo", "--compare", "{ro}"],
    ["demo", "--check", "{ro}"],
]


def _each(cases: list[Any], check: Callable[[Any], None]) -> None:
    """``check(case)`` for every case, a few at a time (each is a command's start-up,
    mostly imports), and every failure reported together."""
    from concurrent.futures import ThreadPoolExecutor

    def one(case: Any) -> str | None:
        try:
            check(case)
        except AssertionError as exc:
            return f"{case}: {exc}"
        return None

    with ThreadPoolExecutor(max_workers=3) as ex:
        failures = [f for f in ex.map(one, cases) if f is not None]
    assert not failures, "\n".join(failures)


def test_read_only_outputs_are_refused_before_the_work(
    tmp_path: Path, inputs: dict[str, Path]
) -> None:
    """Issue 29.5 and its sweep: an output that cannot be written is refused at once
    (one line, exit 2, before a device or a computation), and nothing is left
    behind, where the other outputs would go either: `calibrate -o c.toml --report
    RO/sub` left c.toml and its provenance; `capture -o RO/new` opened the device,
    then ended in a raw "[Errno 30]", exit 1. Every command that writes files, each
    in a folder of its own."""

    def check(case: tuple[int, list[str]]) -> None:
        k, command = case
        work = tmp_path / f"case{k}"
        work.mkdir()
        ro, wrap = read_only_dir(work)
        args = [a.format(ro=ro, tmp=work, **inputs) for a in command]
        before = _tree(work), _tree(inputs["session"].parent)
        p = subprocess.run(
            [*wrap, str(AACMM), *args], capture_output=True, text=True, timeout=180,
            env=cli_env(), cwd=work,
        )  # fmt: skip
        _one_refusal(p, str(ro))
        assert (_tree(work), _tree(inputs["session"].parent)) == before

    _each(list(enumerate(READ_ONLY_OUTPUTS)), check)


# One output of each multi-output command exists: the command is refused and
# writes none of the others (no half-written set of outputs).
EXISTING_OUTPUTS = [
    (["calibrate", "{session}", "-o", "{tmp}/c.toml"], "c.provenance.json"),
    (["calibrate", "{session}", "-o", "{tmp}/c.toml", "--report", "{tmp}/rep"], "rep/report.txt"),
    (["verify", "{session}", "--json", "{tmp}/v.json", "--report", "{tmp}/rep"], "rep/report.pdf"),
    (["fit", "{session}", "point", "--json", "{tmp}/f.json", "--csv", "{tmp}/f.csv"], "f.csv"),
    (["mc", "-n", "100", "--json", "{tmp}/m.json", "--png", "{tmp}/m.png"], "m.png"),
    (
        [
            "uncertainty",
            "example",
            "--trials",
            "100",
            "--json",
            "{tmp}/u.json",
            "--png",
            "{tmp}/u.png",
        ],
        "u.png",
    ),
    (
        ["tolerance", "example", "--trials", "0", "--json", "{tmp}/t.json", "--png", "{tmp}/t.png"],
        "t.png",
    ),
    (
        [
            "sim",
            "--truth",
            "nominal",
            "--truth-out",
            "{tmp}/t.toml",
            "--scenario",
            PLAN,
            "--report",
            "{tmp}/op.json",
        ],
        "op.json",
    ),
    (["log", "{tmp}/run.csv", "--port", NOWHERE], "run.triggers.csv"),
    (["capture", PLAN, "-o", "{tmp}/s", "--from-log", "{log}"], "s/x"),
    (["dbc", "--all", "-o", "{tmp}"], "aacmm-node7.dbc"),
    (["demo", "--compare", "{tmp}"], "before-after.png"),
    (["demo", "--out", "{tmp}/d"], "d/x"),
]


def test_an_existing_output_refuses_the_whole_set(tmp_path: Path, inputs: dict[str, Path]) -> None:
    def check(case: tuple[int, tuple[list[str], str]]) -> None:
        k, (command, existing) = case
        work = tmp_path / f"case{k}"
        target = work / existing
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text("mine")
        args = [a.format(tmp=work, **inputs) for a in command]
        before = _tree(work)
        p = subprocess.run(
            [str(AACMM), *args], capture_output=True, text=True, timeout=180, env=cli_env(),
            cwd=work,
        )  # fmt: skip
        _one_refusal(p)
        assert _tree(work) == before

    _each(list(enumerate(EXISTING_OUTPUTS)), check)


def test_demo_checks_its_arguments_first(tmp_path: Path) -> None:
    """Issue 29.5: `demo --seed -1 --out d` ran two steps before the simulator refused
    random:-1, its messages on stdout only, d/ half full."""
    for args, words in (
        (["--seed", "-1"], "--seed must be in 0 .. 2^64-1"),
        (["--seed", str(1 << 64)], "--seed"),
        (["--seconds", "nan"], "--seconds"),
        (["--poses", "1000000000000"], "--poses"),
    ):
        p = run("demo", *args, "--out", str(tmp_path / "d"), timeout=60)
        _one_refusal(p, words)
        assert p.stdout == "" and list(tmp_path.iterdir()) == []


def test_ctrl_c_is_130_in_every_device_command(tmp_path: Path) -> None:
    """Issue 29.4: Ctrl-C ends every command with one line `... interrupted`, exit 130,
    and no file: here while each waits for a device that never answers (a pty no
    simulator serves), the longest a device command can wait. (`log` waited for
    the device's answers before: Ctrl-C only took effect after the timeout.)"""
    import os
    import pty
    import select
    import signal

    master, slave = pty.openpty()
    try:
        port = f"serial://{os.ttyname(slave)}"
        for cmd in (
            ["info"],
            ["measure"],
            ["compute", "0", "0", "0", "0", "0", "0"],
            ["params", "get", "-o", str(tmp_path / "a.toml")],
            ["params", "save"],
            ["log", str(tmp_path / "run.csv"), "-d", "5"],
            ["capture", PLAN, "-o", str(tmp_path / "s")],
        ):
            proc = subprocess.Popen(
                [str(AACMM), *cmd, "--port", port, "--timeout", "60"],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=cli_env(),
                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
            )  # fmt: skip
            # interrupted while it waits for the answer to its first request
            ready, _, _ = select.select([master], [], [], 60)
            assert ready, cmd
            os.read(master, 4096)
            proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=60)
            assert proc.returncode == exitcodes.INTERRUPTED, (cmd, err)
            assert err.strip().splitlines() == [f"aacmm {cmd[0]}: interrupted"], (cmd, err)
            assert list(tmp_path.iterdir()) == [], cmd
    finally:
        os.close(master)
        os.close(slave)


STDOUT_COMMANDS = [
    ["plan", "list"],
    ["plan", "show", "iso10360-12", "--points"],
    ["dbc"],
    ["summary", "{session}"],
    ["export", "{session}", "--format", "csv"],
    ["fit", "{session}", "point", "--json", "-"],
    ["mc", "-n", "1000"],
    ["uncertainty", "example", "--trials", "200"],
    ["tolerance", "example", "--trials", "0"],
    ["--help"],
    ["fit", "--help"],
]


@pytest.mark.parametrize("command", STDOUT_COMMANDS, ids=lambda c: " ".join(c[:2]))
def test_a_closed_stdout_ends_quietly(inputs: dict[str, Path], command: list[str]) -> None:
    """Issue 29.4: a closed stdout (`aacmm mc | head -c 10`) ended in "error: [Errno 32]
    Broken pipe", exit 2, or a traceback; it ends quietly, exit 0, as for other tools."""
    p = subprocess.Popen(
        [str(AACMM), *[a.format(**inputs) for a in command]],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=cli_env(),
    )  # fmt: skip
    assert p.stdout is not None and p.stderr is not None
    p.stdout.close()  # the reader is gone before the first byte
    err = p.stderr.read()
    assert p.wait(timeout=120) == 0, err
    assert err == "", err
