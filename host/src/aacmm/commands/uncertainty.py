"""``aacmm uncertainty``: probe-point uncertainty from parameter uncertainties.

The computation lives in :mod:`aacmm.uncertainty`; this module
parses the arguments, prints the report, shows the progress and writes the
outputs. User errors (bad arguments, unreadable or invalid files, an
existing output file without ``--force``, poses that cannot fit in memory)
print one line ``aacmm uncertainty: error: ...`` on stderr and exit with
status 2; a spec or a log of another arm than ``--model`` (a parameter this
arm does not have, a log of another joint count or shape) exits with status
10 (``WRONG_ARM``); Ctrl-C stops a run within a chunk of trials (``aacmm uncertainty:
interrupted``, status 130).
"""

from __future__ import annotations

import argparse
from typing import Any

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


def register(sub: Any) -> None:
    """Add ``uncertainty`` to an argparse subparsers object."""
    un = sub.add_parser(
        "uncertainty",
        help="probe-point uncertainty from parameter uncertainties (Monte Carlo and linear)",
        description="Propagate structural-parameter uncertainties (TOML file) to the probe "
        "point by Monte Carlo (JCGM 101) and by linear propagation J Sigma J^T (GUM); "
        "report both, their agreement, 95 % intervals and the budget.",
    )
    un.add_argument(
        "spec",
        metavar="SPEC.toml",
        help="parameter-uncertainty file "
        "(see docs/montecarlo.md; 'example' uses the packaged example)",
    )
    add_model_option(un, "the nominal arm, whose parameters the spec names")
    un.add_argument("--trials", type=int, default=100_000, help="Monte Carlo trials (1e5)")
    un.add_argument(
        "--workspace",
        type=int,
        default=None,
        help="random workspace poses to add (default 100, with --log 0; 0 = only given poses): "
        "joints uniform in [-180, 180) deg, within the joint limits of another arm model than "
        "the paper's",
    )
    un.add_argument(
        "--pose",
        action="append",
        default=[],
        metavar="T1,..,TN",
        help="a pose to report, the arm's N joint angles in deg (six for the paper's arm); "
        "repeatable",
    )
    un.add_argument(
        "--log",
        metavar="CSV",
        help="also the poses of a measurement log (aacmm log CSV, as mc --log) of the "
        "same arm model",
    )
    un.add_argument(
        "--every",
        type=int,
        default=1,
        metavar="K",
        help="with --log: every K-th logged pose (default 1: all)",
    )
    un.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    un.add_argument(
        "--ndig",
        type=int,
        default=1,
        help="significant digits for the JCGM 101 sec. 8 agreement check (1)",
    )
    un.add_argument("--threads", type=int, default=None, help="worker threads (default: all)")
    un.add_argument("--top", type=int, default=10, help="budget rows to print (10)")
    un.add_argument("--json", metavar="PATH", help="write the result as JSON")
    un.add_argument("--csv", metavar="PATH", help="write every pose and axis as CSV")
    un.add_argument(
        "--png",
        metavar="PATH",
        help="write a figure: MC vs linear per pose, the spread over the poses, the budget",
    )
    add_force_option(un)
    add_run_limit_options(un, "the trials")
    un.set_defaults(func=run_uncertainty)


class _Progress:
    """The run's estimate and progress (:class:`RunProgress`); the library reports
    its total (trials x poses, each pass counted) with every chunk."""

    def __init__(self, args: argparse.Namespace, limit_s: float) -> None:
        self.args = args
        self.limit_s = limit_s
        self.run: RunProgress | None = None

    def update(self, n: int, total: int) -> None:
        if self.run is None:
            from aacmm.uncertainty.runlimits import format_count

            self.run = RunProgress(
                "uncertainty",
                total,
                "trial-poses",
                show=self.args.progress,
                limit_s=self.limit_s,
                what=f"--trials {format_count(self.args.trials)}",
                hint="use fewer --trials or poses (or a larger --max-hours)",
            )
        self.run.update(n)

    def close(self) -> None:
        if self.run is not None:
            self.run.close()


def run_uncertainty(args: argparse.Namespace) -> int:
    """``aacmm uncertainty``: returns the exit status."""
    import json
    from dataclasses import replace

    import numpy as np

    from aacmm import uncertainty as unc
    from aacmm.arm import Arm
    from aacmm.errors import AacmmError
    from aacmm.fileio import atomic_output, check_outputs, save_figure, write_output

    bar: _Progress | None = None
    try:
        bar = _Progress(args, max_run_seconds(args))
        check_outputs([args.json, args.csv, args.png], args.force)
        model = model_arm(args)
        n = model.n_joints
        if args.model is None:  # the paper's arm, as before issue 26
            spec = unc.load_spec(args.spec)
        else:
            spec = unc.load_spec(args.spec, model.arm, model.name)
        extra = [spec.poses_rad]
        if args.pose:
            given = []
            for text in args.pose:
                try:
                    given.append([float(v) for v in text.split(",")])
                except ValueError as e:
                    raise ValueError(f"--pose {text!r}: {n} comma-separated angles in deg") from e
            try:
                extra.append(unc.pose_list(given, "deg", n))
            except ValueError as e:
                raise ValueError(f"--pose: {e} (model {model.name})") from None
        if args.every < 1:
            raise ValueError(f"--every must be >= 1, got {args.every}")
        if args.log is not None:
            from aacmm.analysis.poselog import read_pose_log
            from aacmm.core import Params

            log = read_pose_log(args.log)
            if log.params is not None:
                log_arm = log.params.to_arm() if isinstance(log.params, Params) else log.params
                check_log_arm(f"log {args.log}", log_arm, model)
            elif log.theta_rad.shape[1] != n:
                raise WrongArmError(
                    f"log {args.log} has {log.theta_rad.shape[1]} joint columns, model "
                    f"{model.name} {n} joints: give the log's model with --model"
                )
            extra.append(log.theta_rad[:: args.every])
        elif args.every != 1:
            raise ValueError("--every needs --log")
        spec = replace(spec, poses_rad=np.concatenate(extra))
        workspace = args.workspace
        if workspace is None:
            workspace = 0 if args.log is not None else unc.DEFAULT_WORKSPACE
        res = unc.propagate(
            spec,
            trials=args.trials,
            workspace=workspace,
            seed=args.seed,
            ndig=args.ndig,
            threads=args.threads,
            progress=bar.update,
            # another arm than the paper's: its workspace poses within its joint limits
            joint_ranges_rad=None if model.arm == Arm.paper() else model.sampling_ranges_rad(),
        )
        bar.close()
        # the files first: a closed stdout (uncertainty | head) must not cost them
        if args.json:
            write_output(args.json, json.dumps(unc.to_json(res), indent=2) + "\n", force=args.force)
        if args.csv:
            with atomic_output(args.csv, force=args.force, newline="") as f:
                f.write(unc.csv_text(res))
        if args.png:
            save_figure(unc.figure(res), args.png, force=args.force, dpi=120)
        print(unc.format_report(res, top=args.top), flush=True)
    except BrokenPipeError:
        raise
    except (unc.ArmParameterError, WrongArmError) as e:
        print_err("uncertainty", f"error: {e}")
        return WRONG_ARM
    except (AacmmError, ValueError, OSError) as e:
        print_err("uncertainty", f"error: {e}")
        return USAGE
    finally:
        if bar is not None:
            bar.close()
    return 0
