"""The project's own tooling (issue 14 item 7): `make help` lists every
target, `make test`'s runner prints one line per suite and keeps each suite's
output in a log, and `make check-format` finds badly formatted sources."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(120)

ROOT = Path(__file__).resolve().parents[2]
RUNNER = ROOT / "scripts" / "run-suites.sh"
CHECK_FORMAT = ROOT / "scripts" / "check-format.sh"
RUFF = ROOT / ".venv" / "bin" / "ruff"
SUITE_LINE = re.compile(r"^  (\S+) +(pass|FAIL|ok) +(\d+\.\d) s$")


def make(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["make", "--no-print-directory", *args], cwd=cwd, capture_output=True, text=True
    )


def phony_targets() -> set[str]:
    db = make("-pRrq", "-f", "Makefile", ":").stdout
    names: set[str] = set()
    for line in db.splitlines():
        if line.startswith(".PHONY:"):
            names.update(line.split()[1:])
    return names


def test_make_help_lists_every_phony_target() -> None:
    """Before: `make help` named 6 targets and the suites; sim, fuzz, run-<board>,
    check-format, ... were missing although the README says it lists them all."""
    p = make("help")
    assert p.returncode == 0, p.stderr
    words = set(re.split(r"[\s,:()]+", p.stdout))
    phony = phony_targets()
    assert {"sim", "fuzz", "check-format", "run-microbit", "run-mps2-an386", "test"} <= phony
    missing = sorted(phony - words)
    assert not missing, f"add a '#> NAME  TEXT' line for {missing} (see the Makefile)"
    assert "check-format" in p.stdout and "run-<board>" in p.stdout


def test_check_format_target_exists_and_passes() -> None:
    p = make("check-format")
    assert p.returncode == 0, p.stdout + p.stderr
    assert "all sources formatted" in p.stdout


FAKE_MAKEFILE = """\
.PHONY: prep chatty quick bad
prep:
\t@echo preparing
chatty:
\t@i=0; while [ $$i -lt 5000 ]; do echo "progress line $$i"; i=$$((i+1)); done
quick:
\t@true
bad:
\t@i=0; while [ $$i -lt 100 ]; do echo "bad line $$i"; i=$$((i+1)); done; exit 1
"""


def run_suites(tmp: Path, *args: str, **env: str) -> subprocess.CompletedProcess[str]:
    (tmp / "Makefile").write_text(FAKE_MAKEFILE)
    full_env = {**os.environ, "TEST_LOG_DIR": str(tmp / "logs"), **env}
    return subprocess.run(
        ["sh", str(RUNNER), *args], cwd=tmp, capture_output=True, text=True, env=full_env
    )


def test_runner_prints_one_line_per_suite(tmp_path: Path) -> None:
    """Before: every suite's output went to the terminal (5,800 lines, 4,500 of
    them fuzzer progress)."""
    p = run_suites(tmp_path, "--prepare", "prep", "chatty", "bad", "quick")
    assert p.returncode == 1
    lines = p.stdout.splitlines()
    assert lines[-1] == "suites: 2 passed, 1 failed"  # CI reads this line
    assert lines[-2] == "failed suites: bad"
    results = {m[1]: m[2] for m in map(SUITE_LINE.match, lines) if m}
    assert results == {"prep": "ok", "chatty": "pass", "bad": "FAIL", "quick": "pass"}
    assert "progress line" not in p.stdout  # the chatter is in the log only
    log = tmp_path / "logs" / "chatty.log"
    assert log.read_text().count("progress line") == 5000
    # the failure says where its log is and shows its tail (40 lines)
    bad_log = tmp_path / "logs" / "bad.log"
    assert f"log: {bad_log}" in p.stdout
    shown = [ln for ln in lines if ln.startswith("    | ")]
    assert len(shown) == 40 and "    | bad line 99" in shown[-3:]
    assert len(lines) < 60
    tsv = (tmp_path / "logs" / "summary.tsv").read_text().splitlines()
    assert tsv[0] == "suite\tresult\tseconds" and len(tsv) == 5
    assert [r.split("\t")[1] for r in tsv[1:]] == ["ok", "pass", "FAIL", "pass"]


def test_runner_stops_when_the_preparation_fails(tmp_path: Path) -> None:
    p = run_suites(tmp_path, "--prepare", "bad", "quick", "chatty", TEST_TAIL="3")
    assert p.returncode == 1
    lines = p.stdout.splitlines()
    assert lines[-1] == "suites: 0 passed, 2 failed"
    assert not (tmp_path / "logs" / "quick.log").exists()
    shown = [ln for ln in lines if ln.startswith("    | ")]
    assert len(shown) == 3 and "    | bad line 99" in shown


def test_runner_verbose_streams_everything(tmp_path: Path) -> None:
    p = run_suites(tmp_path, "quick", "chatty", TEST_VERBOSE="1")
    assert p.returncode == 0
    assert p.stdout.count("progress line") == 5000
    assert p.stdout.splitlines()[-1] == "suites: 2 passed, 0 failed"
    assert (tmp_path / "logs" / "chatty.log").read_text().count("progress line") == 5000


PARALLEL_MAKEFILE = """\
.PHONY: ping pong solo env1 env2
# ping and pong each wait (up to 10 s) for the other to start: they pass only side by side
wait = touch $(1).running; i=0; \\
    while [ ! -f $(2).running ] && [ $$i -lt 50 ]; do sleep 0.2; i=$$((i+1)); done; \\
    ok=0; [ -f $(2).running ] || ok=1; sleep 0.5; rm -f $(1).running; exit $$ok
ping: shared.o
\t@$(call wait,ping,pong)
pong: shared.o
\t@$(call wait,pong,ping)
# solo runs alone: neither of the others may be running
solo:
\t@test ! -f ping.running && test ! -f pong.running && echo solo-ok
env1 env2:
\t@echo "$$XDG_RUNTIME_DIR" > $@.xdg; test -d "$$XDG_RUNTIME_DIR"
shared.o:
\t@echo built >> build-count; echo x > $@
"""


def test_runner_runs_two_at_a_time_and_alone_last(tmp_path: Path) -> None:
    """Suites run side by side (two at a time), each with its own XDG_RUNTIME_DIR;
    what they build first is made once, on the "build" line; --alone suites run
    after the others; the summary lists the suites in the order they were named."""
    (tmp_path / "Makefile").write_text(PARALLEL_MAKEFILE)
    env = {**os.environ, "TEST_LOG_DIR": str(tmp_path / "logs"), "TEST_JOBS": "2"}
    p = subprocess.run(
        ["sh", str(RUNNER), "--alone", "solo", "solo", "ping", "env1", "pong", "env2"],
        cwd=tmp_path, capture_output=True, text=True, env=env,
    )  # fmt: skip
    assert p.returncode == 0, p.stdout + p.stderr
    lines = p.stdout.splitlines()
    assert lines[0].endswith("5 suites, 2 at a time; the output of each goes to "
                             f"{tmp_path / 'logs'}/<suite>.log")  # fmt: skip
    names = [m[1] for m in map(SUITE_LINE.match, lines) if m]
    assert names[0] == "build" and names[-1] == "solo", names
    assert sorted(names[1:-1]) == ["env1", "env2", "ping", "pong"]
    assert (tmp_path / "build-count").read_text() == "built\n"  # once, before the suites
    xdg1, xdg2 = ((tmp_path / f"env{i}.xdg").read_text().strip() for i in (1, 2))
    assert xdg1 != xdg2 and xdg1.endswith("/run/env1")
    tsv = (tmp_path / "logs" / "summary.tsv").read_text().splitlines()
    assert [r.split("\t")[0] for r in tsv[1:]] == ["build", "solo", "ping", "env1", "pong", "env2"]
    assert "solo-ok" in (tmp_path / "logs" / "solo.log").read_text()
    # one at a time, each waits for the other in vain and fails
    env["TEST_JOBS"] = "1"
    q = subprocess.run(["sh", str(RUNNER), "ping", "pong"], cwd=tmp_path, capture_output=True,
                       text=True, env=env, timeout=120)  # fmt: skip
    assert q.returncode == 1 and "suites: 0 passed, 2 failed" in q.stdout


def test_check_format_finds_bad_files(tmp_path: Path) -> None:
    subprocess.run(["git", "init", "-q", str(tmp_path)], check=True)
    (tmp_path / "ok.py").write_text("x = 1\n")
    (tmp_path / "ok.c").write_text("int x;\n")
    (tmp_path / "pyproject.toml").write_text("[tool.ruff]\nline-length = 100\n")
    subprocess.run(["git", "-C", str(tmp_path), "add", "."], check=True)

    def check() -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            ["sh", str(CHECK_FORMAT), str(RUFF), "pyproject.toml"],
            cwd=tmp_path,
            capture_output=True,
            text=True,
        )

    assert check().returncode == 0
    bad = {
        "bad.py": "x=1\n",
        "blank.c": "int y; \n",
        "tab.h": "\tint z;\n",
        "crlf.md": "a\r\n",
        "end.mk": "a",
    }
    for name, text in bad.items():
        (tmp_path / name).write_text(text, newline="")
    subprocess.run(["git", "-C", str(tmp_path), "add", "."], check=True)
    p = check()
    assert p.returncode == 1
    out = p.stdout + p.stderr
    for name in bad:
        assert name in out, (name, out)
    assert "ok.py" not in out and "ok.c" not in out


# Hardware register names the docs quote to describe what QEMU models; the
# firmware does not use them.
DOC_ONLY_NAMES = {"RUNSTATUS": "nRF51 WDT status register (docs/boards.md, QEMU limits)"}


def test_docs_name_only_constants_that_exist() -> None:
    """Every `CONSTANT_NAME` that README or docs/ quote (a message, flag, limit,
    variable) is in the code, scripts or tests: a removed one (docs/client.md
    described the framing lock constant long after it was gone, issue 14 item 7) fails."""
    tracked = subprocess.run(
        ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True
    ).stdout.split(b"\0")
    docs = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    code: list[str] = []
    for name in tracked:
        path = ROOT / name.decode()
        if not name or path in docs or not path.is_file():
            continue
        data = path.read_bytes()
        if b"\0" not in data:
            code.append(data.decode("utf-8", "replace"))
    corpus = "\n".join(code)
    quoted = re.compile(r"`([A-Z][A-Z0-9_]{3,})`")
    missing = sorted(
        f"{doc.relative_to(ROOT)}: {name}"
        for doc in docs
        for name in set(quoted.findall(doc.read_text(encoding="utf-8")))
        if name not in corpus and name not in DOC_ONLY_NAMES
    )
    assert not missing, missing
