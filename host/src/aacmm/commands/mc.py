"""``aacmm mc``: Monte Carlo error-transfer coefficients (the paper's Table 2).

Any arm (issue 26): ``--model NAME|FILE`` computes the coefficients of
another arm model (its own, printed and written; the paper's Table 2 is
compared only for the paper's arm, gao2013, the default); ``--log`` takes
the arm from the log's sidecar, and refuses (one line, exit status 10) a
log of another arm than ``--model``.

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
from typing import TYPE_CHECKING, Any

from aacmm.commands.common import (
    RunProgress,
    add_force_option,
    add_model_option,
    add_run_limit_options,
    check_log_arm,
    max_run_seconds,
    model_arm,
    print_err,
)
from aacmm.commands.exitcodes import USAGE, WRONG_ARM, WrongArmError

if TYPE_CHECKING:
    from aacmm.arm import Arm
    from aacmm.core import Params
    from aacmm.models import ArmModel


def _joint_index(text: str, joints: int = 6) -> list[int]:
    if text == "all":
        return list(range(joints))
    try:
        j = int(text)
    except ValueError:
        j = 0
    if not 1 <= j <= joints:
        raise ValueError(f"joint must be 1..{joints} or 'all', got {text!r}")
    return [j - 1]


def register(sub: Any) -> None:
    """Add ``mc`` to an argparse subparsers object."""
    mc = sub.add_parser(
        "mc",
        help="Monte Carlo error-transfer coefficients (the paper's Table 2)",
        description="Average |error transfer coefficient| (Jacobian entries, from the "
        "firmware's C core) over random or logged poses, beside the paper's Table 2 "
        "(the paper's arm; another arm model: its own coefficients).",
    )
    add_model_option(
        mc, "the arm whose coefficients are computed (with --log: checked against the log's arm)"
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
        help="joint J (1..N or all) uniform in [LOW, HIGH) deg; repeatable "
        "(default: all joints uniform in [-180, 180); another arm model than the paper's: "
        "within its joint limits, [-180, 180) for a joint without limits)",
    )
    mc.add_argument(
        "--normal",
        nargs=3,
        action="append",
        default=[],
        metavar=("J", "MEAN", "SD"),
        help="joint J (1..N or all) normal with MEAN and SD in deg; repeatable",
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
        help="use the poses of a measurement log (aacmm log CSV) instead of random, "
        "with the arm of its sidecar",
    )
    mc.add_argument("--threads", type=int, default=None, help="worker threads (default: all cores)")
    mc.add_argument(
        "--csv", metavar="PATH", help="write all 3 x P coefficients as CSV (75 for the paper's)"
    )
    mc.add_argument("--json", metavar="PATH", help="write the result as JSON")
    mc.add_argument("--png", metavar="PATH", help="write a figure of the coefficients (PNG)")
    mc.add_argument("-q", "--quiet", action="store_true", help="no terminal table")
    add_force_option(mc)
    add_run_limit_options(mc, "the poses")
    mc.set_defaults(func=run_mc)


def _joints(args: argparse.Namespace, model: ArmModel) -> Any:
    """The joint distributions of ``--range``/``--normal`` for the arm of ``model``:
    by default every joint uniform in [-180, 180) deg on the paper's arm (Table 2),
    within the model's joint limits on another arm (:meth:`ArmModel.sampling_ranges_rad`)."""
    from aacmm.analysis.mc_poses import JointDistribution, joint_distributions, limit_distributions
    from aacmm.arm import Arm

    joints = model.n_joints
    if model.arm == Arm.paper():
        js = list(joint_distributions(None, joints))
    else:
        js = list(limit_distributions(model.sampling_ranges_rad()))
    for j, lo, hi in args.range:
        for i in _joint_index(j, joints):
            js[i] = JointDistribution.uniform(math.radians(float(lo)), math.radians(float(hi)))
    for j, mu, sd in args.normal:
        for i in _joint_index(j, joints):
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
        model = model_arm(args)
        params, name = _nominal(model, args.model is not None)
        if args.log is not None:
            if args.adaptive or args.range or args.normal or args.seed is not None:
                raise ValueError(
                    "--log takes its poses from the log: no --adaptive, --range, --normal or --seed"
                )
            from aacmm.analysis.poselog import read_pose_log

            log = read_pose_log(args.log)
            log_params, name = _log_arm(args, log.params, log.theta_rad.shape[1], model)
            bar = _progress(args, log.theta_rad.shape[0], limit_s, f"mc --log {args.log}")
            res = mc.coefficients_over_poses(
                log.theta_rad,
                params=log_params if log_params is not None else params,
                threads=args.threads,
                source=f"log {args.log}",
                progress=None if bar is None else bar.update,
                model_name=name,
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
                joints=_joints(args, model),
                seed=args.seed,
                params=params,
                threads=args.threads,
                progress=None if bar is None else bar.update,
                model_name=name,
            )
        else:
            if args.ndig is not None or args.tol is not None:
                raise ValueError("--ndig and --tol need --adaptive")
            joints = _joints(args, model)
            bar = _progress(args, args.poses, limit_s, f"-n {format_count(args.poses)}")
            res = mc.error_transfer_coefficients(
                args.poses,
                joints=joints,
                seed=args.seed,
                params=params,
                threads=args.threads,
                progress=None if bar is None else bar.update,
                model_name=name,
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
    except WrongArmError as e:
        print_err("mc", f"error: {e}")
        return WRONG_ARM
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


def _nominal(model: ArmModel, given: bool) -> tuple[Arm | None, str | None]:
    """The arm to compute with (None: the paper's, as before issue 26) and its name."""
    from aacmm.arm import Arm

    if model.arm == Arm.paper():
        return None, (model.name if given else None)
    return model.arm, model.name


def _log_arm(
    args: argparse.Namespace, logged: Params | Arm | None, columns: int, model: ArmModel
) -> tuple[Params | Arm | None, str | None]:
    """The arm of a log's poses (its sidecar's; None: the model's) and the model name.

    Raises:
        WrongArmError: with ``--model``, a log of another arm; without a sidecar
            arm, joint columns other than the model's joints.
    """
    from aacmm.core import Params

    if logged is None:
        if columns != model.n_joints:
            raise WrongArmError(
                f"log {args.log} has {columns} joint columns and no arm in a sidecar; "
                f"model {model.name} has {model.n_joints} joints: give the log's model with --model"
            )
        return None, _nominal(model, args.model is not None)[1]
    arm = logged.to_arm() if isinstance(logged, Params) else logged
    if args.model is not None:
        check_log_arm(f"log {args.log}", arm, model)
        return logged, model.name
    # no --model: the log's own arm (an arm of the paper's shape: Table 2, as before)
    return logged, None


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
