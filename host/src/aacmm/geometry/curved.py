"""Sphere, circle in 3D and cylinder: orthogonal-distance least squares by Gauss-Newton.

Each fit starts from an algebraic estimate and iterates on the true
orthogonal distances (the residual of a point is its distance to the surface),
with the Jacobian taken in a frame local to the current feature (the
axis/normal along z), which keeps the parameterisation free of
singularities. Data are centred on their centroid first, so points a metre
from the arm base fit as well as points near the origin.

Probe compensation: a ball of radius ``r`` touching a convex (outer) feature
has its centre ``r`` outside the surface, so the fitted radius is reduced by
``r``; for an inner feature (a bore, a socket) it is increased. Centres,
axes, residuals and form are the same either way.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
import numpy.typing as npt

from aacmm.geometry._base import (
    SPREAD_MM,
    DegenerateGeometryError,
    Fit,
    FloatArray,
    GeometryError,
    State,
    TooFewPointsError,
    as_points,
    canonical_sign,
    covariance,
    extent,
    frame,
    gauss_newton,
    make_fit,
    rank_check,
    spreads,
    unit,
)
from aacmm.geometry.algebraic import kasa_spheres

SPHERE_PARAMS = ("x", "y", "z", "radius")
CIRCLE_PARAMS = ("x", "y", "z", "tilt_u", "tilt_v", "radius")
CYLINDER_PARAMS = ("shift_u", "shift_v", "tilt_u", "tilt_v", "radius")


@dataclass(frozen=True)
class Sphere:
    """A sphere (mm)."""

    center: tuple[float, float, float]
    radius: float


@dataclass(frozen=True)
class Circle:
    """A circle in 3D: centre, unit normal of its plane, radius (mm)."""

    center: tuple[float, float, float]
    normal: tuple[float, float, float]
    radius: float


@dataclass(frozen=True)
class Cylinder:
    """A cylinder: ``point`` on the axis (foot of the data's centroid), unit ``axis``, radius."""

    point: tuple[float, float, float]
    axis: tuple[float, float, float]
    radius: float


@dataclass(frozen=True)
class SphereBatch:
    """Geometric fits of a batch of spheres (ball-centre radii, no compensation).

    ``centers`` (B, 3), ``radii`` (B,), ``residuals`` (B, n), ``covariance``
    (B, 4, 4) over x, y, z, radius, ``iterations`` of the slowest member.
    """

    centers: FloatArray
    radii: FloatArray
    residuals: FloatArray
    covariance: FloatArray
    iterations: int


def _t(v: FloatArray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _surface_radius(r: float, probe_radius: float, inner: bool, what: str) -> float:
    if not probe_radius >= 0.0:
        raise ValueError(f"probe radius must be >= 0, got {probe_radius}")
    out = r + probe_radius if inner else r - probe_radius
    if not out > 0.0:
        raise GeometryError(
            f"{what}: fitted radius {r:.6f} mm is not larger than the probe radius "
            f"{probe_radius:.6f} mm (wrong probe, or an inner feature?)"
        )
    return out


# ------------------------------------------------------------------ sphere


def fit_spheres(points: npt.ArrayLike, radius: npt.ArrayLike | None = None) -> SphereBatch:
    """Geometric least-squares spheres through a batch of point sets (B, n >= 4, 3).

    The radii are those of the ball-centre spheres (no probe compensation;
    see :func:`fit_sphere`). With ``radius`` (a scalar or (B,), mm, > 0) only
    the centres are fitted, the radius held at that value (the covariance's
    radius row and column are then zero).

    Raises:
        ValueError: bad shape or non-finite values.
        TooFewPointsError: fewer than 4 points per set.
        DegenerateGeometryError: a set is coplanar (a sphere needs points off one plane).
        ConvergenceError: a fit did not converge.
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 3 or p.shape[2] != 3:
        raise ValueError(f"point sets must have shape (B, n, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("points contain NaN or infinite coordinates")
    if p.shape[1] < 4:
        raise TooFewPointsError(f"a sphere needs at least 4 points, got {p.shape[1]}")
    c0 = p.mean(axis=1, keepdims=True)
    q = p - c0
    ext = np.sqrt(np.max(np.sum(q**2, axis=-1), axis=-1))
    ext = np.maximum(ext, 1e-300)
    start_c, start_r = kasa_spheres(q)
    fixed = radius is not None
    if fixed:
        start_r = np.broadcast_to(np.asarray(radius, dtype=np.float64), start_r.shape).copy()
        if not np.all(np.isfinite(start_r) & (start_r > 0)):
            raise ValueError(f"a fixed sphere radius must be > 0 mm, got {radius!r}")
    npar = 3 if fixed else 4

    def linearise(s: State) -> tuple[FloatArray, FloatArray]:
        c, r = s
        d = q - c[:, None, :]
        dist = np.linalg.norm(d, axis=-1)
        res = dist - r[:, None]
        jac = -d / dist[..., None]
        if not fixed:
            jac = np.concatenate([jac, -np.ones((*dist.shape, 1))], axis=-1)
        return res, jac

    def update(s: State, dx: FloatArray) -> State:
        return s[0] + dx[:, :3], s[1] if fixed else s[1] + dx[:, 3]

    state: State = (start_c, start_r)
    _, jac0 = linearise(state)
    what = "sphere"
    flat = spreads(q)[:, 2] < SPREAD_MM
    if np.any(flat):
        raise DegenerateGeometryError(
            f"{what}: the points are coplanar (a sphere needs points off one plane)"
            + (f": set {int(np.argmax(flat))}" if len(flat) > 1 else "")
        )
    rank_check(jac0, what, "the points are coplanar (a sphere needs points off one plane)")
    scale = np.broadcast_to(1.0 / ext[:, None], (p.shape[0], npar))
    state, res, jac, it = gauss_newton(state, linearise, update, scale, what)
    rank_check(jac, what, "the points do not determine a sphere")
    cov_fit, _ = covariance(jac, res)
    cov = np.zeros((p.shape[0], 4, 4))
    cov[:, :npar, :npar] = cov_fit
    return SphereBatch(state[0] + c0[:, 0, :], state[1], res, cov, it)


def fit_sphere(
    points: npt.ArrayLike,
    probe_radius: float = 0.0,
    inner: bool = False,
    radius: float | None = None,
) -> Fit[Sphere]:
    """Geometric least-squares sphere of (n >= 4, 3) points.

    ``probe_radius``: the probe ball's radius (mm); the reported radius is the
    fitted ball-centre radius minus it (plus it with ``inner=True``, for a
    concave socket). Residuals: distance from the centre minus the fitted
    ball-centre radius; ``form`` = their range. ``radius``: hold the sphere's
    (surface) radius at this value and fit the centre only (a calibrated
    sphere; 3 parameters, ``std["radius"]`` 0).

    Raises:
        ValueError, TooFewPointsError, DegenerateGeometryError, ConvergenceError,
        GeometryError (compensated radius <= 0).
    """
    p = as_points(points, 4, "sphere")
    held = None
    if radius is not None:
        if not (np.isfinite(radius) and radius > 0.0):
            raise ValueError(f"a fixed sphere radius must be > 0 mm, got {radius}")
        held = radius - probe_radius if inner else radius + probe_radius
    b = fit_spheres(p[None], held)
    surface = _surface_radius(float(b.radii[0]), probe_radius, inner, "sphere")
    feature = Sphere(_t(b.centers[0]), surface)
    return make_fit(
        "sphere",
        feature,
        b.residuals[0],
        b.covariance[0],
        SPHERE_PARAMS,
        p.shape[0] - (4 if radius is None else 3),
        iterations=b.iterations,
        probe_radius=probe_radius,
    )


# ------------------------------------------------------------------ circle and cylinder


def _local(q: FloatArray, origin: FloatArray, axis: FloatArray) -> tuple[FloatArray, ...]:
    """Coordinates (B, n) of points q (B, n, 3) along u, v, axis of the frame at origin (B, 3)."""
    fu, fv = frame(axis)
    d = q - origin[:, None, :]
    return tuple(np.einsum("bni,bi->bn", d, e) for e in (fu, fv, axis))


def _start(q: FloatArray, w: FloatArray) -> State:
    """Start (centre, axis, radius) for q (1, n, 3): algebraic circle across axis w (1, 3)."""
    u, v = frame(w)
    cc, rr = kasa_spheres(np.stack([q @ u[0], q @ v[0]], axis=-1))
    return (cc[:, :1] * u + cc[:, 1:] * v, w, rr)


def fit_circle(
    points: npt.ArrayLike, probe_radius: float = 0.0, inner: bool = False
) -> Fit[Circle]:
    """Geometric least-squares circle in 3D of (n >= 3, 3) points.

    Minimises the sum of squared 3D distances from the points to the circle
    (in-plane radial deviation and distance from the plane, both). Residuals
    are the in-plane radial deviations and ``form`` their range (roundness);
    ``extra["out_of_plane_form"]`` is the range of the distances from the
    circle's plane. Probe compensation as for :func:`fit_sphere` (``inner``
    for a bore). Covariance parameters: centre ``x``, ``y``, ``z`` (global),
    ``tilt_u``, ``tilt_v`` of the normal (rad), ``radius``.

    Raises:
        ValueError, TooFewPointsError, DegenerateGeometryError (collinear
        points), ConvergenceError, GeometryError (compensated radius <= 0).
    """
    p = as_points(points, 3, "circle")
    n = p.shape[0]
    c0 = p.mean(axis=0)
    q = (p - c0)[None]
    ext = extent(p)
    _, s, vt = np.linalg.svd(q[0], full_matrices=False)
    if s[1] / np.sqrt(n) < SPREAD_MM:
        raise DegenerateGeometryError("circle: the points are collinear")
    state = _start(q, vt[2][None])

    def linearise(st: State) -> tuple[FloatArray, FloatArray]:
        c, nrm, r = st
        qu, qv, h = _local(q, c, nrm)
        rho = np.hypot(qu, qv)
        zeros, ones = np.zeros_like(rho), np.ones_like(rho)
        j_rho = np.stack(
            [-qu / rho, -qv / rho, zeros, -h * qu / rho, -h * qv / rho, -ones], axis=-1
        )
        j_h = np.stack([zeros, zeros, -ones, qu, qv, zeros], axis=-1)
        res = np.concatenate([rho - r[:, None], h], axis=-1)
        return res, np.concatenate([j_rho, j_h], axis=-2)

    def update(st: State, dx: FloatArray) -> State:
        c, nrm, r = st
        fu, fv = frame(nrm)
        c = c + dx[:, :1] * fu + dx[:, 1:2] * fv + dx[:, 2:3] * nrm
        nrm = unit(nrm + dx[:, 3:4] * fu + dx[:, 4:5] * fv)
        return c, nrm, r + dx[:, 5]

    scale = np.array([1.0 / ext] * 3 + [1.0, 1.0, 1.0 / ext])
    state, res, jac, it = gauss_newton(state, linearise, update, scale, "circle")
    # canonical normal, then the covariance in the frame of that normal
    state = (state[0], canonical_sign(state[1]), state[2])
    res, jac = linearise(state)
    rank_check(jac, "circle", "the points do not determine a circle")
    cov_local, _ = covariance(jac, res)
    fu, fv = frame(state[1])
    t = np.eye(6)
    t[:3, :3] = np.stack([fu[0], fv[0], state[1][0]], axis=1)
    cov = t @ cov_local[0] @ t.T
    r_fit = float(state[2][0])
    radius = _surface_radius(r_fit, probe_radius, inner, "circle")
    radial, height = res[0, :n], res[0, n:]
    return make_fit(
        "circle",
        Circle(_t(state[0][0] + c0), _t(state[1][0]), radius),
        radial,
        cov,
        CIRCLE_PARAMS,
        2 * n - 6,
        ssr=float(np.sum(res**2)),
        iterations=it,
        probe_radius=probe_radius,
        extra={"out_of_plane_form": float(np.ptp(height))},
    )


def _cylinder_linearise(q: FloatArray, st: State) -> tuple[FloatArray, FloatArray]:
    """Residuals (1, n) and Jacobian (1, n, 5) of centred points q (1, n, 3) at state st."""
    x0, ax, r = st
    qu, qv, qw = _local(q, x0, ax)
    rho = np.hypot(qu, qv)
    jac = np.stack(
        [-qu / rho, -qv / rho, -qu * qw / rho, -qv * qw / rho, -np.ones_like(rho)], axis=-1
    )
    return rho - r[:, None], jac


def _cylinder_update(st: State, dx: FloatArray) -> State:
    x0, ax, r = st
    fu, fv = frame(ax)
    x0 = x0 + dx[:, :1] * fu + dx[:, 1:2] * fv
    ax = unit(ax + dx[:, 2:3] * fu + dx[:, 3:4] * fv)
    # keep the axis point at the foot of the centroid (the origin of q)
    x0 = x0 - np.sum(x0 * ax, axis=-1, keepdims=True) * ax
    return x0, ax, r + dx[:, 4]


def _cylinder_from(
    q: FloatArray, w0: FloatArray, ext: float
) -> tuple[State, FloatArray, FloatArray, int]:
    """Gauss-Newton cylinder on centred points q (1, n, 3) from axis direction w0 (3,)."""
    state = _start(q, unit(w0)[None])
    linearise = partial(_cylinder_linearise, q)
    _, jac0 = linearise(state)
    rank_check(jac0, "cylinder", "the points do not determine a cylinder")
    scale = np.array([1.0 / ext, 1.0 / ext, 1.0, 1.0, 1.0 / ext])
    return gauss_newton(state, linearise, _cylinder_update, scale, "cylinder")


def fit_cylinder(
    points: npt.ArrayLike,
    probe_radius: float = 0.0,
    inner: bool = False,
    axis_hint: npt.ArrayLike | None = None,
) -> Fit[Cylinder]:
    """Geometric least-squares cylinder of (n >= 5, 3) points.

    The axis starts from ``axis_hint`` if given, else from each principal
    direction of the points in turn (the best converged fit wins), so long
    and short (disc-like) point sets both find their axis. Residuals: the
    distance from the axis minus the fitted radius; ``form`` = their range
    (cylindricity about the least-squares axis). Probe compensation as for
    :func:`fit_sphere`. Covariance parameters: ``shift_u``, ``shift_v`` of the
    axis at ``point`` (mm), ``tilt_u``, ``tilt_v`` (rad), ``radius``.

    Raises:
        ValueError, TooFewPointsError, DegenerateGeometryError (e.g. all points
        on one circle), ConvergenceError, GeometryError (compensated radius <= 0).
    """
    p = as_points(points, 5, "cylinder")
    n = p.shape[0]
    c0 = p.mean(axis=0)
    q = (p - c0)[None]
    ext = extent(p)
    if axis_hint is not None:
        hint = np.asarray(axis_hint, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(hint)) or float(np.linalg.norm(hint)) == 0.0:
            raise ValueError("cylinder: the axis hint must be a non-zero vector")
        starts = [hint]
    else:
        starts = list(np.linalg.svd(q[0], full_matrices=False)[2])
    best: tuple[State, FloatArray, FloatArray, int] | None = None
    error: GeometryError | None = None
    for w0 in starts:
        try:
            got = _cylinder_from(q, w0, ext)
        except GeometryError as exc:
            error = exc
            continue
        if best is None or float(np.sum(got[1] ** 2)) < float(np.sum(best[1] ** 2)):
            best = got
    if best is None:
        assert error is not None
        raise error
    (x0, ax, r), _, _, it = best
    ax_c = canonical_sign(ax)
    # the covariance in the frame of the reported (canonical) axis
    res, jac = _cylinder_linearise(q, (x0, ax_c, r))
    rank_check(jac, "cylinder", "the points do not determine a cylinder")
    cov, _ = covariance(jac, res)
    radius = _surface_radius(float(r[0]), probe_radius, inner, "cylinder")
    feature = Cylinder(_t(x0[0] + c0), _t(ax_c[0]), radius)
    return make_fit(
        "cylinder",
        feature,
        res[0],
        cov[0],
        CYLINDER_PARAMS,
        n - 5,
        iterations=it,
        probe_radius=probe_radius,
    )
