"""``aacmm calibrate``: identify the arm's parameters from capture sessions.

The computation lives in :mod:`aacmm.calibration`; this module reads the
sessions, prints the identifiability report, the solver's progress and the
results, and writes the parameter file (which ``aacmm params set`` loads),
its provenance sidecar and, with ``--report DIR``, the text and JSON reports
and the figures. Bad data (an empty session, a seat with one point, a
session taken with another parameter set or encoder configuration, a damaged
session) end in one line on stderr and exit status 2. Before anything is
written the result goes through its quality gate
(:mod:`aacmm.calibration.gate`): a refused calibration ends in one line, exit
status 9 and no file, unless ``--override`` (recorded in the provenance and
the parameter file). docs/calibration.md.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from aacmm.commands.calibrate_output import (
    crc_hex,
    gate_text,
    probe_text,
    provenance_path,
    recorded_crc,
    step_png,
    summary_text,
    thermal_note,
    write_outputs,
)
from aacmm.commands.common import add_force_option, print_err
from aacmm.commands.exitcodes import CalibrationRefusedError

CMD = "calibrate"


def register(sub: Any) -> None:
    """Add ``calibrate`` to an argparse subparsers object."""
    p = sub.add_parser(
        "calibrate",
        help="identify the arm's parameters from capture sessions (seats, lengths, spheres)",
        description="Calibrate the arm's structural parameters (25 for the paper's arm, the "
        "arm's P for any other, as the sessions' parameter set says) from capture sessions: "
        "identifiability (SVD, named unobservable directions), weighted Levenberg-Marquardt "
        "in the identifiable subspace, covariance, chi-square check, outliers, before/after "
        "figures; writes a parameter file for `aacmm params set` and its provenance.",
    )
    p.add_argument("sessions", nargs="+", metavar="SESSION", help="capture session folders")
    p.add_argument(
        "-o", "--output", required=True, metavar="PARAMS.toml", help="calibrated parameter file"
    )
    p.add_argument(
        "--probe",
        action="store_true",
        help="probe (tip) calibration: only the tip's parameters free (pivot on seats): "
        "theta6, alpha6, d6, a6 and l for the paper's arm, the last joint's and the tip's "
        "for any arm (docs/calibration.md)",
    )
    which = p.add_mutually_exclusive_group()
    which.add_argument(
        "--free",
        action="append",
        metavar="NAMES",
        help="estimate only these parameters (names or groups theta, alpha, d, a, tip; "
        "comma lists, repeatable)",
    )
    which.add_argument(
        "--fix",
        action="append",
        metavar="NAMES",
        help="hold these parameters at their values in force (names or groups)",
    )
    p.add_argument(
        "--sigma-um",
        type=float,
        default=5.0,
        metavar="UM",
        help="probing standard uncertainty per axis of one point, um (default 5)",
    )
    p.add_argument(
        "--strategy",
        choices=("fix", "min-norm"),
        default="fix",
        help="unobservable directions: hold parameters at their start values (fix, default) "
        "or take the minimum-norm change",
    )
    p.add_argument(
        "--reject", action="store_true", help="exclude outliers and solve again (else report)"
    )
    p.add_argument(
        "--harmonics",
        default=None,
        metavar="K",
        help="also estimate encoder angle harmonics c<j>_<k>, s<j>_<k>, k = 1..K on every "
        "joint (K 0..4), or 'auto': per joint the largest K the data identify (stated in "
        "the output, per joint with why); written to the file's [errmodel] table, which "
        "aacmm params set sends to the device. Default auto (0 with --probe)",
    )
    p.add_argument(
        "--thermal",
        choices=("auto", "on", "off"),
        default=None,
        help="also estimate each link's CTE (cte1..cteN, 1/K, reference 20 degC) from the "
        "points' link temperatures (the device's readings, else aacmm capture --temperature): "
        "auto (default; "
        "off with --probe) when they span at least 5 degC, on whatever the span (every point "
        "must state one), off never; written to the file's [errmodel] table (cte_per_k, "
        "tref_c), which aacmm params set sends to a device that reads its link temperatures "
        "(its thermal block) and aacmm verify --params applies",
    )
    p.add_argument(
        "--validate",
        action="append",
        default=[],
        metavar="SESSION",
        help="held-out session: before/after figures on data the fit did not see; repeatable",
    )
    p.add_argument(
        "--kfold", type=int, metavar="K", help="k-fold cross-validation on the sessions (K >= 2)"
    )
    p.add_argument(
        "--base-frame",
        action="store_true",
        help="reference locations in the plan are in the arm's base frame (no registration)",
    )
    p.add_argument(
        "--min-spread-deg",
        type=float,
        default=10.0,
        metavar="DEG",
        help="--probe: least RMS orientation spread of the worst tip direction (default 10)",
    )
    p.add_argument(
        "--report", metavar="DIR", help="write report.txt, report.json and figures (PNG) here"
    )
    p.add_argument(
        "--workspace",
        type=int,
        default=100,
        metavar="N",
        help="random poses for the propagated point uncertainty (default 100; 0: none)",
    )
    gate = p.add_argument_group("quality gate (docs/calibration.md, 'Quality gate')")
    gate.add_argument(
        "--override",
        action="store_true",
        help="write the calibration even if its quality gate refuses it (the provenance "
        "and the parameter file say so)",
    )
    gate.add_argument(
        "--previous",
        metavar="PROVENANCE.json",
        help="the provenance of the calibration that made the set in force: its predicted "
        "accuracy is the bar to beat (default: the -o file's own provenance when -f "
        "replaces it and it made the set in force)",
    )
    gate.add_argument(
        "--max-u-um",
        type=float,
        metavar="UM",
        help="largest standard uncertainty of a length parameter, um (default 50, or 3x the "
        "coarsest encoder's quantisation at the data's lever if that is more)",
    )
    gate.add_argument(
        "--max-u-arcsec",
        type=float,
        metavar="ARCSEC",
        help="largest standard uncertainty of an angle parameter, arcsec (default 20, or 3x "
        "the coarsest encoder's quantisation, 2 pi / counts / sqrt 12, or the angle whose "
        "effect at the data's lever is the length limit, if that is more)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no solver progress on stderr")
    add_force_option(p)
    p.set_defaults(func=run_calibrate)


def _check_args(args: argparse.Namespace) -> None:
    from aacmm.commands.exitcodes import UsageError

    if not (args.sigma_um > 0 and args.sigma_um < 1e6):
        raise UsageError(f"--sigma-um must be a positive number of um, got {args.sigma_um}")
    if args.kfold is not None and args.kfold < 2:
        raise UsageError(f"--kfold needs K >= 2, got {args.kfold}")
    if args.workspace < 0:
        raise UsageError(f"--workspace must be >= 0, got {args.workspace}")
    if args.probe and (args.free or args.fix):
        raise UsageError("--probe sets the free parameters itself: drop --free/--fix")
    from aacmm.calibration.harmonics import check_harmonics_option

    if args.harmonics is None:  # the default: auto, the tip alone with --probe
        args.harmonics = "0" if args.probe else "auto"
    try:
        args.harmonics = check_harmonics_option(args.harmonics)
    except ValueError as exc:
        raise UsageError(f"--harmonics: {exc}") from None
    if args.probe and args.harmonics != "0":
        raise UsageError("--probe calibrates the tip only: drop --harmonics")
    if args.thermal is None:
        args.thermal = "off" if args.probe else "auto"
    if args.probe and args.thermal != "off":
        raise UsageError("--probe calibrates the tip only: drop --thermal")
    if not args.output.lower().endswith(".toml"):
        raise UsageError(f"{args.output}: the parameter file must be a .toml file")
    for opt, v in (("--max-u-um", args.max_u_um), ("--max-u-arcsec", args.max_u_arcsec)):
        if v is not None and not (v > 0 and v < 1e9):
            raise UsageError(f"{opt} must be a positive number, got {v}")


def run_calibrate(args: argparse.Namespace) -> int:
    """``aacmm calibrate``: returns the exit status."""
    # The engine's matrices are tall and thin: OpenBLAS threads only contend
    # (docs/calibration.md). Must be set before numpy loads OpenBLAS.
    if "numpy" not in sys.modules:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    _check_args(args)
    from aacmm.calibration.sessions import load_sessions

    sigma = args.sigma_um / 1000.0
    thermal = args.thermal != "off"
    data = load_sessions(args.sessions, sigma, args.base_frame, temperatures=thermal)
    for warning in data.temperature_warnings:
        print_err("calibrate", f"warning: {warning}")
    if args.thermal == "on" and data.unstated_temperature:
        from aacmm.commands.exitcodes import UsageError

        raise UsageError(
            f"--thermal on: {data.unstated_temperature[0]}: a capture run states no link "
            "temperature (aacmm capture --temperature)"
        )
    held_out = (
        load_sessions(
            args.validate,
            sigma,
            args.base_frame,
            like=data.param_set,
            any_params=True,
            arm=data.sources,
            temperatures=thermal and data.observations.temp_c is not None,
        )
        if args.validate
        else None
    )
    previous = _previous(args, data)
    _check_outputs(args, data.observations.step_names)
    return _calibrate(args, data, held_out, previous)


def _previous(args: argparse.Namespace, data: Any) -> Any:
    """The calibration that made the set in force (:class:`PreviousCalibration`), if known:
    ``--previous FILE`` (an error unless it made that set), else the output's own
    provenance when it is being replaced and made that set."""
    from aacmm.calibration.gate import previous_from_provenance
    from aacmm.commands.exitcodes import UsageError
    from aacmm.fileio import InputFileError, load_json

    explicit = args.previous is not None
    path = Path(args.previous) if explicit else provenance_path(args.output)
    if not explicit and not (args.force and path.is_file()):
        return None
    try:
        prev = previous_from_provenance(load_json(path), str(path), like=data.start)
    except (InputFileError, ValueError) as exc:
        if explicit:
            raise UsageError(f"--previous {exc}") from None
        return None
    crc = crc_hex(prev.params, data.encoders)
    recorded = recorded_crc(load_json(path))  # with its error model, as the device took it
    if data.param_set.crc_hex in (crc, recorded):
        crc = data.param_set.crc_hex
    if crc != data.param_set.crc_hex:
        if explicit:
            raise UsageError(
                f"--previous {path}: its calibration made parameter set {crc}, the sessions "
                f"were taken with {data.param_set.crc_hex}: not the provenance of the set in force"
            )
        return None
    return prev


def _check_outputs(args: argparse.Namespace, step_names: tuple[str, ...]) -> None:
    """Every output checked before the work starts; nothing is created yet (the
    report folder is made when its files are written), so a refusal leaves nothing."""
    from aacmm.fileio import check_output_dir, check_outputs

    check_outputs([Path(args.output), provenance_path(args.output)], args.force)
    if args.report:
        names = ["report.txt", "report.json", "spectrum.png", "correlation.png", "convergence.png"]
        if args.workspace:
            names.append("uncertainty.png")
        names += [step_png(i, n) for i, n in enumerate(step_names)]
        from aacmm.view.html import report_names

        names += report_names()
        check_output_dir(
            args.report, names, args.force, parents=True, what=f"--report {args.report}"
        )


def _progress(args: argparse.Namespace) -> Any:
    if args.quiet:
        return None

    last: dict[str, float] = {"stage": 0.0, "chi2": float("inf")}

    def show(p: Any) -> None:
        # only progress worth a line: a new stage, or chi^2 down by more than 1e-6
        if p.stage == last["stage"] and not p.chi2 < last["chi2"] * (1 - 1e-6):
            return
        last["stage"], last["chi2"] = p.stage, p.chi2
        print_err(
            CMD,
            f"stage {p.stage}, evaluation {p.nfev}: chi^2 {p.chi2:.6g}, "
            f"rms residual {p.rms_mm * 1e3:.2f} um ({p.free} free)",
        )

    return show


def _gate(args: argparse.Namespace, data: Any, res: Any, val: Any, previous: Any) -> Any:
    from aacmm.calibration.gate import (
        ARCSEC_RAD,
        GateLimits,
        SessionState,
        arm_limits,
        assess,
    )

    auto = arm_limits(res, data.encoders.counts_per_rev)
    limits = GateLimits(
        max_u_length_mm=auto.max_u_length_mm if args.max_u_um is None else args.max_u_um / 1e3,
        max_u_angle_rad=(
            auto.max_u_angle_rad if args.max_u_arcsec is None else args.max_u_arcsec * ARCSEC_RAD
        ),
    )
    states = [SessionState(s.path, s.status, s.points, s.plan_points) for s in data.sources]
    gate = assess(res, states, limits, previous, val)
    print()
    print(gate_text(gate, args))
    if not gate.passed and not args.override:
        n = len(gate.refusals)
        more = f" (+{n - 1} more reason{'s' if n > 2 else ''} above)" if n > 1 else ""
        raise CalibrationRefusedError(
            f"refused by the quality gate, nothing written: {gate.refusals[0].message}{more}; "
            "--override writes it anyway"
        )
    return gate


_THERMAL: dict[str, bool | str] = {"auto": "auto", "on": True, "off": False}


def set_in_force(data: Any) -> Any:
    """The fit's start: the sessions' parameter set in force, its error model too (the
    encoder harmonics and link CTEs the device applied: the 'before' figures and the
    quality gate's set in force are what the device computed, and a term the data do
    not measure keeps its value), as a CalibParams; the arm alone without one."""
    from aacmm.calibration.parameters import CalibParams

    errors = data.param_set.errors
    return data.start if errors is None else CalibParams(data.start, errors)


def _calibrate(args: argparse.Namespace, data: Any, held_out: Any, previous: Any = None) -> int:
    from aacmm.calibration import Problem, analyse, parse_names, report
    from aacmm.calibration.parameters import param_names, tip_columns
    from aacmm.calibration.validation import compare, kfold
    from aacmm.commands.exitcodes import UsageError

    obs = data.observations
    print(summary_text(data))
    start = set_in_force(data)
    all_names = param_names(start)  # the arm's own (the paper's 25 for its shape), its errors'
    free = tip_columns(data.start) if args.probe else (tuple(args.free) if args.free else None)
    fix = tuple(args.fix or ())
    names = parse_names(free, start) if free is not None else all_names
    held = set(parse_names(fix, start))
    cand = [all_names.index(n) for n in names if n not in held]
    if not cand:
        raise UsageError("no parameter left free to calibrate")
    ident0 = analyse(Problem(obs).evaluate(start), cand)
    print()
    print(report.format_identifiability(ident0, "Identifiability at the parameters in force"))
    print()
    probe = None
    if args.probe:
        from aacmm.calibration.probe import calibrate_probe

        probe = calibrate_probe(
            obs,
            start,
            min_spread_deg=args.min_spread_deg,
            reject=args.reject,
            progress=_progress(args),
        )
        res = probe.result
    else:
        from aacmm.calibration import calibrate

        res = calibrate(
            obs,
            start,
            free=free,
            fix=fix,
            strategy=args.strategy,
            reject=args.reject,
            progress=_progress(args),
            harmonics=args.harmonics,
            thermal=_THERMAL[args.thermal],
        )
    cmp_ = compare(res.observations, res.start, res.params)
    print(report.format_result(res, cmp_))
    thermal_text = "" if args.probe else thermal_note(args, data, res)
    if thermal_text:
        print(thermal_text)
    if probe is not None:
        print(probe_text(probe))
    val = None
    if held_out is not None:
        val = compare(held_out.observations, res.start, res.params)
        print()
        print(report.format_comparison(val, "Held-out sessions (not used by the fit)"))
    kf = None
    if args.kfold:
        kf = kfold(
            obs,
            start,
            k=args.kfold,
            free=free,
            fix=fix,
            strategy=args.strategy,
            harmonics=args.harmonics,
            thermal=_THERMAL[args.thermal],
        )
        print()
        print(
            report.format_comparison(
                kf.pooled, f"{args.kfold}-fold cross-validation (held-out folds)"
            )
        )
    ures = None
    if args.workspace:
        ures = report.point_uncertainty(res, workspace=args.workspace)
        u3 = sorted(p.u3_lin for p in ures.workspace)
        print()
        print(
            f"Probe-point uncertainty from the calibration alone ({args.workspace} workspace "
            f"poses, k = 1): median {u3[len(u3) // 2] * 1e3:.2f} um, max {u3[-1] * 1e3:.2f} um "
            "(held parameters excluded: they move the whole arm, not distances)"
        )
    gate = _gate(args, data, res, val, previous)
    write_outputs(args, data, held_out, res, cmp_, val, kf, ures, probe, gate)
    if not gate.passed:
        print_err(
            CMD,
            "warning: written with --override although the quality gate refused it: "
            f"{gate.refusals[0].message}",
        )
    if not res.chi_square.consistent:
        print_err(CMD, f"warning: {res.chi_square.describe()}")
    return 0
