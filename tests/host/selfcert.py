"""Self-certifying test data for geometric fits, built by the null-space method.

Points on a nominal feature are displaced along the feature's normal
directions by residuals ``e`` chosen orthogonal to the columns of the fit's
residual Jacobian (``J^T e = 0``), so that the nominal feature is the exact
least-squares solution of the displaced points (the approach behind ISO
10360-6 style tests of fitting software). This module does not use
aacmm.geometry: the residual functions are written here in a global
parameterisation of their own, and the Jacobians come from complex-step
differentiation (exact to rounding), so the test data are independent of
the code under test.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

Array = Any
Residual = Callable[[Array, Array], Array]  # (params (P,), points (n, 3)) -> (n, k)


def _norm(v: Array) -> Array:
    # complex-safe Euclidean norm (no abs, no conjugate)
    return np.sqrt(np.sum(v * v, axis=-1))


def _dir(theta: Array, phi: Array) -> Array:
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


def _perp_frame(d: Array) -> tuple[Array, Array]:
    ref = np.array([0.3, -0.5, 0.8]) / np.sqrt(0.98)  # fixed, never parallel in these tests
    u = np.cross(ref, d)
    u = u / _norm(u)
    return u, np.cross(d, u)


def _angles(d: Array) -> tuple[float, float]:
    return float(np.arccos(d[2])), float(np.arctan2(d[1], d[0]))


@dataclass
class Case:
    """A nominal feature with base points and per-point displacement directions."""

    name: str
    params: Array  # nominal parameters in this module's parameterisation
    base: Array  # (n, 3) points on the nominal feature
    dirs: Array  # (n, k, 3) unit displacement directions; residual k == displacement k
    residual: Residual
    nominal: dict[str, Array | float]  # the expected fit, in plain terms


def jacobian(res: Residual, params: Array, pts: Array) -> Array:
    """Complex-step Jacobian (n*k, P) of the stacked residuals."""
    h = 1e-30
    cols = []
    for j in range(len(params)):
        a = params.astype(complex)
        a[j] += 1j * h
        cols.append(np.imag(res(a, pts)).reshape(-1) / h)
    return np.stack(cols, axis=1)


def certify(case: Case, rng: np.random.Generator, size: float) -> tuple[Array, Array]:
    """Displaced points (n, 3) and their residuals e (n, k) with max |e| = size."""
    n, k, _ = case.dirs.shape
    e = rng.normal(size=(n, k))
    for _ in range(8):  # J may depend on the displacement: iterate to the fixed point
        pts = case.base + np.einsum("nk,nki->ni", e, case.dirs)
        jac = jacobian(case.residual, case.params, pts)
        flat = e.reshape(-1)
        flat = flat - jac @ np.linalg.lstsq(jac, flat, rcond=None)[0]
        e = flat.reshape(n, k) * (size / np.max(np.abs(flat)))
    pts = case.base + np.einsum("nk,nki->ni", e, case.dirs)
    # the certificate: the residuals at the nominal parameters are e, the gradient is 0
    r = case.residual(case.params, pts).real
    scale = max(1.0, float(np.max(np.abs(pts))))
    assert np.allclose(r, e, atol=1e-14 * scale, rtol=0)
    # the Gauss-Newton correction from the nominal moves no point by 1e-12 mm
    jac = jacobian(case.residual, case.params, pts)
    step = jac @ np.linalg.lstsq(jac, r.reshape(-1), rcond=None)[0]
    assert np.max(np.abs(step)) < 1e-12
    return pts, e


def _place(rng: np.random.Generator) -> tuple[Array, Array]:
    rot = Rotation.random(random_state=int(rng.integers(1 << 31))).as_matrix()
    offset = rng.uniform(-800.0, 800.0, size=3)
    return rot, offset


def sphere_case(rng: np.random.Generator, n: int, radius: float, half_angle_deg: float) -> Case:
    """Points on a cap of polar half-angle ``half_angle_deg`` (90 = hemisphere, 180 = full)."""
    rot, centre = _place(rng)
    z = rng.uniform(np.cos(np.radians(half_angle_deg)), 1.0, n)
    phi = rng.uniform(0.0, 2 * np.pi, n)
    u = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], 1)
    u = u @ rot.T

    def res(a: Array, p: Array) -> Array:
        return (_norm(p - a[:3]) - a[3])[:, None]

    return Case(
        f"sphere {2 * half_angle_deg:g} deg",
        np.array([*centre, radius]),
        centre + radius * u,
        u[:, None, :],
        res,
        {"center": centre, "radius": radius},
    )


def fixed_sphere_case(
    rng: np.random.Generator, n: int, radius: float, half_angle_deg: float
) -> Case:
    """As :func:`sphere_case` with the radius known (only the centre is fitted)."""
    free = sphere_case(rng, n, radius, half_angle_deg)

    def res(a: Array, p: Array) -> Array:
        return (_norm(p - a[:3]) - radius)[:, None]

    return Case(
        f"fixed {free.name}", free.params[:3].copy(), free.base, free.dirs, res, free.nominal
    )


def plane_case(rng: np.random.Generator, n: int, side: float) -> Case:
    rot, point = _place(rng)
    nrm = rot[:, 2]
    th, ph = _angles(nrm)
    xy = rng.uniform(-side / 2, side / 2, size=(n, 2))
    base = point + xy @ rot[:, :2].T

    def res(a: Array, p: Array) -> Array:
        return (p @ _dir(a[0], a[1]) - a[2])[:, None]

    return Case(
        "plane",
        np.array([th, ph, point @ nrm]),
        base,
        np.tile(nrm, (n, 1, 1)),
        res,
        {"point": point, "normal": nrm},
    )


def line_case(rng: np.random.Generator, n: int, length: float) -> Case:
    rot, point = _place(rng)
    d = rot[:, 2]
    th, ph = _angles(d)
    u0, v0 = _perp_frame(d)
    t = rng.uniform(-length / 2, length / 2, n)
    base = point + np.outer(t, d)

    def res(a: Array, p: Array) -> Array:
        dd = _dir(a[2], a[3])
        x0 = point + a[0] * u0 + a[1] * v0
        q = p - x0
        perp = q - np.outer(q @ dd, dd)
        u, v = _perp_frame(dd)
        return np.stack([perp @ u, perp @ v], axis=1)

    dirs = np.tile(np.stack([u0, v0]), (n, 1, 1))
    return Case(
        "line", np.array([0.0, 0.0, th, ph]), base, dirs, res, {"point": point, "direction": d}
    )


def point_case(rng: np.random.Generator, n: int) -> Case:
    _, centre = _place(rng)

    def res(a: Array, p: Array) -> Array:
        return p - a[:3]

    return Case(
        "point",
        centre.copy(),
        np.tile(centre, (n, 1)),
        np.tile(np.eye(3), (n, 1, 1)),
        res,
        {"center": centre},
    )


def circle_case(rng: np.random.Generator, n: int, radius: float, arc_deg: float) -> Case:
    rot, centre = _place(rng)
    nrm = rot[:, 2]
    th, ph = _angles(nrm)
    phi = np.sort(rng.uniform(0.0, np.radians(arc_deg), n))
    radial = np.stack([np.cos(phi), np.sin(phi), np.zeros(n)], 1) @ rot.T
    base = centre + radius * radial

    def res(a: Array, p: Array) -> Array:
        nn = _dir(a[3], a[4])
        q = p - a[:3]
        h = q @ nn
        rho = _norm(q - np.outer(h, nn))
        return np.stack([rho - a[5], h], axis=1)

    dirs = np.stack([radial, np.tile(nrm, (n, 1))], axis=1)
    return Case(
        f"circle {arc_deg:g} deg",
        np.array([*centre, th, ph, radius]),
        base,
        dirs,
        res,
        {"center": centre, "normal": nrm, "radius": radius},
    )


def cylinder_case(
    rng: np.random.Generator, n: int, radius: float, length: float, arc_deg: float
) -> Case:
    rot, point = _place(rng)
    d = rot[:, 2]
    th, ph = _angles(d)
    u0, v0 = _perp_frame(d)
    phi = rng.uniform(0.0, np.radians(arc_deg), n)
    t = rng.uniform(-length / 2, length / 2, n)
    radial = np.outer(np.cos(phi), rot[:, 0]) + np.outer(np.sin(phi), rot[:, 1])
    base = point + radius * radial + np.outer(t, d)

    def res(a: Array, p: Array) -> Array:
        dd = _dir(a[2], a[3])
        q = p - (point + a[0] * u0 + a[1] * v0)
        return (_norm(q - np.outer(q @ dd, dd)) - a[4])[:, None]

    return Case(
        f"cylinder {arc_deg:g} deg",
        np.array([0.0, 0.0, th, ph, radius]),
        base,
        radial[:, None, :],
        res,
        {"point": point, "axis": d, "radius": radius},
    )
