"""Each plan step's fitted feature and every point's residual to it.

What the view colours points by: the feature the step's procedure implies,
fitted to the step's points so far with :mod:`aacmm.geometry` (orthogonal
least squares, ball centres, no probe compensation: a residual is the
distance of a probe-ball centre from the fitted ball-centre surface):

======================  ==========================================  =======================
procedure               feature                                     residual of a point
======================  ==========================================  =======================
``cone``                the seat: centroid of its points            distance from it
``sphere``              sphere (>= 5 points)                        signed radial distance
``articulation``        one sphere per articulation (sphere; >= 5   signed radial distance
                        each) or the seat (cone)                    (seat: distance)
``plane``               plane (>= 4 points)                         signed distance
``length``              each position's end centres (seat point,    the position's length
                        or sphere of >= 5 points), its length       error (measured minus
                                                                    calibrated)
``points``              none                                        none
======================  ==========================================  =======================

One point more than the minimum, so a residual says something. A fit that
fails (too few or degenerate points) leaves the step without a feature and
its points without residuals; the reason is in :attr:`StepFeature.note`.
A pure function of the points: the live view and the offline views and
reports call the same code.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from aacmm.geometry import GeometryError, fit_plane, fit_point, fit_sphere

FloatArray = npt.NDArray[np.float64]


class Labelled(Protocol):
    """A point's labels (as :class:`aacmm.records.CapturedPoint` and :class:`aacmm.plans.Slot`)."""

    @property
    def step_index(self) -> int: ...
    @property
    def position_index(self) -> int | None: ...
    @property
    def end(self) -> str | None: ...
    @property
    def articulation_index(self) -> int | None: ...


@dataclass
class StepFeature:
    """One step's feature (JSON-ready ``feature``: see :func:`step_features`)."""

    step_index: int
    step_id: str
    procedure: str
    artefact: str | None
    rows: list[int]  #: indices into the points given, in order
    feature: dict[str, Any] | None = None
    residuals_mm: list[float | None] = field(default_factory=list)  #: per row of ``rows``
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        fin = [abs(r) for r in self.residuals_mm if r is not None]
        return {
            "step": self.step_index,
            "id": self.step_id,
            "procedure": self.procedure,
            "artefact": self.artefact,
            "points": len(self.rows),
            "feature": self.feature,
            "rms_mm": math.sqrt(sum(r * r for r in fin) / len(fin)) if fin else None,
            "max_mm": max(fin) if fin else None,
            "note": self.note,
        }


def _v(a: Any) -> list[float]:
    return [float(x) for x in np.asarray(a, dtype=np.float64).reshape(-1)]


def _sphere(p: FloatArray) -> tuple[dict[str, Any], list[float]]:
    f = fit_sphere(p)
    return {"center_mm": _v(f.feature.center), "radius_mm": float(f.feature.radius)}, _v(
        f.residuals
    )


def _seat(p: FloatArray) -> tuple[dict[str, Any], list[float]]:
    f = fit_point(p)
    return {"kind": "seat", "center_mm": _v(f.feature.center)}, _v(f.residuals)


def _end(p: FloatArray) -> FloatArray:
    if len(p) >= 5:
        return np.asarray(fit_sphere(p).feature.center, dtype=np.float64)
    out: FloatArray = p.mean(axis=0)
    return out


def _fit_step(
    procedure: str,
    artefact: Any,
    labels: Sequence[Labelled],
    p: FloatArray,
) -> tuple[dict[str, Any] | None, list[float | None], str]:
    n = len(p)
    none: list[float | None] = [None] * n
    if procedure == "cone" or (
        procedure == "articulation" and getattr(artefact, "type", "") == "cone"
    ):
        if n < 2:
            return None, none, "a seat needs 2 points"
        feat, res = _seat(p)
        return feat, list(res), ""
    if procedure == "sphere":
        if n < 5:
            return None, none, "a sphere needs 5 points"
        feat, res = _sphere(p)
        return {"kind": "sphere", **feat}, list(res), ""
    if procedure == "articulation":
        groups: dict[int, list[int]] = {}
        for k, lab in enumerate(labels):
            groups.setdefault(int(lab.articulation_index or 0), []).append(k)
        spheres = []
        out = list(none)
        for g, rows in sorted(groups.items()):
            if len(rows) < 5:
                continue
            feat, res = _sphere(p[rows])
            spheres.append({"articulation": g, **feat})
            for k, r in zip(rows, res, strict=True):
                out[k] = r
        if not spheres:
            return None, none, "an articulation needs 5 points"
        return {"kind": "spheres", "spheres": spheres}, out, ""
    if procedure == "plane":
        if n < 4:
            return None, none, "a plane needs 4 points"
        f = fit_plane(p)
        size = getattr(artefact, "size_mm", None)
        feat = {
            "kind": "plane",
            "point_mm": _v(f.feature.point),
            "normal": _v(f.feature.normal),
            "size_mm": list(size) if size else None,
        }
        return feat, list(_v(f.residuals)), ""
    if procedure == "length":
        nominal = getattr(artefact, "length_mm", None)
        by_pos: dict[int, dict[str, list[int]]] = {}
        for k, lab in enumerate(labels):
            by_pos.setdefault(int(lab.position_index or 0), {}).setdefault(
                str(lab.end or "A"), []
            ).append(k)
        positions = []
        out = list(none)
        for pos, ends in sorted(by_pos.items()):
            if "A" not in ends or "B" not in ends:
                continue
            a, b = _end(p[ends["A"]]), _end(p[ends["B"]])
            length = float(np.linalg.norm(b - a))
            err = None if nominal is None else length - float(nominal)
            positions.append(
                {
                    "position": pos,
                    "end_a_mm": _v(a),
                    "end_b_mm": _v(b),
                    "length_mm": length,
                    "error_mm": err,
                }
            )
            for k in ends["A"] + ends["B"]:
                out[k] = err
        if not positions:
            return None, none, "a length needs both ends"
        return {"kind": "lengths", "nominal_mm": nominal, "positions": positions}, out, ""
    return None, none, ""


def step_features(
    plan: Any, labels: Sequence[Labelled], points_mm: npt.ArrayLike
) -> list[StepFeature]:
    """Every plan step with points among ``labels``: its feature and residuals.

    ``plan`` is an :class:`aacmm.plans.Plan`; ``labels[i]`` labels row i of
    ``points_mm`` (n, 3). Steps come in plan order; residuals in mm.
    Raises ValueError if the lengths differ.
    """
    p = np.asarray(points_mm, dtype=np.float64).reshape(-1, 3)
    if len(labels) != len(p):
        raise ValueError(f"{len(labels)} labels for {len(p)} points")
    out: list[StepFeature] = []
    for st in plan.steps:
        rows = [k for k, lab in enumerate(labels) if lab.step_index == st.index]
        if not rows:
            continue
        art = plan.artefacts.get(st.artefact) if st.artefact else None
        sf = StepFeature(st.index, st.id, st.procedure, st.artefact, rows)
        try:
            sf.feature, sf.residuals_mm, sf.note = _fit_step(
                st.procedure, art, [labels[k] for k in rows], p[rows]
            )
        except GeometryError as exc:
            sf.residuals_mm, sf.note = [None] * len(rows), f"no fit: {exc}"
        out.append(sf)
    return out


def point_residuals(features: Sequence[StepFeature], n: int) -> list[float | None]:
    """The residual of each of ``n`` points (None where its step has no feature)."""
    out: list[float | None] = [None] * n
    for sf in features:
        for k, r in zip(sf.rows, sf.residuals_mm, strict=True):
            out[k] = r
    return out
