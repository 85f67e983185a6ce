"""``aacmm demo``: the README's main job, an arm owner's session end to end.

On the simulator, with an arm whose true geometry is random and hidden from
the device (``aacmm sim --truth random:SEED``: every length +-0.5 mm, every
angle +-0.05 deg, encoder noise, eccentric encoders, probing noise), and a
simulated operator who probes each plan (``--scenario``):

1. a short measurement log (``aacmm log``, ``aacmm summary``) and the paper's
   Table 2 (``aacmm mc``; for another model its own error-transfer
   coefficients, ``aacmm mc --model``, and the step says Table 2 is the
   paper's arm's);
2. the verification plan (ISO 10360-12 + the B89.4.22 single-point
   articulation test): ``aacmm capture``, ``aacmm verify`` -- FAIL;
3. the kinematic-calibration plan, ``aacmm calibrate``,
   ``aacmm params set --save``;
4. the verification plan again -- PASS;
5. the before/after table and figure, and a check of the calibration
   against the simulator's truth (the only step that reads it).

``--model NAME`` (issue 26) tells the same story with an arm of any shipped
model (or model file): the simulator runs that model (``aacmm sim --model``)
with a random true arm of it, and every analysis command works from the
sessions' parameter set. The default, the paper's ``gao2013``, runs exactly
as without the option.

Every step runs the real ``aacmm`` command in the output folder
(``out/demo-<UTC time>/``) and prints its command line first, so each can be
repeated by hand there. ``aacmm demo --compare DIR`` and ``--check DIR`` are
the last two steps alone.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime as dt
import os
import secrets
import shlex
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import IO, Any

from aacmm.commands.common import add_force_option
from aacmm.commands.exitcodes import NOT_MET, OK, REFUSED, USAGE, WORSE

VERIFY_PLAN = "arm-verification"
CALIBRATION_PLAN = "kinematic-calibration"
#: The calibration of the same data without the error model (the arm alone), written
#: beside calibrated.toml when that has an [errmodel] table.
DH_ONLY = "calibrated-dh-only.toml"  # demo_report.DH_ONLY_FILE
DH_ONLY_ARGS = ("calibrate", "calibration", "-o", DH_ONLY, "--harmonics", "0", "--override")
SIM_READY_S = 60.0  # planning the articulations of a plan takes a few seconds
TITLE = "aacmm demo: an arm out of calibration, verified, calibrated, verified again"


def register(sub: Any) -> None:
    """Add ``demo`` to an argparse subparsers object."""
    p = sub.add_parser(
        "demo",
        help="the main job on the simulator: verify (FAIL), calibrate, verify again (PASS)",
        description="An arm owner's session on the simulator, whose arm has a random true "
        "geometry hidden from the device: a short log and the paper's Table 2, the "
        f"{VERIFY_PLAN} plan (aacmm capture, aacmm verify: FAIL), the {CALIBRATION_PLAN} "
        "plan, aacmm calibrate, aacmm params set --save, the verification again (PASS), a "
        "before/after table and figure, and a check against the simulator's truth. Every "
        "command line is printed and can be repeated by hand in the output folder "
        "(docs/tutorial.md, docs/cli.md).",
    )
    add_arguments(p)
    p.set_defaults(func=run_demo)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--out", type=Path, metavar="DIR", help="output folder (default out/demo-<UTC time>)"
    )
    p.add_argument(
        "--seed",
        type=int,
        metavar="N",
        help="the simulated arm's true geometry is random:SEED (default: a random seed, "
        "printed, so the same arm can be taken again)",
    )
    p.add_argument(
        "--model",
        metavar="NAME|FILE",
        help="the simulated arm's model: a shipped model (aacmm model list) or a model file "
        "(default gao2013, the paper's arm); its true geometry is a random arm of the model",
    )
    p.add_argument(
        "--encoder-grade",
        metavar="GRADE",
        help="the simulated arm's encoders (aacmm sim --encoder-grade: two-head, the "
        "default; one-head; magnetic): their reading errors are encoder angle harmonics "
        "the calibration estimates beside the arm",
    )
    p.add_argument(
        "--pace",
        choices=("fast", "person"),
        default="fast",
        help="the simulated operator: 'fast' (no pacing, default) or a person's pace "
        "(about 1.5 s per point: some 10 minutes)",
    )
    p.add_argument(
        "--seconds", type=float, default=2.0, metavar="S", help="log duration (default 2)"
    )
    p.add_argument(
        "--poses", type=int, default=10_000, metavar="N", help="Table 2 poses (default 10^4)"
    )
    alone = p.add_mutually_exclusive_group()
    alone.add_argument(
        "--compare",
        metavar="DIR",
        type=Path,
        help="only the before/after step: the table and figure of a finished demo folder DIR "
        "(from DIR/before-report and DIR/after-report)",
    )
    alone.add_argument(
        "--check",
        metavar="DIR",
        type=Path,
        help="only the last step: compare the calibration of a finished demo folder DIR "
        "with the simulator's truth (DIR/arm/truth.toml)",
    )
    add_force_option(p)


def _aacmm() -> list[str]:
    exe = Path(sys.executable).with_name("aacmm")
    return [str(exe)] if exe.is_file() else [sys.executable, "-m", "aacmm.cli"]


def _shown(args: Sequence[str]) -> str:
    return " ".join(shlex.quote(a) for a in ["aacmm", *args])


class StepFailed(Exception):
    """A command of the demo failed; ``code`` is its exit status."""

    def __init__(self, code: int) -> None:
        super().__init__(code)
        self.code = code


class Demo:
    """Prints (and keeps in ``demo.txt``) the steps, runs the commands in ``out``."""

    def __init__(self, out: Path, steps: int, transcript: IO[str]) -> None:
        self.out = out
        self.steps = steps
        self.index = 0
        self.t0 = time.monotonic()
        self.transcript = transcript
        self.live = sys.stdout.isatty()

    def say(self, text: str = "") -> None:
        print(text, flush=True)
        self.transcript.write(text + "\n")
        self.transcript.flush()

    def fail(self, text: str) -> None:
        """Why the demo stops: in the story on stdout, and as the one line on stderr
        a script reads (once, when both are the same terminal)."""
        self.say(text)
        if not (sys.stdout.isatty() and sys.stderr.isatty()):
            print(text, file=sys.stderr, flush=True)

    def step(self, title: str) -> None:
        """The progress line of the next step: number, elapsed time, what it does."""
        self.index += 1
        m, s = divmod(int(time.monotonic() - self.t0), 60)
        self.say(f"\n[{self.index}/{self.steps}] {m}:{s:02d}  {title}")

    def elapsed(self) -> float:
        return time.monotonic() - self.t0

    def run(
        self,
        args: list[str],
        console: str,
        ok: Sequence[int] = (OK,),
        show: Callable[[str], list[str]] | None = None,
        live: str | None = None,
    ) -> subprocess.CompletedProcess[str]:
        """``aacmm ARGS`` in the output folder: its command line first, its whole
        output kept in ``console/CONSOLE``, the lines ``show`` picks printed.
        ``live``: a prefix of stdout lines counted on a terminal while it runs."""
        self.say(f"$ {_shown(args)}")
        t = time.monotonic()
        proc = subprocess.Popen(
            [*_aacmm(), *args],
            cwd=self.out,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            stdin=subprocess.DEVNULL,
            text=True,
        )
        err: list[str] = []
        assert proc.stderr is not None and proc.stdout is not None
        drain = threading.Thread(target=lambda: err.extend(proc.stderr or ()), daemon=True)
        drain.start()
        lines: list[str] = []
        for line in proc.stdout:
            lines.append(line)
            if live and self.live and line.lstrip().startswith(live):
                print(f"\r  {line.strip()[:70]:<70}", end="", flush=True)
        proc.wait()
        drain.join()
        if live and self.live:
            print("\r" + " " * 74 + "\r", end="", flush=True)
        p = subprocess.CompletedProcess(proc.args, proc.returncode, "".join(lines), "".join(err))
        from aacmm.fileio import write_output

        write_output(self.out / "console" / console, p.stdout + p.stderr)
        picked = show(p.stdout) if show is not None else p.stdout.rstrip().splitlines()
        for line in picked:
            self.say(f"  {line}" if line else "")
        if p.returncode not in ok:
            for line in p.stderr.strip().splitlines()[-5:]:
                self.say(f"  {line}")
            failed = (
                f"demo: step failed (exit status {p.returncode}): {_shown(args)} "
                f"(output: console/{console})"
            )
            self.fail(failed)
            raise StepFailed(p.returncode)
        self.say(f"  ({time.monotonic() - t:.1f} s; output: console/{console})")
        return p

    @contextlib.contextmanager
    def simulator(self, args: list[str], log_name: str) -> Iterator[str]:
        """``aacmm sim ARGS &``: yields the URL it prints; at the end waits for it to
        finish (a scenario ends when capture stops streaming), else stops it."""
        self.say(f"$ {_shown(args)} &")
        log_path = self.out / "console" / log_name
        failed = False
        with open(log_path, "w", encoding="utf-8") as log:
            proc = subprocess.Popen(
                [*_aacmm(), *args],
                cwd=self.out,
                stdout=subprocess.PIPE,
                stderr=log,
                stdin=subprocess.DEVNULL,
                text=True,
            )
            try:
                url = _first_line(proc, SIM_READY_S)
                if not url:
                    with contextlib.suppress(subprocess.TimeoutExpired):
                        proc.wait(timeout=10)
                    tail = log_path.read_text(encoding="utf-8").strip().splitlines()[-3:]
                    for line in tail:
                        self.say(f"  {line}")
                    self.fail(
                        f"demo: the simulator did not start (its messages: console/{log_name})"
                    )
                    raise StepFailed(proc.returncode if proc.returncode else 3)
                try:
                    yield url
                except StepFailed:  # the simulator's own reason, if it gave one
                    failed = True
                    raise
                if "--scenario" in args:  # it ends by itself once capture has stopped
                    with contextlib.suppress(subprocess.TimeoutExpired):
                        proc.wait(timeout=60)
            finally:
                if proc.poll() is None:
                    self.say("$ kill $!                        # stop the simulator")
                    proc.send_signal(signal.SIGTERM)
                    try:
                        proc.wait(timeout=15)
                    except subprocess.TimeoutExpired:
                        proc.kill()
                        proc.wait()
                if proc.stdout is not None:
                    proc.stdout.close()
                if failed:  # e.g. a plan out of the arm's reach
                    log.flush()
                    said = log_path.read_text(encoding="utf-8").splitlines()
                    for line in [s for s in said if " error: " in s][-2:]:
                        self.say(f"  simulator: {line}")


def _first_line(proc: subprocess.Popen[str], timeout: float) -> str:
    """The first stdout line of ``proc`` (empty if it ended or stayed silent)."""
    got: list[str] = []
    assert proc.stdout is not None
    out = proc.stdout

    def reader() -> None:
        got.append(out.readline().strip())
        for _ in out:  # keep draining: the simulator never blocks on a full pipe
            pass

    threading.Thread(target=reader, daemon=True).start()
    deadline = time.monotonic() + timeout
    while not got and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    return got[0] if got else ""


def _table_lines(text: str) -> list[str]:
    """From ``aacmm verify``: the results table and the verdict."""
    lines = text.splitlines()
    start = next((i for i, s in enumerate(lines) if s.startswith("test ")), None)
    end = next((i for i, s in enumerate(lines) if s.startswith("verdict")), None)
    if start is None or end is None:
        return lines[-3:]
    return lines[start : end + 1]


def _calibrate_lines(text: str) -> list[str]:
    """From ``aacmm calibrate``: rank, chi-square, the encoder harmonics, the
    before/after table, files."""
    lines = text.splitlines()
    out: list[str] = []
    if any("rank" in s for s in lines):
        out.append(next(s.strip() for s in lines if s.strip().startswith("rank")))
    out += [s for s in lines if s.startswith(("chi^2", "note: held"))]
    # which error terms beside the arm were estimated, and why (auto: per joint)
    out += [s for s in lines if s.startswith(("Encoder angle harmonics", "note: encoder"))]
    gate = [
        s.strip()
        for s in lines
        if s.strip().startswith(("predicted length", "uncertainty limits", "passed:"))
    ]
    out += [f"quality gate: {s}" for s in gate]
    start = next((i for i, s in enumerate(lines) if s.startswith("Before / after")), None)
    if start is not None:
        for s in lines[start:]:
            if not s.strip():
                break
            out.append(s)
    out += [s for s in lines if s.startswith("wrote ")]
    return out


def _dh_only_lines(text: str) -> list[str]:
    """From ``aacmm calibrate --harmonics 0``: the chi-square verdict and the file."""
    lines = text.splitlines()
    return [s for s in lines if s.startswith(("chi^2", "wrote ")) and "provenance" not in s]


def _last_line(text: str) -> list[str]:
    lines = text.strip().splitlines()
    return lines[-1:] if lines else []


def _first(text: str) -> list[str]:
    lines = text.strip().splitlines()
    return lines[:1]


def run_demo(args: argparse.Namespace) -> int:
    """Run the whole demo (or ``--compare``/``--check DIR`` alone); the exit status."""
    from aacmm.commands import demo_report as dr

    if args.compare is not None:
        return dr.print_before_after(Path(args.compare), force=args.force)
    if args.check is not None:
        return dr.print_truth_check(Path(args.check), force=args.force)
    from aacmm.simulation.process import find_simulator, repo_root

    # Every argument and the output folder are checked before anything runs or is
    # written: a refusal is one line on stderr, exit status 2, and no file.
    problem = _bad_arguments(args)
    if problem:
        print(f"demo: {problem}", file=sys.stderr)
        return USAGE
    root = repo_root() or Path.cwd()
    stamp = dt.datetime.now(dt.UTC).strftime("%Y%m%d-%H%M%S")
    out = (args.out or root / "out" / f"demo-{stamp}").resolve()
    if out.is_dir() and any(out.iterdir()):  # every output is refused if it exists
        print(f"demo: {out} is not empty: give a new --out folder", file=sys.stderr)
        return USAGE
    from aacmm.fileio import OutputFileError, check_output_dir

    try:
        check_output_dir(out, parents=True, what=f"--out {out}")
    except OutputFileError as exc:
        print(f"demo: {exc}", file=sys.stderr)
        return USAGE
    try:
        model = demo_model(args.model)
    except ValueError as exc:  # ModelError: one line naming the file and field
        print(f"demo: {exc}", file=sys.stderr)
        return USAGE
    find_simulator()  # "run make sim" before anything is written
    for sub in ("arm", "console"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    seed = args.seed if args.seed is not None else secrets.randbelow(1_000_000)
    with open(out / "demo.txt", "w", encoding="utf-8") as transcript:
        demo = Demo(out, 11, transcript)
        try:
            return _story(demo, seed, args, model)
        except StepFailed as exc:
            return exc.code
        finally:
            demo.say(f"demo: outputs in {out}")


#: The largest log duration (s) and Table 2 poses the demo takes: a demo, not a study
#: (aacmm log and aacmm mc take more).
MAX_SECONDS = 600.0
MAX_POSES = 10_000_000


def _bad_arguments(args: argparse.Namespace) -> str | None:
    """What is wrong with the demo's options (None: nothing)."""
    if args.seed is not None and not 0 <= args.seed < 1 << 64:
        return f"--seed must be in 0 .. 2^64-1 (the arm random:SEED), got {args.seed}"
    if not 0 < args.seconds <= MAX_SECONDS:  # also refuses NaN
        return f"--seconds must be in (0, {MAX_SECONDS:g}], got {args.seconds:g}"
    if not 1 <= args.poses <= MAX_POSES:
        return f"--poses must be in 1 .. {MAX_POSES}, got {args.poses}"
    if args.encoder_grade is not None:
        from aacmm.simulation.encgrade import GRADES

        if args.encoder_grade not in GRADES:
            return f"--encoder-grade must be one of {', '.join(GRADES)}, got {args.encoder_grade!r}"
    return None


def demo_model(name: str | None) -> Any:
    """The :class:`aacmm.models.ArmModel` of ``--model`` (None: the paper's shipped
    gao2013, whose demo is today's, without ``--model`` anywhere).

    Raises:
        aacmm.errors.ModelError: no such model, or a bad model file.
    """
    from aacmm.models import DEFAULT_MODEL, load_model

    if name is None:
        return None
    model = load_model(name)
    return None if model.name == DEFAULT_MODEL and model.file is None else model


def _plans(model: Any) -> tuple[str, str]:
    """The verification and calibration plans of the demo's arm: the model's own when
    it names them (an arm smaller than the paper's needs plans it can reach), else the
    shipped ones."""
    if model is None:
        return VERIFY_PLAN, CALIBRATION_PLAN
    return (
        str(model.verification_plan),
        str(model.calibration_plan),
    )


def _story(demo: Demo, seed: int, args: argparse.Namespace, model: Any = None) -> int:
    from aacmm.plans import load_plan

    out = demo.out
    verify_plan, calibration_plan = _plans(model)
    n_verify = len(load_plan(verify_plan).slots)
    n_calibration = len(load_plan(calibration_plan).slots)
    demo.say(TITLE)
    demo.say(f"demo: outputs go to {out}")
    demo.say(
        f"demo: every command runs in that folder: to repeat one by hand, cd {out} and run it "
        "with the venv's aacmm (.venv/bin/aacmm)"
    )
    demo.say(
        f"demo: the simulated arm is random:{seed}: its true geometry, hidden from the device "
        f"and from every analysis step (aacmm demo --seed {seed}: the same arm again)"
    )
    on_model: list[str] = []
    if model is not None:
        # a model file by its absolute path: every command runs in the output folder
        on_model = ["--model", str(Path(model.file).resolve()) if model.file else model.name]
        demo.say(
            f"demo: the arm is a {model.name}: {model.n_joints} joints, {model.n_params} "
            f"parameters (aacmm model show {model.name}); every simulator runs it "
            f"(aacmm sim {shlex.join(on_model)})"
        )
    _log_and_table2(demo, args, on_model)
    fast = ["--fast"] if args.pace == "fast" else []
    grade = ["--encoder-grade", args.encoder_grade] if args.encoder_grade else []
    truth = [*on_model, "--truth", f"random:{seed}", *grade]
    if grade:
        demo.say(
            f"demo: its encoders are {args.encoder_grade} encoders (aacmm sim "
            f"--encoder-grade {args.encoder_grade}): reading errors DH cannot describe"
        )
    store = ["--storage", "arm/arm.bin", "--link", "arm/port"]

    def session(plan: str, name: str, op_seed: int, extra: list[str]) -> None:
        sim = ["sim", "--scenario", plan, *truth, *extra, *fast, "--seed", str(op_seed), *store]
        sim += ["--report", f"arm/operator-{name}.json"]
        with demo.simulator(sim, f"sim-{name}.log") as url:
            demo.run(
                ["capture", plan, "-o", name, "--port", url, "-q", "--no-keys"],
                f"capture-{name}.txt",
                show=_last_line,
                live="recorded",
            )

    def verify(name: str) -> subprocess.CompletedProcess[str]:
        """``aacmm verify NAME``: exit status 0 (PASS) or 7 (FAIL) both go on."""
        args = ["verify", name, "--report", f"{name}-report"]
        return demo.run(args, f"verify-{name}.txt", ok=(OK, NOT_MET), show=_table_lines)

    demo.step(
        f"verification before calibration: the simulated operator probes the {verify_plan} "
        f"plan (ISO 10360-12 + B89.4.22 single-point articulation, {n_verify} points)"
    )
    session(verify_plan, "before", 1, ["--truth-out", "arm/truth.toml"])
    demo.step("aacmm verify: the arm as it comes (expected: FAIL)")
    rb = verify("before")
    demo.step(
        f"calibration data: the operator probes the {calibration_plan} plan "
        f"({n_calibration} points)"
    )
    session(calibration_plan, "calibration", 2, [])
    demo.step("aacmm calibrate: identify the arm's parameters (identifiable ones only)")
    demo.run(
        ["calibrate", "calibration", "-o", "calibrated.toml", "--report", "calibration-report"],
        "calibrate.txt",
        show=_calibrate_lines,
    )
    if "[errmodel]" in (out / "calibrated.toml").read_text(encoding="utf-8"):
        # the same data without the error model: the arm alone (DH only), for the
        # truth check's comparison (--override: its quality gate may refuse it)
        demo.run(
            [*DH_ONLY_ARGS, "-q", "--workspace", "0"],
            "calibrate-dh-only.txt",
            ok=(OK, REFUSED),
            show=_dh_only_lines,
        )
    demo.step("load the calibrated parameters into the arm and save them (its storage file)")
    with demo.simulator(["sim", *truth, *store], "sim-params.log") as url:
        demo.run(["params", "set", "calibrated.toml", "--save", "--port", url], "params-set.txt")
    demo.step(
        f"verification after calibration: the operator probes the {verify_plan} plan again "
        "(other articulations; the arm restarted on its saved parameters)"
    )
    session(verify_plan, "after", 3, [])
    demo.step("aacmm verify: the calibrated arm (expected: PASS)")
    ra = verify("after")
    demo.step("before / after (from the two verification reports)")
    rc = demo.run(["demo", "--compare", "."], "before-after.txt", ok=(OK, NOT_MET, WORSE))
    demo.step("check against the simulator's truth (arm/truth.toml, read by no step before)")
    rt = demo.run(["demo", "--check", "."], "truth-check.txt", ok=(OK, WORSE))

    demo.say("\ndemo: figures: before-report/*.png, after-report/*.png, before-after.png,")
    demo.say("      calibration-report/*.png, " + ("table2" if model is None else "mc") + "/mc.png")
    demo.say("demo: one-page reports: before-report/report.pdf, after-report/report.pdf")
    demo.say("demo: interactive 3-D reports (open offline): before-report/report.html,")
    demo.say("      after-report/report.html, calibration-report/report.html")
    demo.say(f"demo: {demo.elapsed():.0f} s in all")
    if rb.returncode == OK:
        demo.say("demo: note: this arm passed before calibration (a lucky random arm)")
    if WORSE in (rc.returncode, rt.returncode):
        demo.say(
            "demo: the calibration made the arm WORSE in some figure (see before-after.txt, "
            "truth-check.txt)"
        )
        return WORSE
    if ra.returncode != OK:
        demo.say("demo: the calibrated arm still FAILS its verification (see after-report)")
        return NOT_MET
    return OK


def _log_and_table2(demo: Demo, args: argparse.Namespace, on_model: list[str]) -> None:
    """The measurement log (aacmm log, summary) and the paper's Table 2 (aacmm mc); for
    another model (``on_model``: its ``--model``) that model's error-transfer coefficients
    instead (``mc/``): Table 2 is the paper's arm's, and the step says so."""
    (demo.out / "logging").mkdir()
    mc_dir = "mc" if on_model else "table2"
    (demo.out / mc_dir).mkdir()
    demo.step(f"log {args.seconds:g} s of measurement at 200 Hz from a simulated arm (aacmm log)")
    sim = ["sim", *on_model, "--motion", "walk", "--seed", "7", "--noise-counts", "64"]
    sim += ["--button-every", "0.5", "--link", "logging/port"]
    with demo.simulator(sim, "sim-logging.log") as url:
        demo.run(
            ["info", "--port", url],
            "info.txt",
            show=lambda t: [s for s in t.splitlines() if s.startswith(("firmware", "parameters"))],
        )
        demo.run(["params", "get", "-o", "logging/params.toml", "--port", url], "params-get.txt")
        demo.run(
            ["log", "logging/session.csv", "--port", url, "-r", "200", "-d", f"{args.seconds:g}"],
            "log.txt",
            show=_last_line,
        )
    demo.run(["summary", "logging/session.csv"], "summary.txt")
    if on_model:
        demo.step(
            f"the arm's error-transfer coefficients: Monte Carlo over {args.poses} random "
            "poses (the paper's Table 2 is of the paper's arm: not this one's, no comparison)"
        )
    else:
        demo.step(f"the paper's Table 2: Monte Carlo error transfer over {args.poses} random poses")
    demo.run(
        ["mc", *on_model, "--log", "logging/session.csv", "--json", f"{mc_dir}/mc_log.json"],
        "mc-log.txt",
        show=_first,
    )
    demo.run(
        [
            *("mc", *on_model, "-n", str(args.poses), "--seed", "1"),
            *("--json", f"{mc_dir}/mc.json", "--csv", f"{mc_dir}/mc.csv"),
            *("--png", f"{mc_dir}/mc.png"),
        ],
        "mc.txt",
    )


def main(argv: list[str] | None = None) -> int:
    """``python -m aacmm.commands.demo`` (same as ``aacmm demo``)."""
    ap = argparse.ArgumentParser(prog="aacmm demo", description=TITLE)
    add_arguments(ap)
    from aacmm.commands.exitcodes import exit_code
    from aacmm.errors import AacmmError

    try:
        return run_demo(ap.parse_args(argv))
    except KeyboardInterrupt:
        print("demo: interrupted", file=sys.stderr)
        return exit_code(KeyboardInterrupt())
    except (AacmmError, ValueError, OSError) as exc:
        print(f"demo: error: {exc}", file=sys.stderr)
        return exit_code(exc)


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    sys.exit(main())
