"""How well a parameter set measures: held-out data, before/after, k-fold.

:func:`measure` computes, for one parameter set, what a metrologist reads off
the data without fitting the arm: each calibrated length's error (measured
minus calibrated), each seat's dispersion (distance of each point from the
seat's mean point, and the single-point articulation figure: per axis
(max - min) / 2, largest axis), the form of each sphere and plane, and the
residuals of reference points after a best-fit registration. :func:`compare`
puts two parameter sets side by side on the same data (before and after a
calibration, on a held-out session). :func:`kfold` splits the constraints into
k folds, calibrates on k-1 and measures the held-out fold.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from aacmm.calibration.features import fit_ball
from aacmm.calibration.observations import (
    Cone,
    Constraint,
    LengthSet,
    ObservationError,
    Observations,
    Plane,
    ReferencePoints,
    Sphere,
)
from aacmm.calibration.parameters import ArmParams
from aacmm.calibration.problem import Problem
from aacmm.core import FloatArray, Params


@dataclass(frozen=True)
class Metrics:
    """What one parameter set measures on one data set (mm).

    ``length_errors``: measured minus calibrated length per position;
    ``cone_rms`` / ``cone_max``: per seat, RMS and largest distance of its
    points from their mean; ``cone_spat``: per seat, the largest per-axis
    (max - min) / 2; ``sphere_form``, ``plane_form``: range of the residuals
    per feature; ``sphere_size``: fitted minus stated radius (NaN for a free
    radius); ``reference_rms``: per reference set, RMS 3D residual.
    """

    length_errors: FloatArray
    cone_rms: FloatArray
    cone_max: FloatArray
    cone_spat: FloatArray
    sphere_form: FloatArray
    sphere_size: FloatArray
    plane_form: FloatArray
    reference_rms: FloatArray

    @property
    def length_rms(self) -> float:
        e = self.length_errors
        return float(np.sqrt(np.mean(e**2))) if e.size else math.nan

    @property
    def length_max(self) -> float:
        e = self.length_errors
        return float(np.max(np.abs(e))) if e.size else math.nan

    @property
    def dispersion_rms(self) -> float:
        """RMS over all seats (weighted by their RMS values' squares: pooled)."""
        c = self.cone_rms
        return float(np.sqrt(np.mean(c**2))) if c.size else math.nan

    @property
    def dispersion_max(self) -> float:
        return float(np.max(self.cone_max)) if self.cone_max.size else math.nan

    def summary(self) -> dict[str, float]:
        """The headline figures (mm), NaN where the data have no such constraint."""

        def mx(a: FloatArray) -> float:
            return float(np.max(np.abs(a))) if a.size else math.nan

        return {
            "length_rms_mm": self.length_rms,
            "length_max_mm": self.length_max,
            "cone_rms_mm": self.dispersion_rms,
            "cone_max_mm": self.dispersion_max,
            "cone_spat_mm": mx(self.cone_spat),
            "sphere_form_mm": mx(self.sphere_form),
            "sphere_size_mm": mx(self.sphere_size[np.isfinite(self.sphere_size)]),
            "plane_form_mm": mx(self.plane_form),
            "reference_rms_mm": mx(self.reference_rms),
        }


def measure(obs: Observations, params: ArmParams) -> Metrics:
    """The figures of :class:`Metrics` for ``params`` on ``obs``.

    Raises ObservationError for bad data, CalibrationError if a fitted
    feature degenerates.
    """
    problem = Problem(obs)
    ev = problem.evaluate(params)
    pts = ev.points
    lens, crms, cmax, cspat, sform, ssize, pform, rrms = ([] for _ in range(8))
    for i, c in enumerate(obs.constraints):
        if isinstance(c, Cone):
            p = pts[c.poses]
            d = np.linalg.norm(p - p.mean(axis=0), axis=1)
            crms.append(float(np.sqrt(np.mean(d**2))))
            cmax.append(float(d.max()))
            cspat.append(float(np.max((p.max(axis=0) - p.min(axis=0)) / 2)))
        elif isinstance(c, LengthSet):
            for ea, eb in zip(c.ends_a, c.ends_b, strict=True):
                if c.end_radius_mm is not None:  # ball ends: their fitted centres
                    end_a = fit_ball(pts[ea], c.end_radius_mm, c.name)
                    end_b = fit_ball(pts[eb], c.end_radius_mm, c.name)
                else:  # seats: the mean tip point of each end
                    end_a, end_b = pts[ea].mean(axis=0), pts[eb].mean(axis=0)
                lens.append(float(np.linalg.norm(end_a - end_b) - c.length_mm))
        elif isinstance(c, Sphere):
            nu = ev.nuisance[i]
            r = np.linalg.norm(pts[c.poses] - nu["centre_mm"], axis=1)
            sform.append(float(r.max() - r.min()))
            ssize.append(
                float(nu["radius_mm"]) - c.radius_mm if c.radius_mm is not None else math.nan
            )
        elif isinstance(c, Plane):
            nu = ev.nuisance[i]
            h = (pts[c.poses] - nu["point_mm"]) @ nu["normal"]
            pform.append(float(h.max() - h.min()))
        elif isinstance(c, ReferencePoints):
            p = pts[c.poses]
            if c.base_known:
                res = p - c.xyz_mm
            else:
                nu = ev.nuisance[i]
                res = p @ nu["rotation"].T + nu["translation_mm"] - c.xyz_mm
            rrms.append(float(np.sqrt(np.mean(np.sum(res**2, axis=1)))))
    a = np.asarray
    return Metrics(
        a(lens, dtype=float),
        a(crms, dtype=float),
        a(cmax, dtype=float),
        a(cspat, dtype=float),
        a(sform, dtype=float),
        a(ssize, dtype=float),
        a(pform, dtype=float),
        a(rrms, dtype=float),
    )


def factor_text(f: float) -> str:
    """A ratio as a table prints it: ``181x``, ``50.6x``, ``1.07x``."""
    return f"{f:.0f}x" if f >= 100 else f"{f:.3g}x"


def is_worse(before: float, after: float) -> bool:
    """A figure (a magnitude: smaller is better) grew from ``before`` to ``after``."""
    return math.isfinite(before) and math.isfinite(after) and abs(after) > abs(before)


def describe_change(before: float, after: float) -> str:
    """How a figure (a magnitude: smaller is better) changed, for before/after tables:
    ``132x better``, ``1.07x worse``, ``unchanged``, ``-`` when one side is missing.
    The factor is always the larger over the smaller magnitude, so it reads the
    same way in both directions."""
    b, a = abs(before), abs(after)
    if not (math.isfinite(b) and math.isfinite(a)):
        return "-"
    if a == b:
        return "unchanged"
    if a < b:
        return "better (to 0)" if a == 0 else f"{factor_text(b / a)} better"
    return "worse (from 0)" if b == 0 else f"{factor_text(a / b)} worse"


@dataclass(frozen=True)
class Comparison:
    """Two parameter sets measured on the same data (``before``, ``after``)."""

    before: Metrics
    after: Metrics

    def rows(self) -> list[tuple[str, float, float, float]]:
        """(figure, before, after, before / after) for the figures present
        (:func:`describe_change` says it in words, "worse" when a figure grew)."""
        b, a = self.before.summary(), self.after.summary()
        out = []
        for k, vb in b.items():
            va = a[k]
            if math.isnan(vb) and math.isnan(va):
                continue
            out.append((k, vb, va, vb / va if va > 0 else math.inf))
        return out


def compare(obs: Observations, before: ArmParams, after: ArmParams) -> Comparison:
    """:func:`measure` with both parameter sets."""
    return Comparison(measure(obs, before), measure(obs, after))


@dataclass(frozen=True)
class KFold:
    """Held-out figures of a k-fold cross-validation.

    ``folds``: per fold, the comparison (start parameters vs the parameters
    calibrated without that fold) on the fold's constraints; ``pooled``: all
    held-out figures together.
    """

    k: int
    folds: tuple[Comparison, ...]
    pooled: Comparison


def _pool(ms: Sequence[Metrics]) -> Metrics:
    def cat(name: str) -> FloatArray:
        return np.concatenate([getattr(m, name) for m in ms])

    return Metrics(*(cat(f) for f in Metrics.__dataclass_fields__))


def _split_units(obs: Observations) -> list[Constraint]:
    """Constraints as validation units: a length set becomes one set per position."""
    out: list[Constraint] = []
    for c in obs.constraints:
        if isinstance(c, LengthSet) and len(c.ends_a) > 1:
            for i, (ea, eb) in enumerate(zip(c.ends_a, c.ends_b, strict=True)):
                out.append(replace(c, name=f"{c.name}#{i}", ends_a=(ea,), ends_b=(eb,)))
        else:
            out.append(c)
    return out


def kfold(
    obs: Observations,
    start: ArmParams | None = None,
    k: int = 5,
    seed: int = 0,
    **calibrate_args: object,
) -> KFold:
    """k-fold cross-validation: calibrate on k-1 folds, measure the held-out one.

    Constraints are dealt to the folds at random (seeded), each kind
    separately so that every fold gets its share of seats and lengths; a
    length set counts position by position. ``calibrate_args`` go to
    :func:`~aacmm.calibration.solve.calibrate`.

    Raises ValueError if ``k`` < 2 or there are fewer constraints than folds.
    """
    from aacmm.calibration.solve import calibrate

    if k < 2:
        raise ValueError(f"k-fold needs k >= 2, got {k}")
    units = _split_units(obs)
    if len(units) < k:
        raise ObservationError(f"{len(units)} constraints cannot make {k} folds")
    rng = np.random.default_rng(seed)
    fold_of = np.empty(len(units), dtype=int)
    kinds = [type(u).__name__ for u in units]
    offset = 0
    for kind in sorted(set(kinds)):
        idx = [i for i, kk in enumerate(kinds) if kk == kind]
        perm = rng.permutation(len(idx))
        for j, p in enumerate(perm):
            fold_of[idx[p]] = (offset + j) % k
        offset += len(idx)
    p0: ArmParams = start or Params()
    comps = []
    for f in range(k):
        train = obs.subset([u for u, g in zip(units, fold_of, strict=True) if g != f])
        test = obs.subset([u for u, g in zip(units, fold_of, strict=True) if g == f])
        res = calibrate(train, p0, **calibrate_args)  # type: ignore[call-overload]
        comps.append(compare(test, p0, res.params))
    pooled = Comparison(_pool([c.before for c in comps]), _pool([c.after for c in comps]))
    return KFold(k, tuple(comps), pooled)
