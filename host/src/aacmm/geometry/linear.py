"""Point, line and plane: orthogonal-distance least squares in closed form.

For these three features the geometric least-squares solution is exact
without iteration: the centroid is the best point, and the singular vectors
of the centred points give the best line direction (largest) and plane normal
(smallest).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aacmm.geometry._base import (
    SPREAD_MM,
    DegenerateGeometryError,
    Fit,
    FloatArray,
    as_points,
    canonical_sign,
    covariance,
    frame,
    make_fit,
    unit,
)

LINE_PARAMS = ("shift_u", "shift_v", "tilt_u", "tilt_v")
PLANE_PARAMS = ("offset", "tilt_u", "tilt_v")


@dataclass(frozen=True)
class Point:
    """A point (mm)."""

    center: tuple[float, float, float]


@dataclass(frozen=True)
class Line:
    """A line through ``point`` (the centroid's foot) along the unit ``direction``."""

    point: tuple[float, float, float]
    direction: tuple[float, float, float]


@dataclass(frozen=True)
class Plane:
    """The plane ``normal . x = normal . point``; ``normal`` is a unit vector."""

    point: tuple[float, float, float]
    normal: tuple[float, float, float]


def _t(v: FloatArray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def fit_point(points: npt.ArrayLike) -> Fit[Point]:
    """The least-squares point of (n >= 1, 3) points: their centroid.

    A ball probe held in a cone or seat reports its centre, so no probe
    compensation applies. Residuals are the distances from the centroid;
    ``form`` is twice the largest (the diameter of the centred sphere holding
    every point). Covariance: ``s^2 / n`` on x, y, z with ``s^2`` the residual
    variance per coordinate (3n - 3 degrees of freedom).

    Raises:
        ValueError: bad shape or non-finite values.
        TooFewPointsError: no point.
    """
    p = as_points(points, 1, "point")
    n = p.shape[0]
    c = p.mean(axis=0)
    d = p - c
    dist = np.linalg.norm(d, axis=1)
    ssr = float(np.sum(d**2))
    dof = 3 * n - 3
    s2 = ssr / dof if dof > 0 else float("nan")
    cov = np.eye(3) * s2 / n
    return make_fit(
        "point",
        Point(_t(c)),
        dist,
        cov,
        ("x", "y", "z"),
        dof,
        ssr=ssr,
        form=2.0 * float(dist.max()),
    )


def fit_line(points: npt.ArrayLike) -> Fit[Line]:
    """The orthogonal-distance least-squares line of (n >= 2, 3) points.

    Residuals are the distances from the line; ``form`` is twice the largest
    (the diameter of the cylinder around the fitted line holding every
    point: straightness about the least-squares axis). Covariance parameters
    (local to the line; ``u``, ``v`` perpendicular to the direction
    ``w``, see :func:`aacmm.geometry.frame`): ``shift_u``, ``shift_v`` (mm, of the
    line at the centroid) and ``tilt_u``, ``tilt_v`` (rad).

    Raises:
        ValueError, TooFewPointsError, DegenerateGeometryError (all points within
        :data:`SPREAD_MM` of one point).
    """
    p = as_points(points, 2, "line")
    n = p.shape[0]
    c = p.mean(axis=0)
    q = p - c
    _, s, vt = np.linalg.svd(q, full_matrices=False)
    if s[0] / np.sqrt(n) < SPREAD_MM:
        raise DegenerateGeometryError(
            f"line: all points coincide (spread {s[0] / np.sqrt(n):.2g} mm)"
        )
    w = canonical_sign(vt[0])
    u, v = frame(w)
    t = q @ w
    ru, rv = q @ u, q @ v
    dist = np.hypot(ru, rv)
    zeros, ones = np.zeros(n), np.ones(n)
    jac = np.concatenate(
        [
            np.stack([-ones, zeros, -t, zeros], axis=1),
            np.stack([zeros, -ones, zeros, -t], axis=1),
        ]
    )
    res = np.concatenate([ru, rv])
    cov, dof = covariance(jac[None], res[None])
    feature = Line(_t(c), _t(w))
    return make_fit("line", feature, dist, cov[0], LINE_PARAMS, dof, form=2.0 * float(dist.max()))


def fit_plane(
    points: npt.ArrayLike,
    probe_radius: float = 0.0,
    outward: npt.ArrayLike | None = None,
) -> Fit[Plane]:
    """The orthogonal-distance least-squares plane of (n >= 3, 3) points.

    The normal is oriented along ``outward`` (a rough vector from the material
    towards the side the probe came from) when it is given, else so that its
    largest component is positive. With a probe ball of radius
    ``probe_radius`` (mm) the measured ball centres lie that far outside the
    surface, so the reported plane is shifted by ``-probe_radius`` along the
    normal; ``outward`` is then required. Residuals are signed distances
    (positive along the normal); ``form`` is their range (least-squares
    flatness). Covariance parameters: ``offset`` (mm, along the normal at the
    centroid), ``tilt_u``, ``tilt_v`` (rad).

    Raises:
        ValueError: bad points, a negative radius, a radius without ``outward``
            or an ``outward`` in the plane.
        TooFewPointsError: fewer than 3 points.
        DegenerateGeometryError: the points are collinear (rms spread across the
            line below :data:`SPREAD_MM`).
    """
    p = as_points(points, 3, "plane")
    if not probe_radius >= 0.0:
        raise ValueError(f"probe radius must be >= 0, got {probe_radius}")
    n = p.shape[0]
    c = p.mean(axis=0)
    q = p - c
    _, s, vt = np.linalg.svd(q, full_matrices=False)
    if s[1] / np.sqrt(n) < SPREAD_MM:
        raise DegenerateGeometryError(
            f"plane: the points are collinear (spread {s[1] / np.sqrt(n):.2g} mm across the "
            "line; a plane needs two directions)"
        )
    w = vt[2]
    if outward is not None:
        o = np.asarray(outward, dtype=np.float64).reshape(3)
        side = float(o @ w)
        if not np.isfinite(side) or abs(side) <= 1e-6 * float(np.linalg.norm(o)):
            raise ValueError("plane: the outward direction lies in the plane")
        w = w if side > 0 else -w
    else:
        if probe_radius > 0.0:
            raise ValueError("plane: probe compensation needs the outward direction")
        w = canonical_sign(w)
    u, v = frame(w)
    res = q @ w
    ones = np.ones(n)
    jac = np.stack([-ones, -(q @ u), -(q @ v)], axis=1)
    cov, dof = covariance(jac[None], res[None])
    feature = Plane(_t(c - probe_radius * w), _t(unit(w)))
    return make_fit("plane", feature, res, cov[0], PLANE_PARAMS, dof, probe_radius=probe_radius)
