"""The test quantities of ISO 10360-12 and ASME B89.4.22 from measured points.

Pure functions: ball-centre points (mm) in, numbers and fits out. The exact
text of neither standard is public; :data:`DEFINITIONS` states, for each
quantity, the definition implemented here, where it comes from and whether
it rests on a public summary of the standard or on an assumption.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aacmm.geometry import Fit, Sphere, TooFewPointsError, fit_sphere
from aacmm.geometry._base import FloatArray, as_points

PUBLIC = "public summary"
ASSUMED = "assumed (not verified against the standard's text)"


@dataclass(frozen=True)
class Definition:
    """What a reported quantity means here, and on what that rests."""

    name: str
    standard: str
    definition: str
    source: str
    status: str


DEFINITIONS: dict[str, Definition] = {
    d.name: d
    for d in (
        Definition(
            "P_Size.Sph.1x25::Art:AArm",
            "ISO 10360-12:2016",
            "D - D_cal: D is the diameter of the least-squares (orthogonal-distance) sphere "
            "through the 25 probed points, compensated for the probe ball; the result with "
            "the largest magnitude over the sphere positions measured is reported",
            "public summaries of ISO 10360-12 (e.g. Kreon, 'ISO 10360-12 standard for "
            "measuring arms'); the same definition as ISO 10360-5 for CMMs",
            PUBLIC,
        ),
        Definition(
            "P_Form.Sph.1x25::Art:AArm",
            "ISO 10360-12:2016",
            "range of the radial distances of the 25 points from the least-squares sphere's "
            "centre (the thickness of the shell about that centre holding every point); the "
            "largest over the sphere positions",
            "public summaries of ISO 10360-12 (as for P_Size)",
            PUBLIC,
        ),
        Definition(
            "L_Dia.5x5:Art:AArm",
            "ISO 10360-12:2016",
            "one sphere probed from 5 arm articulations with 5 points each; a least-squares "
            "sphere (free radius) per articulation; the diameter of the smallest sphere "
            "enclosing the 5 centres",
            "public descriptions of the articulated location test; whether the standard "
            "fixes the radius in the 5-point fits is not known here",
            ASSUMED,
        ),
        Definition(
            "L_Dia.5x5:Art:AArm, fixed radius",
            "ISO 10360-12:2016",
            "as L_Dia, but each articulation's sphere is fitted with its radius held at the "
            "calibrated diameter (centre only): less sensitive to probing noise (aacmm "
            "verify --l-dia-fit fixed)",
            "our variant of the articulated location test, for comparison with the free-"
            "radius reading",
            ASSUMED,
        ),
        Definition(
            "E_Uni:0:AArm",
            "ISO 10360-12:2016",
            "L - L_cal for each measured calibrated length, L between the two end centres "
            "(a ball end: the least-squares sphere centre of its points; a seat end: the "
            "mean of its points), compared with MPE_E(L); the error with the largest "
            "|error| / MPE_E(L) is reported (without an MPE: the largest |error|). "
            "The positions and orientations are those of the plan",
            "public summaries of ISO 10360-12; the prescribed positions are taken from the "
            "plan, not checked against the standard",
            PUBLIC,
        ),
        Definition(
            "B89.4.22 effective diameter",
            "ASME B89.4.22-2004",
            "D - D_cal of the least-squares sphere (probe compensated) through the points of "
            "a sphere step; the largest magnitude over the steps",
            "public descriptions of the effective diameter test",
            ASSUMED,
        ),
        Definition(
            "B89.4.22 single-point articulation",
            "ASME B89.4.22-2004",
            "per seat position: deviations d_i = |p_i - mean| of the points taken in "
            "different articulations; 2 sigma = 2 sqrt(sum d_i^2 / (n - 1)); also the largest "
            "d_i and, as FARO's SPAT reports it, (max - min)/2 per axis; the worst position "
            "is reported",
            "public descriptions of the single-point articulation test and of FARO's SPAT",
            PUBLIC,
        ),
        Definition(
            "B89.4.22 volumetric performance",
            "ASME B89.4.22-2004",
            "over all measured calibrated lengths: the largest |L - L_cal| (compared with the "
            "MPE), with the range and 2 sigma = 2 sqrt(sum (L - L_cal)^2 / (n - 1))",
            "public descriptions of the volumetric performance test",
            ASSUMED,
        ),
    )
}


# ------------------------------------------------------------------ spheres


@dataclass(frozen=True)
class SphereTest:
    """A sphere measured for size and form: ``size_error`` = D - D_cal, ``form`` (mm)."""

    fit: Fit[Sphere]
    diameter: float
    size_error: float
    form: float


def sphere_size_form(
    points: npt.ArrayLike, cal_diameter: float, probe_radius: float = 0.0
) -> SphereTest:
    """P_Size / P_Form (or the B89 effective diameter) of one probed sphere.

    Raises:
        ValueError: bad points or calibrated diameter; GeometryError subclasses
            from the fit (too few points, coplanar points).
    """
    if not (math.isfinite(cal_diameter) and cal_diameter > 0.0):
        raise ValueError(f"calibrated diameter must be > 0 mm, got {cal_diameter}")
    fit = fit_sphere(points, probe_radius=probe_radius)
    d = 2.0 * fit.feature.radius
    return SphereTest(fit, d, d - cal_diameter, fit.form)


# ------------------------------------------------------------------ articulated location


def _circumsphere(p: FloatArray) -> tuple[FloatArray, float]:
    """The smallest sphere with the points p (1..4, 3) on its surface.

    The centre lies in the points' affine span (minimum-norm solution, so four
    points on one circle give that circle's sphere); the radius is the largest
    distance to a point, so the sphere encloses them even when they are not
    exactly cospherical (degenerate boundaries of duplicate or collinear points).
    """
    if len(p) == 1:
        return p[0], 0.0
    a = p[1:] - p[0]
    g = a @ a.T
    x = np.linalg.lstsq(2.0 * g, np.sum(a * a, axis=1), rcond=1e-12)[0]
    c = p[0] + a.T @ x
    return c, float(np.max(np.linalg.norm(p - c, axis=1)))


def smallest_enclosing_sphere(points: npt.ArrayLike) -> tuple[FloatArray, float]:
    """Centre and radius of the smallest sphere enclosing (n >= 1, 3) points (exact).

    Welzl's incremental algorithm on the points in their given order
    (deterministic): each point outside the current sphere must lie on the
    boundary of the next. Meant for tens of points (the test centres and seat
    points of a verification); the worst case grows as n^4.

    Raises:
        ValueError: bad points. TooFewPointsError: no point.
    """
    p = as_points(points, 1, "enclosing sphere")
    scale = max(1.0, float(np.max(np.abs(p))))
    eps = 1e-12 * scale

    def inside(c: FloatArray, r: float, q: FloatArray) -> bool:
        return float(np.linalg.norm(q - c)) <= r + eps

    def mec(pts: list[FloatArray], boundary: list[FloatArray]) -> tuple[FloatArray, float]:
        c, r = _circumsphere(np.array(boundary)) if boundary else (pts[0], 0.0)
        if len(boundary) == 4:
            return c, r
        for i, q in enumerate(pts):
            if not inside(c, r, q):
                c, r = mec(pts[:i], [*boundary, q])
        return c, r

    centre, radius = mec(list(p), [])
    return centre, radius


@dataclass(frozen=True)
class LocationTest:
    """Articulated location: per-articulation fits, their centres, L_Dia (mm)."""

    fits: tuple[Fit[Sphere], ...]
    centers: FloatArray
    enclosing_center: FloatArray
    l_dia: float


def articulated_location(
    groups: Sequence[npt.ArrayLike],
    probe_radius: float = 0.0,
    cal_diameter: float | None = None,
) -> LocationTest:
    """L_Dia from the points of each articulation (k >= 2 groups of >= 4 points).

    Each articulation's sphere has a free radius, or with ``cal_diameter``
    (mm) its radius held at the calibrated one (centre only).

    Raises:
        TooFewPointsError: fewer than 2 articulations or 4 points in one.
        GeometryError subclasses from a fit.
    """
    if len(groups) < 2:
        raise TooFewPointsError(
            f"articulated location needs at least 2 articulations, got {len(groups)}"
        )
    radius = None if cal_diameter is None else cal_diameter / 2.0
    fits = tuple(fit_sphere(g, probe_radius=probe_radius, radius=radius) for g in groups)
    centres = np.array([f.feature.center for f in fits])
    c, r = smallest_enclosing_sphere(centres)
    return LocationTest(fits, centres, c, 2.0 * r)


# ------------------------------------------------------------------ lengths


@dataclass(frozen=True)
class EndPoint:
    """One end of a test length: its centre, how it was found, its spread (mm)."""

    center: FloatArray
    method: str  # "sphere" (>= 4 points on a ball) or "seat" (mean of points in a seat)
    n_points: int
    form: float


def end_center(points: npt.ArrayLike, as_sphere: bool | None = None) -> EndPoint:
    """The centre of a ball-bar end: sphere fit of >= 4 points, else the mean (a seat).

    ``as_sphere`` forces one or the other (None: by point count).

    Raises:
        TooFewPointsError, GeometryError subclasses (a sphere fit on coplanar points).
    """
    p = as_points(points, 1, "length end")
    sphere = len(p) >= 4 if as_sphere is None else as_sphere
    if sphere:
        f = fit_sphere(p)
        return EndPoint(np.asarray(f.feature.center), "sphere", len(p), f.form)
    c = p.mean(axis=0)
    spread = 2.0 * float(np.max(np.linalg.norm(p - c, axis=1)))
    return EndPoint(c, "seat", len(p), spread)


@dataclass(frozen=True)
class LengthTest:
    """A measured calibrated length: ``length`` (mm) and ``error`` = length - cal."""

    end_a: EndPoint
    end_b: EndPoint
    cal_length: float
    length: float
    error: float


def length_error(
    end_a: npt.ArrayLike, end_b: npt.ArrayLike, cal_length: float, as_sphere: bool | None = None
) -> LengthTest:
    """E for one calibrated length from the points of its two ends.

    Raises:
        ValueError (calibrated length <= 0), TooFewPointsError, GeometryError.
    """
    if not (math.isfinite(cal_length) and cal_length > 0.0):
        raise ValueError(f"calibrated length must be > 0 mm, got {cal_length}")
    a = end_center(end_a, as_sphere)
    b = end_center(end_b, as_sphere)
    length = float(np.linalg.norm(b.center - a.center))
    return LengthTest(a, b, cal_length, length, length - cal_length)


@dataclass(frozen=True)
class LengthStatistics:
    """Volumetric performance over length errors (mm): max |e|, range, 2 sigma."""

    n: int
    max_abs: float
    range: float
    two_sigma: float


def length_statistics(errors: npt.ArrayLike) -> LengthStatistics:
    """B89.4.22 volumetric-performance figures of length errors (n >= 2).

    Raises:
        TooFewPointsError: fewer than 2 errors. ValueError: non-finite errors.
    """
    e = np.asarray(errors, dtype=np.float64).reshape(-1)
    if len(e) < 2:
        raise TooFewPointsError(f"volumetric performance needs at least 2 lengths, got {len(e)}")
    if not np.all(np.isfinite(e)):
        raise ValueError("length errors must be finite")
    two_sigma = 2.0 * float(np.sqrt(np.sum(e**2) / (len(e) - 1)))
    return LengthStatistics(len(e), float(np.max(np.abs(e))), float(np.ptp(e)), two_sigma)


# ------------------------------------------------------------------ single point


@dataclass(frozen=True)
class SinglePointTest:
    """Single-point articulation at one seat position (mm).

    ``deviations`` are |p_i - mean|; ``two_sigma`` = 2 sqrt(sum d^2 / (n - 1));
    ``max_deviation`` the largest; ``half_range`` (3,) = (max - min)/2 per
    axis (FARO's SPAT), ``max_half_range`` the largest of the three.
    """

    mean: FloatArray
    deviations: FloatArray
    two_sigma: float
    max_deviation: float
    half_range: FloatArray
    max_half_range: float


def single_point_articulation(points: npt.ArrayLike) -> SinglePointTest:
    """B89.4.22 single-point articulation / SPAT figures of (n >= 2, 3) points.

    Raises:
        ValueError, TooFewPointsError (fewer than 2 points).
    """
    p = as_points(points, 2, "single-point articulation test")
    m = p.mean(axis=0)
    d = np.linalg.norm(p - m, axis=1)
    half = 0.5 * np.ptp(p, axis=0)
    two_sigma = 2.0 * float(np.sqrt(np.sum(d**2) / (len(p) - 1)))
    return SinglePointTest(m, d, two_sigma, float(d.max()), half, float(half.max()))
