"""Reports of an allocation: terminal text, JSON, CSV, PNG.

Pure functions: they return text, data or the PNG's bytes; the caller writes
the files (the command through the project's output-file rule).
"""

from __future__ import annotations

import csv
import io
import math
from typing import Any

import numpy as np

from aacmm.analysis.tolerance.allocation import Allocation
from aacmm.analysis.tolerance.check import CheckResult
from aacmm.analysis.tolerance.design import Design
from aacmm.analysis.tolerance.request import ARCSEC_RAD
from aacmm.core import Params
from aacmm.uncertainty.spec import param_group


def _fmt_t(t: float, unit: str) -> str:
    return "any" if math.isinf(t) else f"{t:.4g} {unit}"


def _target_line(a: Allocation) -> str:
    t = a.spec.target
    unit, sc = a.spec.length_unit, a.spec.length_scale
    pct = f"{100 * t.coverage:g} %"
    over = (
        ("at the worst pose" if t.quantity == "point" else "at the worst length")
        if t.over == "worst"
        else "as an RMS over the workspace"
    )
    if t.quantity == "point":
        how = (
            f"k = {t.coverage_factor:g} times the combined standard uncertainty"
            if t.coverage_factor is not None
            else f"radius holding {pct} of the probed points"
        )
        return f"target: U of the probe point <= {t.value_mm / sc:g} {unit} {over} ({how})"
    mpe = f"{t.value_mm / sc:g} {unit}" + (
        f" + {t.per_metre_mm / sc:g} {unit}/m x L" if t.per_metre_mm else ""
    )
    return (
        f"target: length error within +-MPE = {mpe} {over} ({pct} coverage; "
        f"{a.design.rows} lengths >= {t.min_length_mm:g} mm)"
    )


def _row_name(a: Allocation, r: int) -> str:
    return row_name(a.design, r)


def row_name(d: Design, r: int) -> str:
    """``pose 3 (0, 90, ... deg)`` or ``length 2 (poses 4-9, 812 mm)``."""
    if d.spec.target.quantity == "point":
        pose = ", ".join(f"{math.degrees(x):.0f}" for x in d.poses[r])
        return f"pose {r + 1} ({pose} deg)"
    i, j = d.pairs[r]
    return f"length {r + 1} (poses {i + 1}-{j + 1}, {d.lengths_mm[r]:.0f} mm)"


def format_report(a: Allocation, check: CheckResult | None = None) -> str:
    """The terminal report (units: the spec's angle and length units)."""
    spec = a.spec
    unit, sc = spec.length_unit, spec.length_scale
    lines = [
        f"Tolerance allocation: {spec.source}",
        *(
            [f"arm: {spec.model} ({spec.joints} joints, {len(spec.costs)} parameters)"]
            if spec.model is not None or not isinstance(spec.params, Params)
            else []
        ),
        _target_line(a),
        f"workspace: {spec.workspace.describe()}",
        "cost: c / t^k per parameter (t: tolerance half-width, in "
        f"{spec.angle_unit} and {spec.length_unit}); errors within +-t",
    ]
    if a.design.calibration is not None:
        cal = a.design.calibration
        lines.append(
            f"calibrated arm ({cal.source}): set by calibration: "
            + (", ".join(a.set_by_calibration) or "none")
        )
        lines.append(
            "  need a manufacturing tolerance: " + (", ".join(a.needs_tolerance) or "none")
        )
    lines += [
        "",
        f"{'param':<7} {'tolerance +-':>16} {'status':>10} {'sens ' + unit + '/unit':>14} "
        f"{'cost':>10} {'contrib ' + unit:>11} {'share':>7}",
    ]
    for p in a.params:
        lines.append(
            f"{p.name:<7} {_fmt_t(p.tolerance, p.unit):>16} {p.status:>10} "
            f"{p.sensitivity:14.4g} {p.cost:10.4g} {p.contribution_mm / sc:11.4g} "
            f"{100 * p.share:6.2f}%"
        )
    if a.encoders:
        lines += [
            "",
            f"{'joint':<5} {'encoder':<24} {'resol. arcsec':>13} {'accur. arcsec':>13} "
            f"{'u arcsec':>9} {'cost':>9} {'contrib ' + unit:>11} {'share':>7}",
        ]
        for r in a.encoders:
            e = r.encoder
            lines.append(
                f"{r.joint:<5} {e.name:<24} {e.resolution_arcsec:13.4g} {e.accuracy_arcsec:13.4g} "
                f"{r.u_rad / ARCSEC_RAD:9.4g} {e.cost:9.4g} {r.contribution_mm / sc:11.4g} "
                f"{100 * r.share:6.2f}%"
            )
    for name, (c, s) in a.fixed_terms.items():
        what = "residual model error" if name == "residual" else "calibration's own error"
        lines.append(f"{what}: contributes {c / sc:.4g} {unit} ({100 * s:.2f} %)")
    groups: dict[str, float] = {}
    for p in a.params:
        g = param_group(p.name)
        groups[g] = groups.get(g, 0.0) + p.share
    groups["encoders"] = sum(r.share for r in a.encoders)
    for name, (_, s) in a.fixed_terms.items():
        groups[name] = s
    where = (
        f"at the governing {_row_name(a, a.governing_row)}"
        if spec.target.over == "worst"
        else "mean over the workspace"
    )
    lines += [
        "",
        f"budget ({where}): " + ", ".join(f"{k} {100 * v:.1f} %" for k, v in groups.items() if v),
    ]
    t = spec.target
    if t.quantity == "point":
        val = "max over poses" if t.over == "worst" else "RMS over poses"
        lines.append(
            f"design: U {val} = {a.value_mm / sc:.4g} {unit} (target {t.value_mm / sc:g}); "
            f"coverage factor {a.kappa.min():.4f}..{a.kappa.max():.4f}"
        )
    else:
        val = "max over lengths" if t.over == "worst" else "RMS over lengths"
        lines.append(f"design: U/MPE {val} = {a.ratio:.4f} (<= 1)")
    lines.append(
        f"cost: tolerances {a.tolerance_cost:.6g} + encoders {a.encoder_cost:.6g} = "
        f"{a.total_cost:.6g}"
    )
    if check is not None:
        lines += ["", check_lines(a, check)]
    lines.append(
        f"solver: {a.combinations} encoder combination(s), {a.solved} solved exactly, "
        f"{a.iterations} coverage-factor iteration(s), {a.elapsed_s:.2f} s"
    )
    return "\n".join(lines)


def summary_lines(a: Allocation, check: CheckResult | None = None) -> list[str]:
    """Three or four lines: target, design value, cost, and the check's verdict."""
    sc, unit = a.spec.length_scale, a.spec.length_unit
    out = [
        _target_line(a),
        f"design value {a.value_mm / sc:.4g} {unit} (ratio to the target {a.ratio:.4f}); "
        f"cost {a.total_cost:.6g} (tolerances {a.tolerance_cost:.6g}, encoders "
        f"{a.encoder_cost:.6g})",
    ]
    if a.encoders:
        out.append(
            "encoders: " + ", ".join(f"joint {r.joint} {r.encoder.name}" for r in a.encoders)
        )
    if check is not None and check.over == "worst":
        out.append(
            f"Monte Carlo ({check.trials} arms): worst {100 * check.worst_within:.2f} % +- "
            f"{100 * check.worst_within_se:.2f} % within the limit (>= {100 * check.coverage:g} "
            "%): " + _verdict(check)
        )
    elif check is not None:
        out.append(
            f"Monte Carlo ({check.trials} arms): RMS over the workspace of the "
            f"{100 * check.coverage:g} % value / limit {check.ratio:.4f} +- {check.ratio_se:.4f} "
            "(<= 1): " + _verdict(check)
        )
    return out


def _verdict(c: CheckResult) -> str:
    if c.verdict == "met":
        return "target met"
    if c.verdict == "within noise":
        return "target met within the Monte Carlo noise (short by less than 2 standard errors)"
    return "TARGET NOT MET"


def check_lines(a: Allocation, c: CheckResult) -> str:
    """The Monte Carlo check as text."""
    sc, unit = a.spec.length_scale, a.spec.length_unit
    what = "poses" if a.spec.target.quantity == "point" else "lengths"
    head = (
        f"Monte Carlo check: {c.trials} arms (seed {c.seed}) at {c.rows.size} {what}, "
        f"errors from the C core with the perturbed parameters ({c.elapsed_s:.1f} s)"
    )
    r = c.worst_row
    k = int(np.flatnonzero(c.rows == r)[0])
    lines = [
        head,
        f"  worst {what[:-1]}: {100 * c.worst_within:.2f} % +- {100 * c.worst_within_se:.2f} % "
        f"of arms within {c.limit_mm[k] / sc:.4g} {unit} (target >= {100 * c.coverage:g} %; "
        f"{_row_name(a, r)})",
    ]
    if c.over == "worst":
        lines.append(
            f"  MC {100 * c.coverage:g} % value / limit, max over {what}: "
            f"{c.ratio:.4f} +- {c.ratio_se:.4f}"
        )
    else:
        lines.append(
            f"  MC {100 * c.coverage:g} % value / limit, RMS over {what}: "
            f"{c.ratio:.4f} +- {c.ratio_se:.4f} (10 batches)"
        )
    lines.append("  verdict: " + _verdict(c))
    return "\n".join(lines)


def to_json(a: Allocation, check: CheckResult | None = None) -> dict[str, Any]:
    """A JSON-ready dict (tolerances in the spec's units, lengths also in mm)."""
    spec = a.spec
    t = spec.target

    def fin(x: float) -> float | None:
        return x if math.isfinite(x) else None

    out: dict[str, Any] = {
        "source": spec.source,
        "arm": {"model": spec.model, "joints": spec.joints, "parameters": len(spec.costs)},
        "units": {"angle": spec.angle_unit, "length": spec.length_unit},
        "target": {
            "quantity": t.quantity,
            "value_mm": t.value_mm,
            "per_metre_mm": t.per_metre_mm,
            "over": t.over,
            "coverage": t.coverage,
            "coverage_factor": t.coverage_factor,
        },
        "workspace": spec.workspace.describe(),
        "rows": a.design.rows,
        "parameters": [
            {
                "name": p.name,
                "unit": p.unit,
                "tolerance": fin(p.tolerance),
                "u_si": p.u,
                "distribution": p.distribution,
                "status": p.status,
                "sensitivity": p.sensitivity,
                "cost": p.cost,
                "contribution_mm": p.contribution_mm,
                "share": p.share,
                "min": p.t_min,
                "max": fin(p.t_max),
            }
            for p in a.params
        ],
        "encoders": [
            {
                "joint": r.joint,
                "name": r.encoder.name,
                "resolution_arcsec": r.encoder.resolution_arcsec,
                "accuracy_arcsec": r.encoder.accuracy_arcsec,
                "u_arcsec": r.u_rad / ARCSEC_RAD,
                "cost": r.encoder.cost,
                "contribution_mm": r.contribution_mm,
                "share": r.share,
            }
            for r in a.encoders
        ],
        "fixed_terms": {
            k: {"contribution_mm": c, "share": s} for k, (c, s) in a.fixed_terms.items()
        },
        "calibration": None
        if a.design.calibration is None
        else {
            "source": a.design.calibration.source,
            "set_by_calibration": list(a.set_by_calibration),
            "need_tolerance": list(a.needs_tolerance),
        },
        "design": {
            "ratio": a.ratio,
            "value_mm": a.value_mm,
            "governing_row": a.governing_row,
            "row_u_mm": a.row_u_mm.tolist(),
            "limit_mm": a.limit_mm.tolist(),
            "kappa": a.kappa.tolist(),
        },
        "cost": {
            "tolerances": a.tolerance_cost,
            "encoders": a.encoder_cost,
            "total": a.total_cost,
        },
        "solver": {
            "combinations": a.combinations,
            "solved": a.solved,
            "iterations": a.iterations,
            "elapsed_s": a.elapsed_s,
        },
    }
    if check is not None:
        out["monte_carlo"] = {
            "trials": check.trials,
            "seed": check.seed,
            "coverage": check.coverage,
            "rows": check.rows.tolist(),
            "within": check.within.tolist(),
            "within_se": check.within_se.tolist(),
            "u_mc_mm": check.u_mc.tolist(),
            "u_mc_se_mm": check.u_mc_se.tolist(),
            "ratio": check.ratio,
            "ratio_se": check.ratio_se,
            "worst_within": check.worst_within,
            "worst_within_se": check.worst_within_se,
            "worst_row": check.worst_row,
            "met": check.met,
            "verdict": check.verdict,
            "elapsed_s": check.elapsed_s,
        }
    return out


CSV_COLUMNS = (
    "kind",
    "name",
    "unit",
    "tolerance",
    "u_si",
    "status",
    "sensitivity",
    "cost",
    "contribution_mm",
    "share",
    "min",
    "max",
    "encoder",
    "resolution_arcsec",
    "accuracy_arcsec",
)


def to_csv(a: Allocation) -> str:
    """One row per parameter, per joint's encoder, per fixed term."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for p in a.params:
        w.writerow(
            [
                "parameter",
                p.name,
                p.unit,
                "inf" if math.isinf(p.tolerance) else repr(p.tolerance),
                repr(p.u),
                p.status,
                repr(p.sensitivity),
                repr(p.cost),
                repr(p.contribution_mm),
                repr(p.share),
                repr(p.t_min),
                "inf" if math.isinf(p.t_max) else repr(p.t_max),
                "",
                "",
                "",
            ]
        )
    for r in a.encoders:
        e = r.encoder
        w.writerow(
            [
                "encoder",
                f"joint{r.joint}",
                "arcsec",
                repr(e.accuracy_arcsec),
                repr(r.u_rad),
                "chosen",
                "",
                repr(e.cost),
                repr(r.contribution_mm),
                repr(r.share),
                "",
                "",
                e.name,
                repr(e.resolution_arcsec),
                repr(e.accuracy_arcsec),
            ]
        )
    for name, (c, s) in a.fixed_terms.items():
        w.writerow(["fixed", name, "", "", "", "", "", "", repr(c), repr(s), "", "", "", "", ""])
    return buf.getvalue()


def budget_png(a: Allocation) -> bytes:
    """The budget as a PNG: the contribution of every item, and its cost."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sc, unit = a.spec.length_scale, a.spec.length_unit
    colours = {
        "theta": "tab:blue",
        "alpha": "tab:orange",
        "d": "tab:green",
        "a": "tab:red",
        "l": "tab:purple",
        "beta": "tab:pink",
        "tip": "tab:purple",
        "encoder": "tab:brown",
        "fixed": "tab:gray",
    }
    items: list[tuple[str, float, float, str, str]] = []
    for p in a.params:
        if p.share > 0 or p.cost > 0:
            g = param_group(p.name)
            items.append(
                (p.name, p.contribution_mm / sc, p.cost, colours[g], _fmt_t(p.tolerance, p.unit))
            )
    for r in a.encoders:
        items.append(
            (
                f"enc{r.joint}",
                r.contribution_mm / sc,
                r.encoder.cost,
                colours["encoder"],
                r.encoder.name,
            )
        )
    for name, (c, _) in a.fixed_terms.items():
        items.append((name, c / sc, 0.0, colours["fixed"], ""))
    items.sort(key=lambda x: x[1])
    fig, (ax1, ax2) = plt.subplots(
        1, 2, figsize=(12, max(4.0, 0.26 * len(items) + 1.5)), sharey=True
    )
    y = np.arange(len(items))
    ax1.barh(y, [i[1] for i in items], color=[i[3] for i in items])
    for yy, it in zip(y, items, strict=True):
        if it[4]:
            ax1.text(
                it[1],
                yy,
                " +-" + it[4] if not it[0].startswith("enc") else " " + it[4],
                va="center",
                fontsize=7,
            )
    ax1.set_yticks(y, [i[0] for i in items], fontsize=8)
    ax1.set_xlabel(f"contribution to the design value ({unit}, adds in quadrature)")
    ax1.grid(axis="x", alpha=0.3)
    ax2.barh(y, [i[2] for i in items], color=[i[3] for i in items])
    ax2.set_xlabel("cost")
    ax2.grid(axis="x", alpha=0.3)
    t = a.spec.target
    where = _row_name(a, a.governing_row) if t.over == "worst" else "mean over the workspace"
    title = (
        f"{'point U' if t.quantity == 'point' else 'length error'} {t.over}: design "
        f"{a.value_mm / sc:.4g} {unit} for target {t.value_mm / sc:g} {unit}; "
        f"total cost {a.total_cost:.4g}\nbudget at {where}"
    )
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()
