"""Evaluate the points of a plan against its MPEs: the verification report.

:func:`evaluate` takes a plan (:class:`aacmm.plans.Plan`), one label per
measured point (the step, point, position, end and articulation of
:class:`aacmm.plans.Slot`) and the points (ball centres, mm), runs every test
the plan's steps allow, and judges each against the plan's MPE with the plan's
decision rule:

=====================  =========================================  ==========================
step                   tests                                      MPE (plan ``[mpe]``)
=====================  =========================================  ==========================
sphere, ISO preset     P_Size.Sph.1x25, P_Form.Sph.1x25           ``p_size_mm``, ``p_form_mm``
sphere, other          B89.4.22 effective diameter                ``effective_diameter_mm``
articulation, sphere   L_Dia.5x5 (other layouts: L_Dia.KxM)       ``l_dia_mm``
cone; articulation,    B89.4.22 single-point articulation:        ``spat_2sigma_mm``,
cone                   2 sigma and SPAT (max - min)/2 per axis    ``spat_range_mm``
length                 E_Uni per length; B89.4.22 volumetric      ``e_uni``, ``volumetric_mm``
plane                  flatness (least squares, minimum zone)     (reported only)
=====================  =========================================  ==========================

Where a test has several values (two sphere positions, several lengths), the
worst one is reported and judged: the largest ratio of value to acceptance
limit (so for E_Uni, whose MPE grows with the length, not necessarily the
largest error); every value is kept in the result's ``items``.

The test uncertainty U (k = 2) comes from the artefact's stated expanded
uncertainty (divided by its coverage factor, times 2): the calibrated
diameter's for P_Size and the effective diameter, the calibrated length's
for E_Uni and volumetric performance; for P_Form the sphere's stated form
deviation; none (0) for L_Dia and the seat tests.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aacmm.errors import AacmmError
from aacmm.geometry import Fit, GeometryError, MinZone, Plane, fit_plane, minimum_zone_plane
from aacmm.geometry._base import FloatArray
from aacmm.verification.evaluations import (
    DEFINITIONS,
    Definition,
    LengthTest,
    LocationTest,
    SinglePointTest,
    SphereTest,
    articulated_location,
    length_error,
    length_statistics,
    single_point_articulation,
    sphere_size_form,
)
from aacmm.verification.rules import Decision, check_rule, decide, overall

if TYPE_CHECKING:
    from aacmm.plans import Plan, PointLabel, Step


#: How the articulations' spheres of L_Dia are fitted (see ``evaluate``).
L_DIA_FITS: tuple[str, ...] = ("free", "fixed")


class VerificationError(AacmmError, ValueError):
    """A session that cannot be verified (no MPE, missing points, degenerate data)."""


@dataclass(frozen=True)
class Result:
    """One reported test: the worst value, judged, with every value in ``items``."""

    key: str
    name: str
    definition: Definition
    value_mm: float
    decision: Decision
    where: str
    items: tuple[dict[str, Any], ...]

    def to_dict(self) -> dict[str, Any]:
        d = self.decision
        return {
            "key": self.key,
            "name": self.name,
            "standard": self.definition.standard,
            "value_mm": self.value_mm,
            "where": self.where,
            "mpe_mm": d.mpe,
            "u_mm": d.u,
            "limit_mm": d.limit,
            "verdict": d.verdict,
            "zone": d.zone,
            "definition": self.definition.definition,
            "source": self.definition.source,
            "definition_status": self.definition.status,
            "items": list(self.items),
        }


@dataclass(frozen=True)
class SphereStep:
    step_id: str
    iso: bool
    test: SphereTest
    points: FloatArray


@dataclass(frozen=True)
class LocationStep:
    step_id: str
    test: LocationTest


@dataclass(frozen=True)
class LengthMeasurement:
    step_id: str
    position: int
    test: LengthTest
    mpe_mm: float | None
    decision: Decision


@dataclass(frozen=True)
class SeatStep:
    step_id: str
    artefact: str
    test: SinglePointTest
    points: FloatArray


@dataclass(frozen=True)
class PlaneStep:
    step_id: str
    fit: Fit[Plane]
    min_zone: MinZone


@dataclass(frozen=True)
class Report:
    """A verification of one session: results, verdict and the per-step detail."""

    plan_name: str
    plan_title: str
    plan_sha256: str
    decision_rule: str
    probe_diameter_mm: float
    temperature_c: float | None
    results: tuple[Result, ...]
    verdict: str
    spheres: tuple[SphereStep, ...] = ()
    locations: tuple[LocationStep, ...] = ()
    lengths: tuple[LengthMeasurement, ...] = ()
    seats: tuple[SeatStep, ...] = ()
    planes: tuple[PlaneStep, ...] = ()
    notes: tuple[str, ...] = ()
    meta: dict[str, Any] = field(default_factory=dict)
    mpe: Any = None  # the plan's aacmm.plans.Mpe (for charts of length-dependent MPEs)

    def result(self, key: str) -> Result:
        """The result with ``key`` (``p_size``, ``e_uni``, ...). Raises KeyError."""
        for r in self.results:
            if r.key == key:
                return r
        raise KeyError(key)

    def to_dict(self) -> dict[str, Any]:
        """The whole report as JSON-ready data (schema ``aacmm-verification-1``)."""
        return {
            "format": "aacmm-verification-1",
            "verdict": self.verdict,
            "decision_rule": self.decision_rule,
            "plan": {"name": self.plan_name, "title": self.plan_title, "sha256": self.plan_sha256},
            "probe_diameter_mm": self.probe_diameter_mm,
            "temperature_c": self.temperature_c,
            "results": [r.to_dict() for r in self.results],
            "steps": _steps_dict(self),
            "notes": list(self.notes),
            **({"session": self.meta} if self.meta else {}),
        }


def _steps_dict(rep: Report) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for s in rep.spheres:
        f = s.test.fit
        out[s.step_id] = {
            "kind": "sphere",
            "center_mm": list(f.feature.center),
            "diameter_mm": s.test.diameter,
            "size_error_mm": s.test.size_error,
            "form_mm": s.test.form,
            "std_center_mm": [f.std["x"], f.std["y"], f.std["z"]],
            "std_diameter_mm": 2.0 * f.std["radius"],
            "residuals_mm": f.residuals.tolist(),
        }
    for loc in rep.locations:
        out[loc.step_id] = {
            "kind": "articulated location",
            "centers_mm": loc.test.centers.tolist(),
            "diameters_mm": [2.0 * f.feature.radius for f in loc.test.fits],
            "l_dia_mm": loc.test.l_dia,
        }
    for m in rep.lengths:
        lt = m.test
        out.setdefault(m.step_id, {"kind": "length", "positions": []})["positions"].append(
            {
                "position": m.position,
                "length_mm": lt.length,
                "calibrated_mm": lt.cal_length,
                "error_mm": lt.error,
                "end_a_mm": lt.end_a.center.tolist(),
                "end_b_mm": lt.end_b.center.tolist(),
                "ends": lt.end_a.method,
                "mpe_mm": m.mpe_mm,
                "verdict": m.decision.verdict,
            }
        )
    for seat in rep.seats:
        t = seat.test
        out[seat.step_id] = {
            "kind": "single point",
            "seat": seat.artefact,
            "mean_mm": t.mean.tolist(),
            "two_sigma_mm": t.two_sigma,
            "max_deviation_mm": t.max_deviation,
            "half_range_mm": t.half_range.tolist(),
            "deviations_mm": t.deviations.tolist(),
        }
    for p in rep.planes:
        out[p.step_id] = {
            "kind": "plane",
            "point_mm": list(p.fit.feature.point),
            "normal": list(p.fit.feature.normal),
            "flatness_ls_mm": p.fit.form,
            "flatness_min_zone_mm": p.min_zone.form,
        }
    return out


# ------------------------------------------------------------------ evaluation


def _fmt_where(step: str, position: int | None = None) -> str:
    return step if position is None else f"{step} position {position + 1}"


#: (reported value, magnitude judged, MPE, U, where)
Value = tuple[float, float, float | None, float, str]


def _worst(key: str, name: str, definition: str, values: list[Value], rule: str) -> Result:
    """A result from (reported value, magnitude judged, MPE, U, where) tuples: the worst."""
    decisions = [decide(mag, mpe, u, rule) for _, mag, mpe, u, _ in values]

    def badness(i: int) -> float:
        d = decisions[i]
        return values[i][1] / d.limit if d.limit else values[i][1]

    i = max(range(len(values)), key=badness)
    items = tuple(
        {"where": w, "value_mm": v, "mpe_mm": mpe, "u_mm": u, "verdict": d.verdict}
        for (v, _, mpe, u, w), d in zip(values, decisions, strict=True)
    )
    # ratio > 1 exactly when a value fails, so the worst value carries the verdict
    return Result(
        key, name, DEFINITIONS[definition], values[i][0], decisions[i], values[i][4], items
    )


def _step_points(
    plan: Plan, labels: Sequence[PointLabel], points: FloatArray
) -> dict[int, list[int]]:
    by_step: dict[int, list[int]] = {}
    for i, lab in enumerate(labels):
        if not 0 <= lab.step_index < len(plan.steps):
            raise VerificationError(f"point {i + 1} belongs to no step of the plan")
        by_step.setdefault(lab.step_index, []).append(i)
    return by_step


def _u(art: Any, expanded: float | None) -> float:
    """The test's expanded uncertainty (k = 2) from an artefact's stated one (its own k)."""
    u = art.standard_uncertainty(expanded)
    return 0.0 if u is None else 2.0 * float(u)


def evaluate(
    plan: Plan,
    labels: Sequence[PointLabel],
    points: npt.ArrayLike,
    meta: dict[str, Any] | None = None,
    name: str | None = None,
    l_dia_fit: str = "free",
) -> Report:
    """Run every test the plan's steps allow on the measured points and judge them.

    ``labels[i]`` says which plan step (and point, position, end,
    articulation) ``points[i]`` (mm, the probe ball centre) belongs to.
    Steps with no points, or not all of theirs, are skipped (and named in the
    notes). ``meta``
    (device, parameter set, ...) is carried into the report; ``name`` replaces
    the plan's name in it. ``l_dia_fit``: ``"free"`` (each articulation's
    sphere with a free radius, the default) or ``"fixed"`` (radius held at the
    calibrated diameter); see :data:`DEFINITIONS`.

    Raises:
        VerificationError: the plan has no MPE at all, or nothing to evaluate.
        GeometryError: a step's points are too few or degenerate (the message
            names the step).
        ValueError: bad arrays, a guard band as large as an MPE.
    """
    from aacmm.plans import ConeSeat, LengthStandard, Sphere

    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) != len(labels):
        raise ValueError(f"points must be ({len(labels)}, 3) for {len(labels)} labels")
    if not np.all(np.isfinite(pts)):
        raise ValueError("points contain NaN or infinite coordinates")
    if not plan.mpe.any():
        raise VerificationError(
            f"plan {plan.name}: no MPE in the plan ([mpe] table): nothing to verify against"
        )
    rule = check_rule(plan.verification.decision_rule)
    if l_dia_fit not in L_DIA_FITS:
        raise ValueError(f"l_dia_fit must be one of {', '.join(L_DIA_FITS)}, got {l_dia_fit!r}")
    ball_r = plan.probe.ball_radius_mm
    mpe = plan.mpe
    by_step = _step_points(plan, labels, pts)
    notes: list[str] = []
    spheres: list[SphereStep] = []
    locations: list[LocationStep] = []
    lengths: list[LengthMeasurement] = []
    seats: list[SeatStep] = []
    planes: list[PlaneStep] = []

    for step in plan.steps:
        idx = by_step.get(step.index, [])
        if not idx:
            notes.append(f"step {step.id}: no points measured, skipped")
            continue
        if len(idx) < step.points:
            notes.append(f"step {step.id}: {len(idx)} of {step.points} points measured, skipped")
            continue
        art = plan.artefact_of(step)
        p = pts[idx]
        labs = [labels[i] for i in idx]
        try:
            if step.procedure == "sphere" and isinstance(art, Sphere):
                t = sphere_size_form(p, art.diameter_mm, ball_r)
                spheres.append(SphereStep(step.id, step.preset is not None, t, p))
            elif step.procedure == "articulation" and isinstance(art, Sphere):
                groups = _groups(step, labs, p)
                cal_d = art.diameter_mm if l_dia_fit == "fixed" else None
                loc = articulated_location(groups, ball_r, cal_d)
                locations.append(LocationStep(step.id, loc))
            elif step.procedure in ("cone", "articulation") and isinstance(art, ConeSeat):
                seats.append(SeatStep(step.id, art.id, single_point_articulation(p), p))
            elif step.procedure == "length" and isinstance(art, LengthStandard):
                lengths.extend(_lengths(step, art, labs, p, mpe.e_uni, rule))
            elif step.procedure == "plane":
                planes.append(PlaneStep(step.id, fit_plane(p), minimum_zone_plane(p)))
            else:
                notes.append(f"step {step.id}: {step.procedure} points are not a verification test")
        except (GeometryError, VerificationError) as exc:
            raise type(exc)(f"step {step.id}: {exc}") from None

    results = _results(plan, spheres, locations, lengths, seats, rule, l_dia_fit)
    if not results:
        raise VerificationError(f"plan {plan.name}: no verification test among the measured steps")
    return Report(
        plan_name=name or plan.name,
        plan_title=plan.title,
        plan_sha256=plan.sha256,
        decision_rule=rule,
        probe_diameter_mm=plan.probe.ball_diameter_mm,
        temperature_c=plan.verification.temperature_c,
        results=tuple(results),
        verdict=overall([r.decision for r in results]),
        spheres=tuple(spheres),
        locations=tuple(locations),
        lengths=tuple(lengths),
        seats=tuple(seats),
        planes=tuple(planes),
        notes=tuple(notes),
        meta=dict(meta or {}),
        mpe=plan.mpe,
    )


def _groups(step: Step, labs: Sequence[PointLabel], p: FloatArray) -> list[FloatArray]:
    groups: dict[int, list[int]] = {}
    for i, lab in enumerate(labs):
        if lab.articulation_index is None:
            raise VerificationError(f"step {step.id}: a point has no articulation index")
        groups.setdefault(lab.articulation_index, []).append(i)
    return [p[groups[k]] for k in sorted(groups)]


def _lengths(
    step: Step,
    art: Any,
    labs: Sequence[PointLabel],
    p: FloatArray,
    e_uni: Any,
    rule: str,
) -> list[LengthMeasurement]:
    ends: dict[tuple[int, str], list[int]] = {}
    for i, lab in enumerate(labs):
        if lab.position_index is None or lab.end not in ("A", "B"):
            raise VerificationError(f"step {step.id}: a length point has no position or end")
        ends.setdefault((lab.position_index, lab.end), []).append(i)
    out = []
    for pos in sorted({k[0] for k in ends}):
        a, b = ends.get((pos, "A")), ends.get((pos, "B"))
        if a is None or b is None:
            raise VerificationError(
                f"step {step.id} position {pos + 1}: end {'A' if a is None else 'B'} not measured"
            )
        t = length_error(p[a], p[b], art.length_mm, as_sphere=art.ends == "sphere")
        m = None if e_uni is None else float(e_uni.at(art.length_mm))
        d = decide(abs(t.error), m, _u(art, art.length_uncertainty_mm), rule)
        out.append(LengthMeasurement(step.id, pos, t, m, d))
    return out


def _results(
    plan: Plan,
    spheres: list[SphereStep],
    locations: list[LocationStep],
    lengths: list[LengthMeasurement],
    seats: list[SeatStep],
    rule: str,
    l_dia_fit: str = "free",
) -> list[Result]:
    from aacmm.plans import Sphere

    mpe = plan.mpe
    out: list[Result] = []

    def sphere_u(step_id: str, attr: str) -> float:
        art = plan.artefact_of(plan.step(step_id))
        if not isinstance(art, Sphere):
            return 0.0
        if attr == "form_mm":  # a calibrated form deviation, not an uncertainty
            return 0.0 if art.form_mm is None else float(art.form_mm)
        return _u(art, getattr(art, attr))

    def sizes(steps: list[SphereStep], mpe_mm: float | None) -> list[Value]:
        return [
            (
                s.test.size_error,
                abs(s.test.size_error),
                mpe_mm,
                sphere_u(s.step_id, "diameter_uncertainty_mm"),
                s.step_id,
            )
            for s in steps
        ]

    iso = [s for s in spheres if s.iso]
    if iso:
        p_size, p_form = "P_Size.Sph.1x25::Art:AArm", "P_Form.Sph.1x25::Art:AArm"
        out.append(_worst("p_size", p_size, p_size, sizes(iso, mpe.p_size_mm), rule))
        form = [
            (s.test.form, s.test.form, mpe.p_form_mm, sphere_u(s.step_id, "form_mm"), s.step_id)
            for s in iso
        ]
        out.append(_worst("p_form", p_form, p_form, form, rule))
    eff = [s for s in spheres if not s.iso]
    if eff:
        name = "B89.4.22 effective diameter"
        vals = sizes(eff, mpe.effective_diameter_mm)
        out.append(_worst("effective_diameter", name, name, vals, rule))
    if locations:
        vals = [
            (loc.test.l_dia, loc.test.l_dia, mpe.l_dia_mm, 0.0, loc.step_id) for loc in locations
        ]
        shapes = {(len(loc.test.fits), loc.test.fits[0].n_points) for loc in locations}
        name = "L_Dia.5x5:Art:AArm" if shapes == {(5, 5)} else "L_Dia (non-standard layout)"
        definition = "L_Dia.5x5:Art:AArm" + (", fixed radius" if l_dia_fit == "fixed" else "")
        if l_dia_fit == "fixed":
            name += ", fixed radius"
        out.append(_worst("l_dia", name, definition, vals, rule))
    if seats:
        two = [
            (s.test.two_sigma, s.test.two_sigma, mpe.spat_2sigma_mm, 0.0, s.step_id) for s in seats
        ]
        out.append(
            _worst(
                "spat_2sigma",
                "B89.4.22 single-point articulation, 2 sigma",
                "B89.4.22 single-point articulation",
                two,
                rule,
            )
        )
        rng = [
            (s.test.max_half_range, s.test.max_half_range, mpe.spat_range_mm, 0.0, s.step_id)
            for s in seats
        ]
        out.append(
            _worst(
                "spat_range",
                "SPAT (max - min)/2 per axis",
                "B89.4.22 single-point articulation",
                rng,
                rule,
            )
        )
    if lengths:
        vals = [
            (
                m.test.error,
                abs(m.test.error),
                m.mpe_mm,
                m.decision.u,
                _fmt_where(m.step_id, m.position),
            )
            for m in lengths
        ]
        out.append(_worst("e_uni", "E_Uni:0:AArm", "E_Uni:0:AArm", vals, rule))
        if len(lengths) >= 2:
            st = length_statistics([m.test.error for m in lengths])
            u = max(m.decision.u for m in lengths)
            d = decide(st.max_abs, mpe.volumetric_mm, u, rule)
            items = (
                {
                    "n": st.n,
                    "max_abs_mm": st.max_abs,
                    "range_mm": st.range,
                    "two_sigma_mm": st.two_sigma,
                },
            )
            out.append(
                Result(
                    "volumetric",
                    "B89.4.22 volumetric performance",
                    DEFINITIONS["B89.4.22 volumetric performance"],
                    st.max_abs,
                    d,
                    "all lengths",
                    items,
                )
            )
    return out
