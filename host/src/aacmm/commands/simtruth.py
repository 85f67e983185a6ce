"""``aacmm sim --truth ... [--scenario PLAN]``: the simulator with an arm of its own.

The device (``aacmm-sim``) keeps computing with its stored parameter set,
while the host moves the *true* arm through the simulator's control channel:
the simulated operator performing a plan (``--scenario``), or a random walk
(``--motion walk``, default) or a still pose (``--motion static``). The truth
never goes over the link; ``--truth-out`` writes it for tests.
``--encoder-grade GRADE`` (with ``--truth random:SEED``) chooses the true
encoders' reading errors (:mod:`aacmm.simulation.encgrade`). See
docs/simulator.md ("Truth", "Encoder grades", "Scenarios") and docs/cli.md.
"""

from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path
from types import FrameType
from typing import Any

from aacmm.commands.common import link_temperatures
from aacmm.commands.exitcodes import OK, UsageError
from aacmm.errors import AacmmError


def add_options(p: argparse.ArgumentParser) -> None:
    """The truth and scenario options of ``aacmm sim``."""
    g = p.add_argument_group("a true arm and a simulated operator (docs/simulator.md)")
    g.add_argument(
        "--truth",
        metavar="SPEC",
        help="the arm's true geometry: 'nominal' (the device's built-in set, no errors), "
        "'random:SEED' (documented perturbation and error sources) or a truth file",
    )
    g.add_argument(
        "--encoder-grade",
        metavar="GRADE",
        help="the true encoders of --truth random:SEED: two-head (default: 0.5-2 arcsec "
        "eccentricity), one-head (harmonics 1-2, 10-30 arcsec) or magnetic (harmonics "
        "1-4, 0.02-0.1 deg)",
    )
    g.add_argument("--truth-out", metavar="FILE", help="write the truth used (TOML)")
    g.add_argument(
        "--scenario",
        metavar="PLAN",
        help="a simulated operator performs this plan (file or shipped name); "
        "it waits for a client to stream (aacmm capture)",
    )
    g.add_argument("--fast", action="store_true", help="no realistic pace (tests)")
    g.add_argument(
        "--follow",
        metavar="SESSION",
        help="probe the point the capture session SESSION expects next (its progress.json), "
        "waiting for each acknowledgement; survives a resumed capture",
    )
    g.add_argument(
        "--misprobe",
        action="append",
        default=[],
        metavar="STEP:POINT:MM[:keep]",
        help="probe point POINT (1-based) of step STEP (id or 1-based number) MM off target "
        "first, then undo it with button 1 and probe it properly (':keep': no undo)",
    )
    g.add_argument("--report", metavar="FILE", help="write what the operator did (JSON)")
    g.add_argument(
        "--verbose",
        action="store_true",
        help="also say every press of the operator (off by default: in the terminal of "
        "aacmm capture they would repeat its prompts)",
    )
    g.add_argument(
        "-f", "--force", action="store_true", help="overwrite --truth-out and --report files"
    )


def wants_truth(args: argparse.Namespace) -> bool:
    return bool(args.truth or args.scenario)


def check_args(args: argparse.Namespace) -> None:
    """Refuse option combinations that make no sense (UsageError, exit 2; an
    unknown ``--encoder-grade``: EncoderGradeError, exit 2)."""
    grade = getattr(args, "encoder_grade", None)
    if grade is not None:
        from aacmm.simulation.encgrade import encoder_grade

        encoder_grade(grade)
        if not (args.truth or "").startswith("random:"):
            raise UsageError("--encoder-grade needs --truth random:SEED (a truth file has its own)")
    if not wants_truth(args):
        for opt in ("truth_out", "follow", "report"):
            if getattr(args, opt):
                raise UsageError(f"--{opt.replace('_', '-')} needs --truth or --scenario")
        if args.fast or args.misprobe or args.verbose:
            raise UsageError("--fast, --misprobe and --verbose need --scenario")
        return
    if args.board is not None:
        raise UsageError("--board runs the board's own firmware: no --truth or --scenario")
    if args.noise_counts is not None:
        raise UsageError("with --truth the encoder noise is the truth's ([encoder_noise])")
    if args.scenario is None:
        for opt, val in (("--follow", args.follow), ("--report", args.report)):
            if val:
                raise UsageError(f"{opt} needs --scenario")
        if args.fast or args.misprobe or args.verbose:
            raise UsageError("--fast, --misprobe and --verbose need --scenario")
        if args.motion not in (None, "walk", "static"):
            raise UsageError("with --truth the host moves the arm: --motion walk or static")
    elif args.motion is not None or args.button_every is not None:
        raise UsageError("with --scenario the operator moves the arm and presses the buttons")


def _sim_cpr(args: argparse.Namespace) -> int | None:
    if args.cpr is not None:
        return int(args.cpr)
    if args.encoder_bits is not None:
        return 1 << int(args.encoder_bits)
    return None


def parse_misprobes(specs: list[str], plan: Any) -> tuple[Any, ...]:
    """``--misprobe STEP:POINT:MM[:keep]`` options as :class:`~aacmm.simulation.run.Misprobe`."""
    from aacmm.simulation.run import Misprobe

    out = []
    for spec in specs:
        parts = spec.split(":")
        if len(parts) not in (3, 4) or (len(parts) == 4 and parts[3] != "keep"):
            raise UsageError(f"--misprobe {spec}: expected STEP:POINT:MM or STEP:POINT:MM:keep")
        step_key: int | str = parts[0]
        if parts[0].isdigit():
            step_key = int(parts[0]) - 1
        try:
            step = plan.step(step_key)
        except (KeyError, IndexError):
            raise UsageError(f"--misprobe {spec}: the plan has no step {parts[0]!r}") from None
        slots = plan.step_slots(step.index)
        try:
            point, mm = int(parts[1]), float(parts[2])
        except ValueError:
            raise UsageError(f"--misprobe {spec}: POINT and MM must be numbers") from None
        if not 1 <= point <= len(slots):
            raise UsageError(f"--misprobe {spec}: step {step.id} has points 1..{len(slots)}")
        if not (math.isfinite(mm) and 0 < mm <= 100):
            raise UsageError(f"--misprobe {spec}: MM must be in (0, 100]")
        out.append(Misprobe(slots[point - 1].index, mm, len(parts) == 4))
    return tuple(out)


def note_others(others: list[tuple[str, int]]) -> None:
    """Say that commands without ``--port`` now use this simulator, not the others."""
    if others:
        urls = ", ".join(f"{u} (pid {p})" for u, p in others)
        print(
            f"aacmm sim: note: commands without --port now use this simulator; "
            f"also running: {urls}, used again when this one stops",
            file=sys.stderr,
            flush=True,
        )


def run(args: argparse.Namespace, sim_args: list[str], model: Any = None) -> int:
    """The command (see the module doc). ``sim_args``: the simulator's own options;
    ``model``: the :class:`aacmm.models.ArmModel` of ``aacmm sim --model`` (None: the
    paper's arm, as before): its truth (:func:`~aacmm.simulation.truthspec.parse_model_truth`)
    and its joint limits for the operator."""
    import numpy as np

    from aacmm.core import Params
    from aacmm.fileio import check_outputs, write_output
    from aacmm.simulation.control import ControlChannel
    from aacmm.simulation.encgrade import DEFAULT_GRADE
    from aacmm.simulation.ik import ARM_LIMITS, JointLimits
    from aacmm.simulation.operator import FAST, Operator, Pace, Stopped
    from aacmm.simulation.process import SimProcess, publish_urls, unpublish_urls
    from aacmm.simulation.truthspec import check_truth_model, parse_model_truth, parse_truth

    check_args(args)
    cpr = _sim_cpr(args)
    limits = ARM_LIMITS
    grade = args.encoder_grade or DEFAULT_GRADE
    if model is None:
        truth = parse_truth(args.truth or "nominal", cpr if cpr is not None else 1 << 32, grade)
        if not isinstance(truth.params, Params):  # a truth file of another arm's shape
            from aacmm.models import DEFAULT_MODEL, load_model

            check_truth_model(truth, load_model(DEFAULT_MODEL), str(args.truth))
    else:
        truth = parse_model_truth(args.truth or "nominal", model, grade)
        limits = JointLimits.from_ranges(model.joint_limits_rad)
        cpr = model.encoders[0].counts_per_rev  # sim_model checked: one for every joint
    cprs = set(truth.encoders.counts_per_rev)
    if len(cprs) != 1:
        cprs_text = list(truth.encoders.counts_per_rev)
        raise UsageError(f"the simulator has one resolution for all joints, the truth {cprs_text}")
    if cpr is not None and cprs != {cpr}:
        says = "--cpr says" if model is None else f"the model {model.name} has"
        raise UsageError(f"the truth has {cprs.pop()} counts per revolution, {says} {cpr}")
    cpr = cprs.pop()
    if args.serial_number is not None:  # the device this truth is, as --truth-out records it
        truth = replace(truth, serial_number=int(args.serial_number))
    plan = None
    misprobes: tuple[Any, ...] = ()
    if args.scenario is not None:
        from aacmm.plans import load_plan

        plan = load_plan(args.scenario)
        misprobes = parse_misprobes(args.misprobe, plan)
    check_outputs([args.truth_out, args.report], args.force)
    if args.truth_out:
        write_output(args.truth_out, truth.dumps(), force=args.force)

    quiet = bool(args.quiet)

    def say(text: str) -> None:
        if not quiet:
            print(f"aacmm sim: {text}", file=sys.stderr, flush=True)

    stop = threading.Event()
    received: list[int] = []

    def on_signal(signum: int, frame: FrameType | None) -> None:
        received.append(signum)
        stop.set()

    base = _without(
        sim_args,
        (
            "--seed",
            "--motion",
            "--button-every",
            "--cpr",
            "--encoder-bits",
            "--serial-number",
            "--temperature",  # the control channel's temps, below
        ),
    )
    profile = temperature_profile(getattr(args, "temperature", None), truth.joints)
    temps = (
        profile(0.0)
        if profile is not None
        else link_temperatures(getattr(args, "temperature", None), truth.joints)
    )
    base += ["--serial-number", str(truth.device_serial)]  # each true arm is its own device
    chan, fd = ControlChannel.pair()
    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    sim = None
    failure: list[BaseException] = []
    runs: list[Any] = []  # the ScenarioRun, once planned
    died = False
    try:
        try:
            sim = SimProcess(
                [*base, "--cpr", str(cpr), "--control", str(fd)], link=args.link, pass_fds=[fd]
            )
        finally:
            chan.child_started()
        chan.hello()
        if temps is not None:  # before the first counts: every reading at them
            chan.set_temperatures(temps)
            chan.sync()
        for url in sim.urls:
            print(url, flush=True)
        others = publish_urls(sim.urls)
        say(
            f"{sim.binary} running (pid {sim.proc.pid}) with {truth_text(truth, temps)}; "
            "Ctrl-C to stop"
        )
        note_others(others)
        rng = np.random.default_rng(args.seed or 0)
        pace = FAST if args.fast else Pace()
        op = Operator(
            chan,
            truth,
            rng,
            pace,
            limits=limits,
            stop=stop,
            temperatures_c=temps,
            temperatures_at=profile,
        )

        def work() -> None:
            try:
                if plan is None:
                    _wander(args, op, stop, None if model is None else op.theta)
                    return
                _perform(args, plan, op, misprobes, say, runs)
            except Stopped:
                pass
            except BaseException as exc:  # handed to the main thread
                failure.append(exc)
            finally:
                stop.set()

        worker = threading.Thread(target=work, name="aacmm-sim-operator", daemon=True)
        worker.start()
        while not stop.is_set() and sim.running():
            stop.wait(0.2)
        died = not sim.running()
        stop.set()
        worker.join(10.0)
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        chan.close()
        rc = sim.stop() if sim is not None else 0
        unpublish_urls()
        if args.report and runs:
            report = runs[0].report()
            report["truth"] = truth.origin
            report["seed"] = args.seed or 0
            report["fast"] = bool(args.fast)
            write_output(args.report, json.dumps(report, indent=1) + "\n", force=args.force)
    if failure:
        raise failure[0]
    if died and not received:
        raise AacmmError(f"the simulator ended by itself (exit status {rc})")
    return OK


def temperature_profile(text: str | None, joints: int | None = None) -> Any:
    """``--temperature START:END:MINUTES``: the links from START to END degC (each one
    value for every link or one per link, ``C[,C...]``), linearly over MINUTES from the
    operator's start, then at END; a function of the seconds since then giving the
    temperature of every link (``joints`` values; None: the count is not checked yet,
    one list as long as START's or END's). None for another form (a constant
    temperature) or none.

    Raises:
        UsageError: START or END not temperatures within -40 .. 85, or neither one nor
        ``joints`` of them, MINUTES not > 0.
    """
    if text is None or ":" not in text:
        return None
    parts = text.split(":")
    if len(parts) != 3:
        raise UsageError(f"--temperature {text}: a profile is START:END:MINUTES")
    ends = []
    for part, name in zip(parts[:2], ("START", "END"), strict=True):
        n = len(part.split(",")) if joints is None else joints
        values = link_temperatures(part, n, f"--temperature {name}")
        assert values is not None
        ends.append(values)
    start, end = ends
    if len(start) == 1:  # one for every link against one per link
        start = start * len(end)
    elif len(end) == 1:
        end = end * len(start)
    if len(start) != len(end):
        raise UsageError(
            f"--temperature {text}: START and END give {len(start)} and {len(end)} "
            "temperatures; give one for every link or one per link"
        )
    try:
        minutes = float(parts[2])
    except ValueError:
        minutes = math.nan
    if not (math.isfinite(minutes) and 0 < minutes <= 24 * 60):
        raise UsageError(f"--temperature {text}: MINUTES must be in (0, 1440]")
    span_s = minutes * 60.0

    def at(seconds: float) -> list[float]:
        f = min(max(seconds / span_s, 0.0), 1.0)
        return [a + (b - a) * f for a, b in zip(start, end, strict=True)]

    return at


def truth_text(truth: Any, temps: list[float] | None = None) -> str:
    """What ``aacmm sim`` says of its truth: its kind and, when its encoders have a
    reading error, their grade (a random truth's, ``[origin] encoder_grade``; one
    without: two-head) or the harmonic orders a truth file gives them; with ``temps``
    (``--temperature``) the links' temperatures and whether its lengths follow them."""
    from aacmm.simulation.encgrade import DEFAULT_GRADE

    kind = truth.origin.get("kind", "file")
    text = f"a {kind} truth"
    errors = truth.errors
    if kind == "random":
        text += f", encoder grade {truth.origin.get('encoder_grade', DEFAULT_GRADE)}"
    else:
        orders = [k for k, (amp, _) in errors.harmonics_arcsec().items() if max(amp) > 0]
        if orders:
            text += f", encoder harmonics {', '.join(str(k) for k in orders)}"
    if temps is not None:
        lo, hi = min(temps), max(temps)
        at = f"{lo:g} C" if lo == hi else f"{lo:g} .. {hi:g} C"
        text += f", links at {at} " + (
            "(its thermal profile scales the lengths)"
            if truth.thermal is not None
            else "(no thermal profile: the lengths of 20 C)"
        )
    return text


def _without(argv: list[str], options: tuple[str, ...]) -> list[str]:
    out: list[str] = []
    skip = False
    for a in argv:
        if skip:
            skip = False
            continue
        if a in options:
            skip = True
            continue
        out.append(a)
    return out


def _wander(args: argparse.Namespace, op: Any, stop: threading.Event, pose: Any) -> None:
    """The true arm walking, or (``--motion static``) still at ``pose``
    (None: :data:`~aacmm.simulation.run.STATIC_POSE_RAD`, the paper's arm)."""
    from aacmm.simulation.run import STATIC_POSE_RAD, Wander

    if args.motion == "static":
        op.theta = op.limits.canonical(STATIC_POSE_RAD if pose is None else pose)
        op.send_pose(op.theta)
        period = args.button_every
        while not stop.wait(period if period else 0.5):
            if period:
                op.press_and_release(0)
        return
    Wander(op, button_every_s=args.button_every).run()


def _perform(
    args: argparse.Namespace,
    plan: Any,
    op: Any,
    misprobes: tuple[Any, ...],
    say: Any,
    runs: list[Any],
) -> None:
    from aacmm.simulation.run import ScenarioRun
    from aacmm.simulation.scenario import choreograph

    t0 = time.monotonic()
    choreo = choreograph(plan, op.arm, op.rng, op.limits)
    say(
        f"plan {plan.name}: {len(choreo.points)} points, articulations planned in "
        f"{time.monotonic() - t0:.1f} s"
    )
    for step_id, spread in choreo.spread_deg.items():
        say(f"  step {step_id}: joint spread {', '.join(f'{v:.0f}' for v in spread)} deg")
    run = ScenarioRun(
        op,
        choreo,
        plan.sha256,
        follow=Path(args.follow) if args.follow else None,
        misprobes=misprobes,
        say=say,
        say_press=say if args.verbose else None,
    )
    runs.append(run)
    run.run()
    say(f"done: {len(op.presses)} presses, largest IK error "
        f"{max((p.ik_error_mm for p in op.presses), default=0.0):.1e} mm")  # fmt: skip
