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
        "sessions' stated link temperatures (aacmm capture --temperature): auto (default; "
        "off with --probe) when they span at least 5 degC, on whatever the span (every point "
        "must state one), off never; written to the file's [errmodel] table (cte_per_k, "
        "tref_c), which aacmm params set refuses (the device takes no thermal block) and "
        "aacmm verify --params applies",
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


def provenance_path(output: str) -> Path:
    """The provenance sidecar of a parameter file: ``params.toml`` -> ``params.provenance.json``."""
    p = Path(output)
    return p.with_name(p.stem + ".provenance.json")


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
    if args.thermal == "on" and data.unstated_temperature:
        from aacmm.commands.exitcodes import UsageError

        raise UsageError(
            f"--thermal on: {data.unstated_temperature[0]}: a capture run states no link "
            "temperature (aacmm capture --temperature)"
        )
    if data.param_set.errors is not None:  # not carried into the fit's start yet
        print_err(
            "calibrate",
            f"warning: the sessions were taken with parameter set {data.param_set.crc_hex}, "
            f"whose {data.param_set.errmodel_text()} the fit does not start from: its "
            "'before' figures and the quality gate's set in force are its arm alone",
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
    crc = _crc_hex(prev.params, data.encoders)
    recorded = _recorded_crc(load_json(path))  # with its error model, as the device took it
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


def _crc_hex(params: Any, encoders: Any, errors: Any = None) -> str:
    """The CRC of the set the device holds for an arm's ``params`` with ``encoders`` and
    the encoder harmonics ``errors`` (an ErrorModel, or None)."""
    from aacmm.records import ParamSetRecord

    rec = ParamSetRecord(0, params, encoders, errors)
    return str(ParamSetRecord.from_device(rec.to_device()).crc_hex)


def _recorded_crc(prov: Any) -> str | None:
    """A provenance's ``arm.calibrated_param_crc32`` (None if absent)."""
    arm = prov.get("arm") if isinstance(prov, dict) else None
    crc = arm.get("calibrated_param_crc32") if isinstance(arm, dict) else None
    return crc if isinstance(crc, str) else None


def _check_outputs(args: argparse.Namespace, step_names: tuple[str, ...]) -> None:
    """Every output checked before the work starts; nothing is created yet (the
    report folder is made when its files are written), so a refusal leaves nothing."""
    from aacmm.fileio import check_output_dir, check_outputs

    check_outputs([Path(args.output), provenance_path(args.output)], args.force)
    if args.report:
        names = ["report.txt", "report.json", "spectrum.png", "correlation.png", "convergence.png"]
        if args.workspace:
            names.append("uncertainty.png")
        names += [_step_png(i, n) for i, n in enumerate(step_names)]
        from aacmm.view.html import report_names

        names += report_names()
        check_output_dir(
            args.report, names, args.force, parents=True, what=f"--report {args.report}"
        )


def _step_png(step: int, name: str) -> str:
    """``residuals-step01-cone1.png`` for step index 0: numbered from 1, as the reports."""
    safe = "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in name)
    return f"residuals-step{step + 1:02d}{'-' + safe if safe else ''}.png"


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


def _summary(data: Any) -> str:
    from collections import Counter

    obs = data.observations
    kinds = Counter(type(c).__name__ for c in obs.constraints)
    lines = [f"Calibration data ({obs.n_poses} points):"]
    lines.append(f"  arm: {_arm_text(data)}")
    for s in data.sources:
        unused = f"; not used: {', '.join(s.unused_steps)}" if s.unused_steps else ""
        of = f" of {s.plan_points}" if s.plan_points and s.plan_points != s.points else ""
        lines.append(
            f"  {s.path}: plan {s.plan}, {s.points}{of} points, {s.status}, parameter set "
            f"{s.param_set.crc_hex}{unused}"
        )
    label = {
        "Cone": "seats",
        "LengthSet": "calibrated lengths",
        "ReferencePoints": "reference sets",
        "Sphere": "spheres",
        "Plane": "planes",
    }
    lines.append(
        "  constraints: "
        + ", ".join(f"{n} {label.get(k, k)}" for k, n in sorted(kinds.items()))
        + f"; probing uncertainty {obs.sigma_mm[0] * 1e3:g} um per axis"
    )
    return "\n".join(lines)


def _arm_text(data: Any) -> str:
    serial = data.serial_number
    fw = data.firmware
    ps = data.param_set
    shape = "" if ps.is_paper_shape else f" (an arm of {ps.describe()})"  # issue 26
    return (
        f"device serial {serial if serial is not None else '(not recorded)'}, firmware "
        f"{fw or '(not recorded)'}, parameter set in force {ps.crc_hex}{shape}"
    )


def _gate_text(gate: Any, args: argparse.Namespace) -> str:
    from aacmm.calibration.gate import ARCSEC_RAD, GateLimits

    lines = ["Quality gate:", f"  {gate.prediction.describe()}"]
    lim, default = gate.limits, GateLimits()
    if (lim.max_u_length_mm, lim.max_u_angle_rad) != (
        default.max_u_length_mm,
        default.max_u_angle_rad,
    ):
        lines.append(
            f"  uncertainty limits: {lim.max_u_length_mm * 1e3:.3g} um, "
            f'{lim.max_u_angle_rad / ARCSEC_RAD:.3g}" (defaults {default.max_u_length_mm * 1e3:g} '
            f'um, {default.max_u_angle_rad / ARCSEC_RAD:g}"; '
            + (
                "as given"
                if args.max_u_um is not None or args.max_u_arcsec is not None
                else "widened for this arm's encoders and lever"
            )
            + ")"
        )
    if gate.passed:
        lines.append(
            "  passed: sessions complete, rank, parameter uncertainties, correlations, "
            "predicted accuracy" + (", held-out sessions" if args.validate else "")
        )
        return "\n".join(lines)
    what = "written anyway (--override)" if args.override else "nothing written"
    lines.append(f"  REFUSED ({what}):")
    lines += [f"    [{r.check}] {r.message}" for r in gate.refusals]
    return "\n".join(lines)


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
    print(_gate_text(gate, args))
    if not gate.passed and not args.override:
        n = len(gate.refusals)
        more = f" (+{n - 1} more reason{'s' if n > 2 else ''} above)" if n > 1 else ""
        raise CalibrationRefusedError(
            f"refused by the quality gate, nothing written: {gate.refusals[0].message}{more}; "
            "--override writes it anyway"
        )
    return gate


_THERMAL: dict[str, bool | str] = {"auto": "auto", "on": True, "off": False}


def _thermal_text(args: argparse.Namespace, data: Any, res: Any) -> str:
    """Whether the link CTEs were estimated (and which), or why not."""
    from aacmm.calibration.parameters import error_model

    if data.unstated_temperature:
        why = (
            f"link CTEs: not estimated ({data.unstated_temperature[0]}: a capture run states "
            "no link temperature)"
        )
    else:  # the notes said it already when the sessions state temperatures
        why = "" if res.thermal in res.notes else res.thermal
    em = error_model(res.params)
    if em is not None and em.cte_columns:
        why += (
            "written to the file's [errmodel] table (cte_per_k, tref_c): aacmm verify "
            "--params applies them; aacmm params set refuses the file (the device takes no "
            "thermal block)"
        )
    if not why:
        return ""
    return f"Thermal (--thermal {args.thermal}): {why}"


def _calibrate(args: argparse.Namespace, data: Any, held_out: Any, previous: Any = None) -> int:
    from aacmm.calibration import Problem, analyse, parse_names, report
    from aacmm.calibration.parameters import param_names, tip_columns
    from aacmm.calibration.validation import compare, kfold
    from aacmm.commands.exitcodes import UsageError

    obs = data.observations
    print(_summary(data))
    all_names = param_names(data.start)  # the arm's own (the paper's 25 for its shape)
    free = tip_columns(data.start) if args.probe else (tuple(args.free) if args.free else None)
    fix = tuple(args.fix or ())
    names = parse_names(free, data.start) if free is not None else all_names
    held = set(parse_names(fix, data.start))
    cand = [all_names.index(n) for n in names if n not in held]
    if not cand:
        raise UsageError("no parameter left free to calibrate")
    ident0 = analyse(Problem(obs).evaluate(data.start), cand)
    print()
    print(report.format_identifiability(ident0, "Identifiability at the parameters in force"))
    print()
    probe = None
    if args.probe:
        from aacmm.calibration.probe import calibrate_probe

        probe = calibrate_probe(
            obs,
            data.start,
            min_spread_deg=args.min_spread_deg,
            reject=args.reject,
            progress=_progress(args),
        )
        res = probe.result
    else:
        from aacmm.calibration import calibrate

        res = calibrate(
            obs,
            data.start,
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
    thermal_text = "" if args.probe else _thermal_text(args, data, res)
    if thermal_text:
        print(thermal_text)
    if probe is not None:
        print(_probe_text(probe))
    val = None
    if held_out is not None:
        val = compare(held_out.observations, res.start, res.params)
        print()
        print(report.format_comparison(val, "Held-out sessions (not used by the fit)"))
    kf = None
    if args.kfold:
        kf = kfold(
            obs,
            data.start,
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
    _write(args, data, held_out, res, cmp_, val, kf, ures, probe, gate)
    if not gate.passed:
        print_err(
            CMD,
            "warning: written with --override although the quality gate refused it: "
            f"{gate.refusals[0].message}",
        )
    if not res.chi_square.consistent:
        print_err(CMD, f"warning: {res.chi_square.describe()}")
    return 0


def _probe_text(pr: Any) -> str:
    import numpy as np

    sd = np.sqrt(np.diag(pr.tip_cov))
    t0 = ", ".join(f"{v:.4f}" for v in pr.tip_before)
    t1 = ", ".join(f"{v:.4f}" for v in pr.tip_after)
    return "\n".join(
        [
            "",
            "Probe:",
            f"  tip in the flange frame: ({t0}) -> ({t1}) mm, u = "
            + ", ".join(f"{v * 1e3:.2f}" for v in sd)
            + " um",
            f"  orientation spread {pr.spread_deg:.1f} deg (worst tip direction)",
            f"  RMS pivot error {pr.pivot_rms_before_mm * 1e3:.1f} -> "
            f"{pr.pivot_rms_mm * 1e3:.1f} um (max {pr.pivot_max_mm * 1e3:.1f} um)",
        ]
    )


def _comment(text: str) -> str:
    """``text`` fit for one TOML comment line (a path may hold any character)."""
    return "".join(ch if ch.isprintable() else "?" for ch in text)


def _arm_table(data: Any) -> dict[str, Any]:
    """The parameter file's ``[arm]`` table: whose calibration it is (docs/cli.md)."""
    out: dict[str, Any] = {}
    if data.serial_number is not None:
        out["serial_number"] = data.serial_number
    if data.firmware is not None:
        out["firmware"] = data.firmware
    out["start_param_crc32"] = data.param_set.crc_hex
    return out


def _param_file_text(data: Any, res: Any, args: argparse.Namespace, gate: Any) -> str:
    from aacmm.calibration.parameters import arm_part, error_model
    from aacmm.protocol import param_set_crc32
    from aacmm.records import ParamSetRecord
    from aacmm.records.paramfile import dump_param_set, param_set_dict, param_set_from_mapping

    ps = ParamSetRecord(0, arm_part(res.params), data.encoders).to_device()
    param_set_from_mapping(param_set_dict(ps), args.output)  # the loader's own checks
    sources = _comment(", ".join(s.path for s in data.sources))
    sidecar = _comment(provenance_path(args.output).name)
    head = (
        f"# calibrated by aacmm calibrate from {sources}\n"
        f"# provenance (sessions, residuals, covariance): {sidecar}\n"
    )
    if not gate.passed:
        head += "# WRITTEN WITH --override: the quality gate refused this calibration:\n"
        head += "".join(f"#   [{r.check}] {_comment(r.message)}\n" for r in gate.refusals)
    em = error_model(res.params)
    # the CRC the device will hold: the arm with the harmonics in the wire's units
    crc = param_set_crc32(ParamSetRecord(0, arm_part(res.params), data.encoders, em).to_device())
    return head + dump_param_set(ps, "toml", crc, arm=_arm_table(data), errmodel=em)


def _write(
    args: argparse.Namespace,
    data: Any,
    held_out: Any,
    res: Any,
    cmp_: Any,
    val: Any,
    kf: Any,
    ures: Any,
    probe: Any,
    gate: Any,
) -> None:
    import datetime as dt
    import json

    from aacmm import __version__
    from aacmm import uncertainty as unc
    from aacmm.calibration import report
    from aacmm.calibration.parameters import arm_part, error_model
    from aacmm.fileio import write_output

    text = _param_file_text(data, res, args, gate)
    prov: dict[str, Any] = {
        "format": "aacmm-calibration-1",
        "created_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "aacmm_version": __version__,
        "command": ["aacmm", *sys.argv[1:]] if sys.argv and "calibrate" in sys.argv else None,
        "parameter_file": Path(args.output).name,
        "sessions": [_source_json(s) for s in data.sources],
        "validation_sessions": [_source_json(s) for s in held_out.sources] if held_out else [],
        "arm": {
            "serial_number": data.serial_number,
            "firmware": data.firmware,
            "start_param_crc32": data.param_set.crc_hex,
            "calibrated_param_crc32": _crc_hex(
                arm_part(res.params), data.encoders, error_model(res.params)
            ),
        },
        "start_param_set": data.param_set.to_json(),
        "probing_sigma_mm": args.sigma_um / 1000.0,
        "settings": {
            "probe": args.probe,
            "free": args.free,
            "fix": args.fix,
            "strategy": args.strategy,
            "reject": args.reject,
            "base_frame": args.base_frame,
            "harmonics": args.harmonics,
            "thermal": args.thermal,
        },
        "result": report.to_json(res, cmp_),
        "quality_gate": {
            **gate.to_json(),
            "override": bool(args.override and not gate.passed),
            "previous": args.previous
            or (gate.prediction.previous_source if gate.prediction.previous_source else None),
        },
    }
    if val is not None:
        prov["validation"] = report.comparison_json(val)
    if kf is not None:
        prov["kfold"] = {"k": kf.k, "pooled": report.comparison_json(kf.pooled)}
    if probe is not None:
        prov["probe"] = {
            "tip_before_mm": probe.tip_before.tolist(),
            "tip_after_mm": probe.tip_after.tolist(),
            "tip_covariance_mm2": probe.tip_cov.tolist(),
            "orientation_spread_deg": probe.spread_deg,
            "pivot_rms_before_mm": probe.pivot_rms_before_mm,
            "pivot_rms_mm": probe.pivot_rms_mm,
            "pivot_max_mm": probe.pivot_max_mm,
        }
    if ures is not None:
        prov["point_uncertainty"] = unc.to_json(ures)
    if args.report:  # first: the parameter file, written last, says the job is done
        _write_report(args, data, res, cmp_, val, kf, ures, probe, prov, gate)
    write_output(provenance_path(args.output), json.dumps(prov, indent=1) + "\n", force=args.force)
    write_output(args.output, text, force=args.force)
    print()
    em = error_model(res.params)
    with_em = "" if em is None else " and its [errmodel] table"
    if em is not None and em.cte_columns:
        print(
            f"wrote {args.output} (with thermal expansion: aacmm params set refuses it; "
            f"aacmm verify --params {args.output} applies it)"
        )
    else:
        print(f"wrote {args.output} (load it{with_em} with: aacmm params set {args.output} --save)")
    print(f"wrote {provenance_path(args.output)}")


def _source_json(s: Any) -> dict[str, Any]:
    return {
        "path": s.path,
        "plan": s.plan,
        "plan_sha256": s.plan_sha256,
        "status": s.status,
        "points": s.points,
        "param_crc32": s.param_set.crc_hex,
        "plan_points": s.plan_points,
        "serial_number": s.serial_number,
        "firmware": s.firmware,
        "used_steps": list(s.used_steps),
        "unused_steps": list(s.unused_steps),
    }


def _write_report(
    args: argparse.Namespace,
    data: Any,
    res: Any,
    cmp_: Any,
    val: Any,
    kf: Any,
    ures: Any,
    probe: Any,
    prov: dict[str, Any],
    gate: Any,
) -> None:
    import json

    from aacmm.calibration import plots, report
    from aacmm.fileio import save_figure, write_output

    d = Path(args.report)
    d.mkdir(parents=True, exist_ok=True)
    parts = [_summary(data), report.format_result(res, cmp_)]
    if probe is not None:
        parts.append(_probe_text(probe))
    if val is not None:
        parts.append(report.format_comparison(val, "Held-out sessions (not used by the fit)"))
    if kf is not None:
        parts.append(report.format_comparison(kf.pooled, f"{kf.k}-fold cross-validation"))
    parts.append(_gate_text(gate, args))
    write_output(d / "report.txt", "\n\n".join(parts) + "\n", force=args.force)
    write_output(d / "report.json", json.dumps(prov, indent=1) + "\n", force=args.force)
    figs = {
        "spectrum.png": plots.spectrum_figure(res.identifiability),
        "correlation.png": plots.correlation_figure(res),
        "convergence.png": plots.convergence_figure(res),
    }
    if ures is not None:
        figs["uncertainty.png"] = plots.uncertainty_figure(ures)
    names = res.observations.step_names
    for step, fig in plots.residual_figures(res).items():
        figs[_step_png(step, names[step] if step < len(names) else "")] = fig
    for name, fig in figs.items():
        save_figure(fig, d / name, force=args.force, dpi=110)
    from aacmm.view.html import report_names, write_report
    from aacmm.view.scene import calibration_scene

    sources = ", ".join(Path(s["path"]).name for s in prov["sessions"])
    write_report(d, calibration_scene(res, cmp_, f"calibration from {sources}"), args.force)
    print(f"wrote {len(figs) + 2 + len(report_names())} report files to {d}/ (report.html: 3-D)")
