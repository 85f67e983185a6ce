"""``aacmm mc``: Monte Carlo error-transfer coefficients (the paper's Table 2).

The computation lives in :mod:`aacmm.analysis.mc`; this module parses the
arguments, prints the report and writes the outputs. Heavy imports (numpy,
the C core, matplotlib) happen only when the command runs, so the other
commands start fast. User errors (bad arguments, unreadable files, an
existing output file without ``--force``) print one line
``aacmm mc: error: ...`` on stderr and exit with status 2; Ctrl-C stops a run
within a chunk's time (``aacmm mc: interrupted``, status 130).
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from aacmm.commands.common import (
    RunProgress,
    add_force_option,
    add_run_limit_options,
    max_run_seconds,
    print_err,
)
from aacmm.commands.exitcodes import USAGE


def _joint_index(text: str) -> list[int]:
    if text == "all":
        return list(range(6))
    try:
        j = int(text)
    except ValueError:
        j = 0
    if not 1 <= j <= 6:
        raise ValueError(f"joint must be 1..6 or 'all', got {text!r}")
    return [j - 1]


def register(sub: Any) -> None:
    """Add ``mc`` to an argparse subparsers object."""
    mc = sub.add_parser(
        "mc",
        help="Monte Carlo error-transfer coefficients (the paper's Table 2)",
        description="Average |error transfer coefficient| (Jacobian entries, from the "
        "firmware's C core) over random or logged poses, beside the paper's Table 2.",
    )
    mc.add_argument(
        "-n",
        "--poses",
        type=int,
        default=10_000,
        metavar="N",
        help="number of random poses (default 10000, as the paper)",
    )
    mc.add_argument(
        "--seed",
        type=int,
        default=None,
        help="random seed (default: a fresh one, printed for reproduction)",
    )
    mc.add_argument(
        "--range",
        nargs=3,
        action="append",
        default=[],
        metavar=("J", "LOW", "HIGH"),
        help="joint J (1..6 or all) uniform in [LOW, HIGH) deg; repeatable "
        "(default: all joints uniform in [-180, 180))",
    )
    mc.add_argument(
        "--normal",
        nargs=3,
        action="append",
        default=[],
        metavar=("J", "MEAN", "SD"),
        help="joint J (1..6 or all) normal with MEAN and SD in deg; repeatable",
    )
    mc.add_argument(
        "--adaptive",
        action="store_true",
        help="adaptive Monte Carlo (JCGM 101 7.9): draw runs of --block poses "
        "until every coefficient is stable to the tolerance",
    )
    mc.add_argument(
        "--ndig",
        type=int,
        default=None,
        help="adaptive: significant digits that must be stable (default 2)",
    )
    mc.add_argument(
        "--tol",
        type=float,
        default=None,
        metavar="DELTA",
        help="adaptive: absolute numerical tolerance in mm/rad instead of --ndig",
    )
    mc.add_argument("--block", type=int, default=10_000, help="adaptive: poses per run (10000)")
    mc.add_argument(
        "--max-trials",
        type=int,
        default=100_000_000,
        help="adaptive: stop after this many poses (default 1e8)",
    )
    mc.add_argument(
        "--log",
        metavar="CSV",
        help="use the poses of a measurement log (aacmm log CSV) instead of random",
    )
    mc.add_argument("--threads", type=int, default=None, help="worker threads (default: all cores)")
    mc.add_argument("--csv", metavar="PATH", help="write all 75 coefficients as CSV")
    mc.add_argument("--json", metavar="PATH", help="write the result as JSON")
    mc.add_argument("--png", metavar="PATH", help="write a figure of the coefficients (PNG)")
    mc.add_argument("-q", "--quiet", action="store_true", help="no terminal table")
    add_force_option(mc)
    add_run_limit_options(mc, "the poses")
    mc.set_defaults(func=run_mc)


def _joints(args: argparse.Namespace) -> Any:
    from aacmm.analysis.mc_poses import DEFAULT_JOINTS, JointDistribution

    js = list(DEFAULT_JOINTS)
    for j, lo, hi in args.range:
        for i in _joint_index(j):
            js[i] = JointDistribution.uniform(math.radians(float(lo)), math.radians(float(hi)))
    for j, mu, sd in args.normal:
        for i in _joint_index(j):
            js[i] = JointDistribution.normal(math.radians(float(mu)), math.radians(float(sd)))
    return js


def run_mc(args: argparse.Namespace) -> int:
    """``aacmm mc``: returns the exit status."""
    import json

    from aacmm.analysis import mc
    from aacmm.analysis.mc_report import csv_text, figure, format_report, to_json
    from aacmm.errors import AacmmError
    from aacmm.fileio import atomic_output, check_outputs, save_figure, write_output
    from aacmm.uncertainty.runlimits import format_count

    bar: RunProgress | None = None
    try:
        limit_s = max_run_seconds(args)
        check_outputs([args.csv, args.json, args.png], args.force)
        if args.log is not None:
            if args.adaptive or args.range or args.normal or args.seed is not None:
                raise ValueError(
                    "--log takes its poses from the log: no --adaptive, --range, --normal or --seed"
                )
            from aacmm.analysis.poselog import read_pose_log

            log = read_pose_log(args.log)
            bar = _progress(args, log.theta_rad.shape[0], limit_s, f"mc --log {args.log}")
            res = mc.coefficients_over_poses(
                log.theta_rad,
                params=log.params,
                threads=args.threads,
                source=f"log {args.log}",
                progress=None if bar is None else bar.update,
            )
        elif args.adaptive:
            if args.tol is not None and args.ndig is not None:
                raise ValueError("give --ndig or --tol, not both")
            bar = _progress(
                args,
                args.max_trials,
                limit_s,
                f"an adaptive run of up to {format_count(args.max_trials)} poses (--max-trials)",
            )
            res = mc.error_transfer_coefficients_adaptive(
                ndig=None if args.tol is not None else (2 if args.ndig is None else args.ndig),
                tolerance=args.tol,
                block=args.block,
                max_trials=args.max_trials,
                joints=_joints(args),
                seed=args.seed,
                threads=args.threads,
                progress=None if bar is None else bar.update,
            )
        else:
            if args.ndig is not None or args.tol is not None:
                raise ValueError("--ndig and --tol need --adaptive")
            joints = _joints(args)
            bar = _progress(args, args.poses, limit_s, f"-n {format_count(args.poses)}")
            res = mc.error_transfer_coefficients(
                args.poses,
                joints=joints,
                seed=args.seed,
                threads=args.threads,
                progress=None if bar is None else bar.update,
            )
        if bar is not None:
            bar.close()
            bar = None
        # the files first: a closed stdout (mc | head) must not cost them
        if args.csv:
            with atomic_output(args.csv, force=args.force, newline="") as f:
                f.write(csv_text(res))
        if args.json:
            write_output(args.json, json.dumps(to_json(res), indent=2) + "\n", force=args.force)
        if args.png:
            save_figure(figure(res), args.png, force=args.force, dpi=120)
        if not args.quiet:
            print(format_report(res), flush=True)
    except BrokenPipeError:
        raise
    except (AacmmError, ValueError, OSError) as e:
        print_err("mc", f"error: {e}")
        return USAGE
    finally:
        if bar is not None:
            bar.close()
    if res.converged is False:
        print_err("mc", "warning: adaptive run did not converge within --max-trials")
        return 1
    return 0


def _progress(
    args: argparse.Namespace, total: int, limit_s: float, what: str
) -> RunProgress | None:
    """The run's estimate and progress (None for a count the library refuses itself)."""
    if total <= 0:
        return None
    return RunProgress(
        "mc",
        total,
        "poses",
        show=args.progress,
        limit_s=limit_s,
        what=what,
        hint="use fewer poses (or a larger --max-hours)",
    )
