"""What ``aacmm calibrate`` prints and writes: the summary of its data, the
quality gate's and the thermal lines, the parameter file (with its ``[arm]``
and ``[errmodel]`` tables), its provenance sidecar and the ``--report`` folder
(text, JSON, figures, HTML). The command itself (:mod:`aacmm.commands.calibrate`)
reads the sessions, runs the calibration and its gate, and calls these.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

CMD = "calibrate"


def provenance_path(output: str) -> Path:
    """The provenance sidecar of a parameter file: ``params.toml`` -> ``params.provenance.json``."""
    p = Path(output)
    return p.with_name(p.stem + ".provenance.json")


def crc_hex(params: Any, encoders: Any, errors: Any = None) -> str:
    """The CRC of the set the device holds for an arm's ``params`` with ``encoders`` and
    the encoder harmonics ``errors`` (an ErrorModel, or None)."""
    from aacmm.records import ParamSetRecord

    rec = ParamSetRecord(0, params, encoders, errors)
    return str(ParamSetRecord.from_device(rec.to_device()).crc_hex)


def recorded_crc(prov: Any) -> str | None:
    """A provenance's ``arm.calibrated_param_crc32`` (None if absent)."""
    arm = prov.get("arm") if isinstance(prov, dict) else None
    crc = arm.get("calibrated_param_crc32") if isinstance(arm, dict) else None
    return crc if isinstance(crc, str) else None


def step_png(step: int, name: str) -> str:
    """``residuals-step01-cone1.png`` for step index 0: numbered from 1, as the reports."""
    safe = "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in name)
    return f"residuals-step{step + 1:02d}{'-' + safe if safe else ''}.png"


def summary_text(data: Any) -> str:
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


def _limits_origin(args: argparse.Namespace) -> str:
    """Where the gate's uncertainty limits came from: the options, or the arm."""
    given = [o for o, v in (("um", args.max_u_um), ("arcsec", args.max_u_arcsec)) if v is not None]
    widened = "widened for this arm's encoders and lever"
    if not given:
        return widened
    if len(given) == 2:
        return "as given"
    return f"--max-u-{given[0]} as given, the other {widened}"


def gate_text(gate: Any, args: argparse.Namespace) -> str:
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
            f'um, {default.max_u_angle_rad / ARCSEC_RAD:g}"; ' + _limits_origin(args) + ")"
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


def thermal_note(args: argparse.Namespace, data: Any, res: Any) -> str:
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
            "--params applies them; aacmm params set sends them to a device that reads its link "
            "temperatures (its thermal block)"
        )
    if not why:
        return ""
    return f"Thermal (--thermal {args.thermal}): {why}"


def probe_text(pr: Any) -> str:
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


def write_outputs(
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
            "calibrated_param_crc32": crc_hex(
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
            f"wrote {args.output} (with thermal expansion: aacmm params set sends it to a "
            f"device that reads its link temperatures; aacmm verify --params {args.output} "
            "applies it)"
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
    parts = [summary_text(data), report.format_result(res, cmp_)]
    if probe is not None:
        parts.append(probe_text(probe))
    if val is not None:
        parts.append(report.format_comparison(val, "Held-out sessions (not used by the fit)"))
    if kf is not None:
        parts.append(report.format_comparison(kf.pooled, f"{kf.k}-fold cross-validation"))
    parts.append(gate_text(gate, args))
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
        figs[step_png(step, names[step] if step < len(names) else "")] = fig
    for name, fig in figs.items():
        save_figure(fig, d / name, force=args.force, dpi=110)
    from aacmm.view.html import report_names, write_report
    from aacmm.view.scene import calibration_scene

    sources = ", ".join(Path(s["path"]).name for s in prov["sessions"])
    write_report(d, calibration_scene(res, cmp_, f"calibration from {sources}"), args.force)
    print(f"wrote {len(figs) + 2 + len(report_names())} report files to {d}/ (report.html: 3-D)")
