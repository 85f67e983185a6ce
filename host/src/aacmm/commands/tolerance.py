"""``aacmm tolerance``: the cost-optimal tolerance of every part for a target accuracy.

The computation lives in :mod:`aacmm.analysis.tolerance`; this module parses
the arguments, prints the report and writes the outputs (refusing existing
files unless ``--force``). Exit status: 0 (the Monte Carlo check confirms the
target), 7 (it does not; the report is still written), 8 (no allocation can
meet the target: one line says what limits it), 2 (a bad spec or argument:
one line naming the file and field), 10 (a spec naming a parameter the arm
of ``--model`` does not have: a spec of another arm).

Any arm (issue 26): ``--model NAME|FILE`` allocates that arm model's
parameters and encoders (default gao2013, the paper's arm).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from aacmm.commands.common import (
    RunProgress,
    add_force_option,
    add_model_option,
    add_run_limit_options,
    max_run_seconds,
    model_arm,
)

EXAMPLE = "example"


def register(sub: Any) -> None:
    """Add ``tolerance`` to an argparse subparsers object."""
    p = sub.add_parser(
        "tolerance",
        help="cost-optimal tolerances and encoders for a target accuracy",
        description="Allocate tolerances to the structural parameters (25 for the paper's "
        "arm; those of the arm model of --model) and choose an "
        "encoder per joint so that the probe point (or a length) meets a target accuracy "
        "at the least cost, then check the allocation by Monte Carlo (docs/tolerance.md).",
    )
    p.add_argument(
        "spec",
        metavar="SPEC.toml",
        help=f"tolerance spec (docs/tolerance.md); '{EXAMPLE}' runs the packaged worked "
        "example (on the paper's arm, or on the arm of --model)",
    )
    add_model_option(p, "the arm whose parameters and encoders are allocated")
    p.add_argument(
        "--trials",
        type=int,
        default=100_000,
        metavar="N",
        help="arms drawn for the Monte Carlo check (default 100000; 0 = no check)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the Monte Carlo check (0)")
    p.add_argument(
        "--check-rows",
        type=int,
        default=None,
        metavar="K",
        help="check only the K poses (or lengths) with the highest design value "
        "(default: all of them)",
    )
    p.add_argument("--threads", type=int, default=None, help="worker threads (default: all)")
    p.add_argument("--json", metavar="PATH", help="write the result as JSON")
    p.add_argument("--csv", metavar="PATH", help="write the tolerances and budget as CSV")
    p.add_argument("--png", metavar="PATH", help="write a figure of the budget (PNG)")
    p.add_argument("-q", "--quiet", action="store_true", help="print only the summary lines")
    add_run_limit_options(p, "the Monte Carlo check")
    add_force_option(p)
    p.set_defaults(func=run_tolerance)


def _load(name: str, args: argparse.Namespace) -> Any:
    """The spec, for the arm of ``--model`` (the paper's without).

    Raises:
        WrongArmError: the spec names a parameter this arm does not have.
        SpecError, ModelError: a bad spec or model (exit status 2).
    """
    from importlib import resources

    from aacmm.analysis import tolerance as tl
    from aacmm.arm import Arm
    from aacmm.commands.exitcodes import WrongArmError
    from aacmm.uncertainty.spec import ArmParameterError

    arm, model, limits = None, None, None
    if args.model is not None:
        m = model_arm(args)
        arm, model = m.arm, m.name
        if m.arm != Arm.paper():  # random poses within the arm's own joint limits
            limits = m.joint_limits_rad
    try:
        if name == EXAMPLE:
            from aacmm.fileio import loads_toml

            src = resources.files("aacmm").joinpath("data", "example_tolerance.toml")
            text = loads_toml(src.read_text("utf-8"), "example_tolerance.toml")
            spec = tl.parse_spec(text, None, arm, model, limits)
            from dataclasses import replace

            what = "the paper's arm" if model is None else f"model {model}"
            return replace(spec, source=f"packaged example ({what})")
        return tl.load_spec(name, arm, model, limits)
    except ArmParameterError as e:
        raise WrongArmError(str(e)) from None


def run_tolerance(args: argparse.Namespace) -> int:
    """``aacmm tolerance``: returns the exit status (errors raise; aacmm.cli prints them)."""
    import json

    from aacmm.commands.exitcodes import NOT_MET, UsageError
    from aacmm.fileio import check_outputs, write_output

    if args.trials != 0 and args.trials < 100:
        raise UsageError(f"--trials must be 0 (no check) or >= 100, got {args.trials}")
    if args.check_rows is not None and args.check_rows < 1:
        raise UsageError(f"--check-rows must be >= 1, got {args.check_rows}")
    if args.seed < 0:
        raise UsageError(f"--seed must be >= 0, got {args.seed}")
    if args.threads is not None and args.threads < 1:
        raise UsageError(f"--threads must be >= 1, got {args.threads}")
    limit_s = max_run_seconds(args)
    check_outputs([args.json, args.csv, args.png], args.force)

    from aacmm.analysis import tolerance as tl

    spec = _load(args.spec, args)
    if args.trials:
        tl.check_memory_limit(spec, args.trials, args.check_rows)  # before the allocation
    alloc = tl.allocate(spec)
    check = None
    if args.trials:
        from aacmm.uncertainty.runlimits import format_count

        rows = alloc.design.limit_mm.size
        if args.check_rows is not None:
            rows = min(rows, args.check_rows)
        work = args.trials * rows
        bar = RunProgress(
            "tolerance",
            work,
            "arm-rows",
            show=args.progress,
            limit_s=limit_s,
            what=f"the Monte Carlo check of {format_count(args.trials)} arms",
            hint="use fewer --trials or --check-rows (or a larger --max-hours)",
        )
        bar.preset(tl.estimate_check_seconds(alloc, args.trials, args.check_rows, args.threads))
        done = [0.0]

        def progress(fraction: float) -> None:
            bar.update(fraction * work - done[0])
            done[0] = fraction * work

        try:
            check = tl.monte_carlo_check(
                alloc,
                trials=args.trials,
                seed=args.seed,
                rows=args.check_rows,
                threads=args.threads,
                progress=progress,
            )
        finally:
            bar.close()
    text = tl.format_report(alloc, check)
    if args.quiet:
        text = "\n".join(tl.summary_lines(alloc, check))
    # the files first: a closed stdout (tolerance | head) must not cost them
    if args.json:
        write_output(
            args.json, json.dumps(tl.to_json(alloc, check), indent=2) + "\n", force=args.force
        )
    if args.csv:
        write_output(args.csv, tl.to_csv(alloc), force=args.force)
    if args.png:
        write_output(args.png, tl.budget_png(alloc), force=args.force)
    print(text, flush=True)
    if check is not None and check.verdict == "not met":
        print(
            "aacmm tolerance: the Monte Carlo check does not confirm the target (report written)",
            file=sys.stderr,
        )
        return NOT_MET
    return 0
