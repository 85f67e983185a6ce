"""Reports of a calibration: text, JSON-ready data, per-point residuals, point uncertainty.

Pure functions of a :class:`~aacmm.calibration.results.CalibrationResult`:
:func:`format_identifiability`, :func:`format_result` (text for a terminal),
:func:`to_json` (everything, machine-readable), :func:`unit_residuals` (the
size of each probed point's or length position's residual, for plots and
tables) and :func:`point_uncertainty` (the calibrated parameters' covariance
propagated to the probe point with :func:`aacmm.uncertainty.propagate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from aacmm import uncertainty as unc
from aacmm.calibration.identifiability import Identifiability
from aacmm.calibration.parameters import param_names, param_units
from aacmm.calibration.problem import KIND_LENGTH, Evaluation, Problem
from aacmm.calibration.results import CalibrationResult, ErrorTerm, Outlier
from aacmm.calibration.validation import Comparison, describe_change, is_worse
from aacmm.core import PARAM_NAMES, FloatArray

ARCSEC = math.pi / 648000.0


@dataclass(frozen=True)
class UnitResiduals:
    """Per unit (probed point or length position) of a problem, at one parameter set.

    ``size_mm``: length of the residual (distance to the seat's mean point,
    |length error|, ...); ``signed_mm``: the signed residual for one-row
    units (length error, distance from a sphere or plane), NaN otherwise;
    ``step``, ``index``: label of the unit's (first) pose; ``kind``.
    """

    size_mm: FloatArray
    signed_mm: FloatArray
    step: np.ndarray
    index: np.ndarray
    kind: np.ndarray
    constraint: np.ndarray


def unit_residuals(problem: Problem, ev: Evaluation) -> UnitResiduals:
    """The residual of every unit of ``problem`` at ``ev`` (mm, unwhitened)."""
    ok = ev.unit >= 0
    u = ev.unit[ok]
    mm = ev.r[ok] * ev.sigma[ok]
    n = problem.n_units
    size = np.sqrt(np.bincount(u, weights=mm**2, minlength=n))
    rows = np.bincount(u, minlength=n)
    signed = np.full(n, np.nan)
    one = rows == 1
    signed[one] = np.bincount(u, weights=mm, minlength=n)[one]
    pose = problem.unit_pose
    return UnitResiduals(
        size,
        signed,
        problem.obs.step[pose],
        problem.obs.index[pose],
        problem.unit_kind,
        problem.unit_constraint,
    )


def _fmt_param(unit: str, v: float) -> str:
    if unit == "1/K":  # a link CTE, in 1e-6/K
        return f"{v * 1e6:.2f} ppm/K"
    return f"{math.degrees(v):.6f} deg" if unit == "rad" else f"{v:.4f} mm"


def _fmt_small(unit: str, v: float) -> str:
    """A change or an uncertainty: arcsec for angles, um for lengths, ppm/K for CTEs."""
    if unit == "1/K":
        return f"{v * 1e6:+.2f} ppm/K"
    return f'{v / ARCSEC:+.2f}"' if unit == "rad" else f"{v * 1e3:+.2f} um"


def _fmt_u(unit: str, v: float) -> str:
    if unit == "1/K":
        return f"{v * 1e6:.2f} ppm/K"
    return f'{v / ARCSEC:.2f}"' if unit == "rad" else f"{v * 1e3:.2f} um"


def format_identifiability(idn: Identifiability, title: str = "Identifiability") -> str:
    """The identifiability report: rank, spectrum, indices, named null space."""
    sv = idn.singular_values
    lines = [
        f"{title}: {idn.n} parameters, {idn.rows} residual rows",
        f"  rank {idn.rank} of {idn.n} (tolerance {idn.tolerance:.2g} = max(1e-10 s_max, "
        f"10 x ||r||/||p|| = {idn.residual_ratio:.2g}))",
        "  singular values (column-scaled): "
        + " ".join(f"{v:.3g}" for v in sv[: idn.rank])
        + (" | " + " ".join(f"{v:.1e}" for v in sv[idn.rank :]) if idn.rank < sv.size else ""),
    ]
    if idn.rank:
        gap = "" if math.isinf(idn.gap) else f", gap {idn.gap:.2g}"
        lines.append(
            f"  condition number {idn.condition_number:.3g} (inverse {idn.inverse_condition:.3g})"
            f", O1 {idn.o1:.3g}, noise amplification {idn.noise_amplification:.3g}, "
            f"smallest {idn.min_singular_value:.3g}{gap}"
        )
        if idn.condition_number > 100:
            lines.append("  (a column-scaled condition number above ~100 means weak directions)")
    if idn.null:
        held = f" -- held at their start values: {', '.join(idn.held)}" if idn.held else ""
        lines.append(f"  unobservable ({len(idn.null)}){held}:")
        for d in idn.null:
            comps = ", ".join(f"{n} {w:+.2f}" for n, w in d.components)
            lines.append(f"    [{d.kind}] {comps}")
            lines.append(f"        {d.meaning}")
            lines.append(f"        to observe it: {d.remedy}")
    else:
        lines.append("  every parameter is identifiable")
    return "\n".join(lines)


def format_parameters(res: CalibrationResult[Any]) -> str:
    """Start and calibrated values, change and standard uncertainty of every parameter
    (the arm's own, for any arm)."""
    v0, v1, sd = res.start.to_vector(), res.params.to_vector(), res.scaled_std
    units = param_units(res.params)
    lines = [
        f"  {'param':<7} {'start':>17} {'calibrated':>17} {'change':>12} {'u (k=1)':>10}",
    ]
    for k, n in enumerate(param_names(res.params)):
        if n in res.held:
            note = "held (unobservable)"
        elif n in res.fixed:
            note = "fixed"
        else:
            note = _fmt_u(units[k], sd[k])
        lines.append(
            f"  {n:<7} {_fmt_param(units[k], v0[k]):>17} {_fmt_param(units[k], v1[k]):>17} "
            f"{_fmt_small(units[k], v1[k] - v0[k]):>12} {note:>10}"
        )
    return "\n".join(lines)


def uncertainty_scaling_text(res: CalibrationResult) -> str:
    """One line saying how the reported uncertainties were scaled ('' when they were not)."""
    if res.variance_factor == 1.0:
        return ""
    return (
        f"the model is incomplete: every uncertainty reported (parameters, tip, point) is "
        f"scaled by sqrt(chi^2/dof) = {res.uncertainty_scale:.3g}, so that it reflects the "
        "residual scatter rather than the stated probing uncertainty"
    )


def format_comparison(cmp_: Comparison, title: str) -> str:
    """A before/after table (um)."""
    lines = [f"{title}:", f"  {'figure':<18} {'before':>12} {'after':>12}  change"]
    for name, b, a, _ in cmp_.rows():
        lines.append(
            f"  {name.removesuffix('_mm'):<18} {b * 1e3:9.2f} um {a * 1e3:9.2f} um  "
            f"{describe_change(b, a)}"
        )
    return "\n".join(lines)


def format_error_terms(terms: tuple[ErrorTerm, ...], requested: str = "") -> str:
    """The encoder harmonics of a calibration: per term its value, uncertainty,
    observability and status ('' without harmonics)."""
    if not terms:
        return ""
    est = sum(1 for t in terms if t.status != "unobserved")
    lines = [
        f"Encoder angle harmonics ({requested or 'asked for'}): {est} of {len(terms)} terms "
        "estimated; q + sum_k (c_k cos kq + s_k sin kq)",
        f"  {'term':<7} {'value':>10} {'u (k=1)':>10} {'observ.':>8}  status",
    ]
    for t in terms:
        if t.in_model and t.status != "unobserved":
            val = f'{t.value / ARCSEC:+.2f}"'
            u = f'{t.std / ARCSEC:.2f}"'
        else:
            val = u = "-"
        why = "" if t.in_model else " (the joint's angle does not move the probe point)"
        lines.append(f"  {t.name:<7} {val:>10} {u:>10} {t.observability:8.3f}  {t.status}{why}")
    return "\n".join(lines)


def error_terms_json(terms: tuple[ErrorTerm, ...]) -> list[dict[str, Any]]:
    """The encoder harmonics as JSON rows (rad)."""
    return [
        {
            "name": t.name,
            "joint": t.joint,
            "k": t.k,
            "value_rad": t.value,
            "std_rad": t.std,
            "observability": t.observability,
            "status": t.status,
            "in_model": t.in_model,
        }
        for t in terms
    ]


def _fmt_outlier(o: Outlier) -> str:
    return (
        f"  {o.label}: {o.constraint} ({o.kind}), residual {o.residual_mm * 1e3:.1f} um, "
        f"statistic {o.statistic:.1f} > {o.threshold:.1f} (p = {o.p_value:.2g})"
    )


def format_result(res: CalibrationResult, cmp_: Comparison | None = None) -> str:
    """The whole text report of a calibration."""
    first = res.history[0].chi2 if res.history else res.before.chi2
    last = res.after.chi2
    lines = [
        format_identifiability(res.identifiability, "Identifiability at the solution"),
        "",
        f"Solver: weighted Levenberg-Marquardt (MINPACK lm) over {len(res.free)} free "
        f"parameters ({res.strategy} strategy for the unobservable directions), "
        f"{res.stages} stage(s), {len(res.history)} evaluations, chi^2 {first:.4g} -> "
        f"{last:.4g}, {res.elapsed_s:.2f} s",
        "",
        "Parameters:",
        format_parameters(res),
        "",
    ]
    harm = format_error_terms(res.error_terms, res.harmonics_requested)
    if harm:
        lines += [harm, ""]
    lines.append(res.chi_square.describe())
    scaling = uncertainty_scaling_text(res)
    if scaling:
        lines.append(scaling)
    corr = res.strongest_correlations(3)
    if corr:
        lines.append(
            "strongest correlations: " + ", ".join(f"{a}-{b} {c:+.3f}" for a, b, c in corr)
        )
    if cmp_ is not None:
        lines += ["", format_comparison(cmp_, "Before / after on the calibration data")]
    if res.rejected:
        lines += ["", f"Rejected as outliers ({len(res.rejected)}, excluded):"]
        lines += [_fmt_outlier(o) for o in res.rejected]
    if res.outliers:
        lines += [
            "",
            f"Outliers ({len(res.outliers)}, kept; exclude them with --reject):",
        ]
        lines += [_fmt_outlier(o) for o in res.outliers]
    else:
        lines += ["", "Outliers: none"]
    for note in res.notes:
        lines.append(f"note: {note}")
    return "\n".join(lines)


def point_uncertainty(
    res: CalibrationResult[Any],
    workspace: int = 100,
    trials: int = 20_000,
    seed: int = 0,
    poses_rad: FloatArray | None = None,
) -> unc.UncertaintyResult:
    """The calibrated parameters' covariance propagated to the probe point.

    Linear (J Sigma J^T with the correlations) and Monte Carlo (correlated
    normal draws) with :func:`aacmm.uncertainty.propagate`, at
    ``workspace`` random poses (and ``poses_rad``), for the paper's arm or
    any other (its P parameters, issue 26). Held parameters add nothing:
    they are rigid motions of the whole arm (theta1, d1) or leave the tip
    where it is (the tip's split), so distances measured with the arm do not
    depend on them. The covariance is the reported one
    (:attr:`~aacmm.calibration.results.CalibrationResult.scaled_covariance`).
    """
    from aacmm.calibration.harmonics import dh_part

    res = dh_part(res)  # encoder harmonics: the arm's parameters, their marginal covariance
    spec = unc.UncertaintySpec.from_covariance(res.scaled_covariance, res.params, poses_rad)
    return unc.propagate(spec, trials=trials, workspace=workspace, seed=seed)


def identifiability_json(idn: Identifiability) -> dict[str, Any]:
    return {
        "parameters": list(idn.names),
        "rows": idn.rows,
        "rank": idn.rank,
        "tolerance": idn.tolerance,
        "residual_ratio": idn.residual_ratio,
        "singular_values": idn.singular_values.tolist(),
        "column_scale_mm_per_unit": idn.scale.tolist(),
        "condition_number": idn.condition_number if idn.rank else None,
        "inverse_condition": idn.inverse_condition,
        "o1": idn.o1,
        "noise_amplification": idn.noise_amplification,
        "min_singular_value": idn.min_singular_value,
        "held": list(idn.held),
        "null_space": [
            {
                "kind": d.kind,
                "components": {n: w for n, w in d.components},
                "vector": d.vector.tolist(),
                "meaning": d.meaning,
                "remedy": d.remedy,
            }
            for d in idn.null
        ],
    }


def _outlier_json(o: Outlier) -> dict[str, Any]:
    return {
        "label": o.label,
        "constraint": o.constraint,
        "kind": o.kind,
        "poses": list(o.poses),
        "position": o.position + 1 if o.kind == KIND_LENGTH else None,  # from 1, as the label
        "residual_mm": o.residual_mm,
        "statistic": o.statistic,
        "threshold": o.threshold,
        "p_value": o.p_value,
    }


def _params_json(v: FloatArray, names: tuple[str, ...] = PARAM_NAMES) -> dict[str, float]:
    return {n: float(v[k]) for k, n in enumerate(names)}


def comparison_json(cmp_: Comparison) -> list[dict[str, Any]]:
    """A before/after table as JSON rows: figure, before, after (mm), factor
    (before / after), change (in words) and worse (the figure grew)."""
    return [
        {
            "figure": n,
            "before": None if math.isnan(b) else b,
            "after": None if math.isnan(a) else a,
            "factor": f if math.isfinite(f) else None,
            "change": describe_change(b, a),
            "worse": is_worse(b, a),
        }
        for n, b, a, f in cmp_.rows()
    ]


def to_json(res: CalibrationResult[Any], cmp_: Comparison | None = None) -> dict[str, Any]:
    """Everything about a calibration as JSON-ready data (mm, rad; any arm: its names)."""
    names = param_names(res.params)
    chi = res.chi_square
    corr = res.correlation
    out: dict[str, Any] = {
        "strategy": res.strategy,
        "free": list(res.free),
        "held": list(res.held),
        "fixed": list(res.fixed),
        "start": _params_json(res.start.to_vector(), names),
        "calibrated": _params_json(res.params.to_vector(), names),
        "std": _params_json(res.scaled_std, names),
        "std_a_priori": _params_json(res.std, names),
        "units": dict(zip(names, param_units(res.params), strict=True)),
        "variance_factor": res.variance_factor,
        "uncertainty_scale": res.uncertainty_scale,
        "covariance": res.scaled_covariance.tolist(),
        "covariance_a_priori": res.covariance.tolist(),
        "correlation": [[None if not np.isfinite(x) else float(x) for x in row] for row in corr],
        "identifiability": identifiability_json(res.identifiability),
        "identifiability_start": identifiability_json(res.identifiability_start),
        "chi_square": {
            "chi2": chi.chi2,
            "dof": chi.dof,
            "ratio": None if chi.dof <= 0 else chi.ratio,
            "p_value": None if math.isnan(chi.p_value) else chi.p_value,
            "alpha": chi.alpha,
            "verdict": chi.verdict,
            "text": chi.describe(),
            "suspects": [
                {
                    "name": s.name,
                    "chi2_drop": s.chi2_drop,
                    "excess": s.excess,
                    "amplitude": s.amplitude,
                    "amplitude_sd": s.amplitude_sd,
                    "explained": s.explained,
                    "unit": s.unit,
                }
                for s in chi.suspects
            ],
        },
        "residuals": {
            "rows": int(res.after.r.size),
            "nuisance_unknowns": res.problem.n_nuisance,
            "rms_mm_before": float(np.sqrt(np.mean((res.before.r * res.before.sigma) ** 2))),
            "rms_mm_after": float(np.sqrt(np.mean((res.after.r * res.after.sigma) ** 2))),
            "chi2_before": res.before.chi2,
            "chi2_after": res.after.chi2,
        },
        "outliers": [_outlier_json(o) for o in res.outliers],
        "rejected": [_outlier_json(o) for o in res.rejected],
        "solver": {
            "method": "Levenberg-Marquardt (scipy.optimize.least_squares, MINPACK lm)",
            "stages": res.stages,
            "evaluations": len(res.history),
            "status": res.solver_status,
            "elapsed_s": res.elapsed_s,
        },
        "notes": list(res.notes),
        "error_model": {
            "harmonics_requested": res.harmonics_requested,
            "terms": error_terms_json(res.error_terms),
        },
    }
    if cmp_ is not None:
        out["before_after"] = comparison_json(cmp_)
    return out
