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

from aacmm.calibration.observations import ObservationError, Plane, ReferencePoints, Sphere
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
    e, jc, nrm = rows(centre, rad)
    nu = {"centre_mm": centre, "radius_mm": np.array(rad)}
    new_state = np.array([*centre, rad])
    if pj is None:
        return BlockResult(e, None, None, nu), new_state
    jp = np.einsum("ka,kac->kc", nrm, pj[idx]) * sq[:, None]
    if prior:
        jp = np.vstack([jp, np.zeros(pj.shape[2])])
    jred, h = project(jp, jc)
    return BlockResult(e, jred, h, nu), new_state


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
