"""``aacmm uncertainty``: probe-point uncertainty from parameter uncertainties.

The computation lives in :mod:`aacmm.analysis.uncertainty`; this module
parses the arguments, prints the report and writes the outputs. User errors
(bad arguments, unreadable or invalid files) print one line
``aacmm uncertainty: error: ...`` on stderr and exit with status 2.
"""

from __future__ import annotations

import argparse
from typing import Any

from aacmm.commands.common import add_force_option, print_err
from aacmm.commands.exitcodes import USAGE


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
    un.add_argument("--trials", type=int, default=100_000, help="Monte Carlo trials (1e5)")
    un.add_argument(
        "--workspace",
        type=int,
        default=100,
        help="random workspace poses to add (default 100; 0 = only given poses)",
    )
    un.add_argument(
        "--pose",
        action="append",
        default=[],
        metavar="T1,..,T6",
        help="a pose to report, six joint angles in deg; repeatable",
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
    add_force_option(un)
    un.set_defaults(func=run_uncertainty)


def run_uncertainty(args: argparse.Namespace) -> int:
    """``aacmm uncertainty``: returns the exit status."""
    import json
    from dataclasses import replace

    import numpy as np

    from aacmm.analysis import uncertainty as unc
    from aacmm.errors import AacmmError
    from aacmm.fileio import check_outputs, write_output

    try:
        check_outputs([args.json], args.force)
        spec = unc.load_spec(args.spec)
        if args.pose:
            extra = []
            for text in args.pose:
                try:
                    extra.append([float(v) for v in text.split(",")])
                except ValueError as e:
                    raise ValueError(f"--pose {text!r}: six comma-separated angles in deg") from e
            spec = replace(
                spec, poses_rad=np.concatenate([spec.poses_rad, unc.pose_list(extra, "deg")])
            )
        res = unc.propagate(
            spec,
            trials=args.trials,
            workspace=args.workspace,
            seed=args.seed,
            ndig=args.ndig,
            threads=args.threads,
        )
        print(unc.format_report(res, top=args.top))
        if args.json:
            write_output(args.json, json.dumps(unc.to_json(res), indent=2) + "\n", force=args.force)
    except (AacmmError, ValueError, OSError) as e:
        print_err("uncertainty", f"error: {e}")
        return USAGE
    return 0
