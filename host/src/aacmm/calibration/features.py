"""Residual blocks with a nonlinear nuisance: reference points, spheres, planes.

Each block fits its nuisance unknowns exactly for the current tip points (a
weighted Kabsch registration, a Gauss-Newton sphere fit, an SVD plane fit),
returns the whitened residuals and, when the point Jacobians are given, the
parameter Jacobian projected onto the complement of the nuisance columns
together with the rows' leverages on the nuisance (see
:mod:`aacmm.calibration.problem`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aacmm.calibration.observations import (
    LengthSet,
    ObservationError,
    Plane,
    ReferencePoints,
    Sphere,
)
from aacmm.core import FloatArray
from aacmm.errors import AacmmError


class CalibrationError(AacmmError, ValueError):
    """A calibration cannot be computed from these data (degenerate geometry, no solution)."""


@dataclass
class BlockResult:
    """One block at one parameter set: residuals, (projected Jacobian, leverages), nuisance."""

    r: FloatArray
    jac: FloatArray | None
    h: FloatArray | None
    nuisance: dict[str, FloatArray]


def project(jp: FloatArray, jc: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(I - Q Q^T) jp`` and the leverages diag(Q Q^T) for the nuisance columns ``jc``."""
    q, _ = np.linalg.qr(jc)
    return jp - q @ (q.T @ jp), np.einsum("ij,ij->i", q, q)


def _skew_rows(v: FloatArray) -> FloatArray:
    """(k, 3, 3) cross-product matrices [v]x."""
    z = np.zeros(v.shape[0])
    return np.stack(
        [
            np.stack([z, -v[:, 2], v[:, 1]], axis=1),
            np.stack([v[:, 2], z, -v[:, 0]], axis=1),
            np.stack([-v[:, 1], v[:, 0], z], axis=1),
        ],
        axis=1,
    )


def reference_sigma(c: ReferencePoints, probe_sigma: FloatArray) -> FloatArray:
    """Per point: probing and reference uncertainties combined."""
    s: FloatArray = np.sqrt(probe_sigma[c.poses] ** 2 + c.u_mm**2)
    return s


def reference_block(
    c: ReferencePoints, s: FloatArray, pts: FloatArray, pj: FloatArray | None
) -> BlockResult:
    """Reference points: residuals R p + t - x (registration fitted unless the base is known)."""
    idx = c.poses
    sq = 1.0 / s
    p, x = pts[idx], c.xyz_mm
    if c.base_known:
        e = ((p - x) * sq[:, None]).reshape(-1)
        if pj is None:
            return BlockResult(e, None, None, {})
        jac = (pj[idx] * sq[:, None, None]).reshape(-1, pj.shape[2])
        return BlockResult(e, jac, np.zeros(e.size), {})
    # weighted Kabsch: R, t minimising sum w |R p + t - x|^2
    w = sq**2
    pm = (w @ p) / w.sum()
    xm = (w @ x) / w.sum()
    hmat = ((p - pm) * w[:, None]).T @ (x - xm)
    uu, sv, vt = np.linalg.svd(hmat)
    if sv[1] < 1e-9 * max(sv[0], 1e-300):
        raise CalibrationError(f"{c.name}: reference points are collinear (no registration)")
    dfix = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(vt.T @ uu.T)))])
    rot = vt.T @ dfix @ uu.T
    t = xm - rot @ pm
    rp = p @ rot.T
    e = ((rp + t - x) * sq[:, None]).reshape(-1)
    nu = {"rotation": rot, "translation_mm": t}
    if pj is None:
        return BlockResult(e, None, None, nu)
    jp = np.einsum("ab,kbc->kac", rot, pj[idx]) * sq[:, None, None]
    # nuisance columns: a small rotation about the centroid, a translation
    jc = (
        np.concatenate(
            [-_skew_rows(rp - rot @ pm), np.broadcast_to(np.eye(3), (idx.size, 3, 3))], axis=2
        )
        * sq[:, None, None]
    )
    jred, h = project(jp.reshape(-1, pj.shape[2]), jc.reshape(-1, 6))
    return BlockResult(e, jred, h, nu)


def _radial(
    e: FloatArray,
    jc: FloatArray,
    nrm: FloatArray,
    pj: FloatArray | None,
    idx: npt.NDArray[np.intp],
    sq: FloatArray,
    prior: bool,
    nu: dict[str, FloatArray],
) -> BlockResult:
    """A block of radial residuals (distance from a fitted centre along ``nrm``)."""
    if pj is None:
        return BlockResult(e, None, None, nu)
    jp = np.einsum("ka,kac->kc", nrm, pj[idx]) * sq[:, None]
    if prior:  # the prior row does not depend on the arm
        jp = np.vstack([jp, np.zeros(pj.shape[2])])
    jred, h = project(jp, jc)
    return BlockResult(e, jred, h, nu)


def sphere_rows(c: Sphere) -> int:
    """Residual rows of a sphere block: one per point, plus the radius prior if any."""
    return c.poses.size + (1 if (not c.free_radius and c.u_radius_mm > 0) else 0)


def sphere_block(
    c: Sphere, s: FloatArray, pts: FloatArray, pj: FloatArray | None, state: FloatArray | None
) -> tuple[BlockResult, FloatArray]:
    """Sphere: residuals |p - c| - rho with the centre (and radius) fitted; the new state."""
    idx = c.poses
    sq = 1.0 / s
    p = pts[idx]
    fixed_r = not c.free_radius and c.u_radius_mm == 0
    prior = not c.free_radius and c.u_radius_mm > 0
    r_stated = float(c.radius_mm) if c.radius_mm is not None else 0.0

    def rows(centre: FloatArray, rad: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        v = p - centre
        dist = np.linalg.norm(v, axis=1)
        if np.any(dist <= 0):
            raise CalibrationError(f"{c.name}: a point lies at the sphere's centre")
        nrm = v / dist[:, None]
        e = (dist - rad) * sq
        jc = -nrm * sq[:, None]
        if not fixed_r:
            jc = np.column_stack([jc, -sq])
        if prior:
            e = np.append(e, (rad - r_stated) / c.u_radius_mm)
            jc = np.vstack([jc, np.array([0.0, 0.0, 0.0, 1.0 / c.u_radius_mm])])
        return e, jc, nrm

    if state is None:
        state = _algebraic_sphere(p, c.name)
        if not c.free_radius:
            state[3] = r_stated
    centre, rad = state[:3].copy(), float(state[3])
    for _ in range(100):
        e, jc, _ = rows(centre, rad)
        step = np.linalg.lstsq(jc, -e, rcond=None)[0]
        centre += step[:3]
        if not fixed_r:
            rad += float(step[3])
        if np.linalg.norm(step) <= 1e-14 * (1.0 + abs(rad)):
            break
    else:
        raise CalibrationError(
            f"{c.name}: the sphere fit does not converge (too few or badly spread points)"
        )
    e, jc, nrm = rows(centre, rad)
    nu = {"centre_mm": centre, "radius_mm": np.array(rad)}
    return _radial(e, jc, nrm, pj, idx, sq, prior, nu), np.array([*centre, rad])


def plane_block(c: Plane, s: FloatArray, pts: FloatArray, pj: FloatArray | None) -> BlockResult:
    """Plane: residuals n . (p - m) with the plane fitted (weighted SVD)."""
    idx = c.poses
    sq = 1.0 / s
    w = sq**2
    p = pts[idx]
    m = (w @ p) / w.sum()
    q = p - m
    _, sv, vt = np.linalg.svd(q * sq[:, None], full_matrices=False)
    if sv[1] < 1e-9 * max(sv[0], 1e-300):
        raise CalibrationError(f"{c.name}: plane points are collinear (no plane)")
    nrm, t1, t2 = vt[2], vt[0], vt[1]
    e = (q @ nrm) * sq
    nu = {"normal": nrm, "point_mm": m}
    if pj is None:
        return BlockResult(e, None, None, nu)
    jp = np.einsum("a,kac->kc", nrm, pj[idx]) * sq[:, None]
    jc = np.column_stack([q @ t1, q @ t2, -np.ones(idx.size)]) * sq[:, None]
    jred, h = project(jp, jc)
    return BlockResult(e, jred, h, nu)


def fit_ball(p: FloatArray, radius: float, name: str) -> FloatArray:
    """Centre (3,) of a ball of known ``radius`` through points ``p`` (Gauss-Newton)."""
    c = _algebraic_sphere(p, name)[:3]
    for _ in range(100):
        v = p - c
        dist = np.linalg.norm(v, axis=1)
        if np.any(dist <= 0):
            raise CalibrationError(f"{name}: a point lies at the ball's centre")
        jc = -v / dist[:, None]
        step = np.linalg.lstsq(jc, radius - dist, rcond=None)[0]
        c = c + step
        if np.linalg.norm(step) <= 1e-14 * (1.0 + radius):
            break
    return c


def ballbar_order(c: LengthSet) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """Poses of a ball-ended length set in row order (end A then B, by position), positions."""
    pairs = list(zip(c.ends_a, c.ends_b, strict=True))
    idx = np.concatenate([np.concatenate([a, b]) for a, b in pairs]).astype(np.intp)
    pos = np.concatenate([np.full(a.size + b.size, k) for k, (a, b) in enumerate(pairs)])
    return idx, pos.astype(np.intp)


def ballbar_rows(c: LengthSet) -> int:
    """Rows of a ball-ended length set: one per point, plus the length prior if any."""
    return int(sum(a.size + b.size for a, b in zip(c.ends_a, c.ends_b, strict=True))) + (
        1 if c.u_length_mm > 0 else 0
    )


def ballbar_block(
    c: LengthSet, s: FloatArray, pts: FloatArray, pj: FloatArray | None, state: FloatArray | None
) -> tuple[BlockResult, FloatArray]:
    """A length between ball ends: tip centres at ``end_radius_mm`` from two centres a length apart.

    Nuisance per position: the centre of end A and the direction to end B
    (5 unknowns; end B = A + length * direction), and the true length when
    it is uncertain (with its prior row). ``s``: per point sigma in row order
    (end A then end B, position by position). ``state`` (6 P + 1,): centres A,
    directions, length from the previous evaluation.
    """
    rho = float(c.end_radius_mm or 0.0)
    npos = len(c.ends_a)
    prior = c.u_length_mm > 0
    idx, pos = ballbar_order(c)
    pairs = zip(c.ends_a, c.ends_b, strict=True)
    is_b = np.concatenate([np.r_[np.zeros(a.size, bool), np.ones(b.size, bool)] for a, b in pairs])
    p = pts[idx]
    sq = 1.0 / s
    if state is None:
        ca = np.array([fit_ball(pts[a], rho, c.name) for a in c.ends_a])
        cb = np.array([fit_ball(pts[b], rho, c.name) for b in c.ends_b])
        d = cb - ca
        u = d / np.linalg.norm(d, axis=1, keepdims=True)
        lam = float(c.length_mm)
    else:
        ca = state[: 3 * npos].reshape(npos, 3).copy()
        u = state[3 * npos : 6 * npos].reshape(npos, 3).copy()
        lam = float(state[-1])
    nz = 5 * npos + (1 if prior else 0)

    def tangents(u: FloatArray) -> tuple[FloatArray, FloatArray]:
        helper = np.where(np.abs(u[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
        t1 = np.cross(u, helper)
        t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
        return t1, np.cross(u, t1)

    def rows(
        ca: FloatArray, u: FloatArray, lam: float
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        centre = ca[pos] + np.where(is_b[:, None], lam * u[pos], 0.0)
        v = p - centre
        dist = np.linalg.norm(v, axis=1)
        if np.any(dist <= 0):
            raise CalibrationError(f"{c.name}: a point lies at a ball end's centre")
        nrm = v / dist[:, None]
        e = (dist - rho) * sq
        t1, t2 = tangents(u)
        jc = np.zeros((idx.size + (1 if prior else 0), nz))
        r = np.arange(idx.size)
        for a in range(3):
            jc[r, 5 * pos + a] = -nrm[:, a] * sq
        bsel = is_b
        jc[r[bsel], 5 * pos[bsel] + 3] = (
            -lam * np.einsum("ka,ka->k", nrm[bsel], t1[pos[bsel]]) * sq[bsel]
        )
        jc[r[bsel], 5 * pos[bsel] + 4] = (
            -lam * np.einsum("ka,ka->k", nrm[bsel], t2[pos[bsel]]) * sq[bsel]
        )
        if prior:
            jc[r[bsel], -1] = -np.einsum("ka,ka->k", nrm[bsel], u[pos[bsel]]) * sq[bsel]
            e = np.append(e, (lam - c.length_mm) / c.u_length_mm)
            jc[-1, -1] = 1.0 / c.u_length_mm
        return e, jc, nrm

    for _ in range(100):
        e, jc, _n = rows(ca, u, lam)
        step = np.linalg.lstsq(jc, -e, rcond=None)[0]
        dp = step[: 5 * npos].reshape(npos, 5)
        t1, t2 = tangents(u)
        ca = ca + dp[:, :3]
        u = u + dp[:, 3:4] * t1 + dp[:, 4:5] * t2
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        if prior:
            lam += float(step[-1])
        if np.linalg.norm(step) <= 1e-14 * (1.0 + lam):
            break
    else:
        raise CalibrationError(
            f"{c.name}: the fit of the ball ends does not converge (too few or badly spread points)"
        )
    e, jc, nrm = rows(ca, u, lam)
    nu = {"end_a_mm": ca, "direction": u, "length_mm": np.array(lam)}
    new_state = np.concatenate([ca.reshape(-1), u.reshape(-1), [lam]])
    return _radial(e, jc, nrm, pj, idx, sq, prior, nu), new_state


def _algebraic_sphere(p: FloatArray, name: str) -> FloatArray:
    """Centre and radius of a sphere through points (linear fit, a start value)."""
    a = np.column_stack([2 * p, np.ones(p.shape[0])])
    b = (p**2).sum(axis=1)
    sol, _, rank, _ = np.linalg.lstsq(a, b, rcond=None)
    if rank < 4:
        raise ObservationError(f"{name}: sphere points are coplanar (no sphere)")
    c = sol[:3]
    r2 = sol[3] + c @ c
    if not r2 > 0 or not math.isfinite(r2):
        raise ObservationError(f"{name}: no sphere fits these points")
    return np.array([c[0], c[1], c[2], math.sqrt(r2)])
