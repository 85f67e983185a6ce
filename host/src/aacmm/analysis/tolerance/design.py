"""The linearised allocation problem: what each tolerance costs the target.

Every target row r (a pose for the point target, a pair of poses for the
length target) has a covariance built from independent sources, linear in
their variances:

    Sigma_r = sum_i v_i g_ri g_ri^T  +  sum_j e_j h_rj h_rj^T  +  F_r

v_i = u_i^2 is the variance of structural parameter i (u = t * u_per_t for a
tolerance t), e_j the variance of joint j's encoder reading, F_r the fixed
part (the residual model error, the calibration's own covariance). For the
point target g_ri is the column i of the 3 x P Jacobian (P = 25 for the
paper's arm) at the pose (times the calibration map M for a calibrated arm)
and h_rj the theta_j column; for
the length target (pose A to pose B, unit direction n) Sigma_r is 1 x 1 with
g_ri = n . (g_Ai - g_Bi) (the same arm at both ends) and
h_rj^2 = (n . h_Aj)^2 + (n . h_Bj)^2 (two independent readings).

The requirement at row r is kappa_r sqrt(tr Sigma_r) <= B_r: B_r is the
target (U, or the MPE at that length) and kappa_r the factor that turns the
combined standard uncertainty into the stated coverage -- a given coverage
factor, z_(1+p)/2 for the 1-D length error, and for the 3-D point radius the
exact factor of a normal distribution of that shape
(:func:`radius_factor`), which depends on the allocation and is iterated.
Dividing by B_r^2 gives rows linear in the variances that must be <= 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import special

from aacmm.analysis.tolerance.calibrated import CalibrationModel
from aacmm.analysis.tolerance.request import ToleranceSpec
from aacmm.core import FloatArray, Model

#: quadrature nodes on the octant of the unit sphere for radius_factor
_NW, _NPHI = 24, 32


def z_two_sided(coverage: float) -> float:
    """The normal quantile z with P(|Z| <= z) = coverage (1.96 for 0.95)."""
    return float(math.sqrt(2.0) * special.erfinv(coverage))


def _octant_nodes() -> tuple[FloatArray, FloatArray]:
    x, wt = np.polynomial.legendre.leggauss(_NW)
    w = 0.5 * (x + 1.0)  # cos of the polar angle, Gauss-Legendre on [0, 1]
    phi = (np.arange(_NPHI) + 0.5) * (0.5 * math.pi / _NPHI)  # midpoint rule (periodic)
    ww, pp = np.meshgrid(w, phi, indexing="ij")
    s2 = 1.0 - ww**2
    u2 = np.stack([s2 * np.cos(pp) ** 2, s2 * np.sin(pp) ** 2, ww**2], axis=-1).reshape(-1, 3)
    weights = np.outer(0.5 * wt, np.full(_NPHI, 1.0 / _NPHI)).ravel()
    return u2, weights


_NODES = _octant_nodes()


def radius_factor(
    eigenvalues: npt.ArrayLike, coverage: float, start: FloatArray | None = None
) -> FloatArray:
    """kappa with P(|x| <= kappa sqrt(tr Sigma)) = coverage for x ~ N(0, Sigma).

    ``eigenvalues`` (n, 3) of each Sigma (any scale, >= 0, not all 0).
    Writing x = rho u (rho^2 ~ chi^2_3, u uniform on the sphere, independent)
    gives P(|x|^2 <= c tr) = E_u[F_chi2_3(c / (u^T Lambda u))] with Lambda
    normalised to trace 1; the sphere average is a product rule on one
    octant (Gauss-Legendre x midpoint; the integrand is smooth), accurate to
    about 1e-9; c is found by safeguarded Newton steps. kappa lies between
    sqrt(chi2_3(p)/3) (isotropic: 1.614 for 0.95) and z_(1+p)/2 (one
    direction: 1.960), the upper bound of Szekely and Bakirov (2003).
    ``start`` (n,): factors to start the iteration from (a nearby shape's).
    """
    lam = np.asarray(eigenvalues, dtype=np.float64).reshape(-1, 3)
    lam = np.clip(lam, 0.0, None)
    tot = lam.sum(axis=1, keepdims=True)
    if np.any(tot <= 0):
        raise ValueError("a covariance with zero trace has no coverage radius")
    lam = lam / tot
    u2, wts = _NODES
    q = lam @ u2.T  # (n, nodes): u^T Lambda u
    q = np.maximum(q, 1e-300)
    lo = np.full(lam.shape[0], special.chdtri(3, 1.0 - coverage) / 3.0)
    hi = np.full(lam.shape[0], z_two_sided(coverage) ** 2)
    c = 0.5 * (lo + hi)
    if start is not None:
        c = np.clip(np.asarray(start, dtype=np.float64) ** 2, lo, hi)
    todo = np.arange(c.size)
    for _ in range(60):
        x = c[todo, None] / q[todo]
        g = np.sqrt(x * (2.0 / math.pi)) * np.exp(-0.5 * x)
        cdf = ((special.erf(np.sqrt(0.5 * x)) - g) * wts).sum(axis=1)
        pdf = (0.5 * g / q[todo] * wts).sum(axis=1)
        ct = c[todo]
        lo[todo] = np.where(cdf < coverage, ct, lo[todo])
        hi[todo] = np.where(cdf >= coverage, ct, hi[todo])
        step = np.where(pdf > 0, (cdf - coverage) / np.where(pdf > 0, pdf, 1.0), np.inf)
        moving = np.abs(step) >= 1e-13 * ct  # Newton converges quadratically: then stop
        cn = ct - step
        out = moving & ((cn < lo[todo]) | (cn > hi[todo]))  # safeguard: bisect
        cn[out] = 0.5 * (lo[todo] + hi[todo])[out]
        c[todo[moving]] = cn[moving]
        todo = todo[moving]
        if todo.size == 0:
            break
    result: FloatArray = np.sqrt(c)
    return result


@dataclass(frozen=True)
class Design:
    """The linearised problem of one spec (see the module docstring).

    ``g`` (m, d, P), ``h`` (m, d, N), ``fixed_cov`` (m, d, d) with d = 3
    (point) or 1 (length), P the arm's parameters (25 for the paper's), N its
    joints; ``limit_mm`` (m,) the permitted value B_r;
    ``poses`` the workspace (n, N) rad, ``points`` (n, 3) mm; ``pairs``
    (m, 2) pose indices and ``lengths_mm`` (m,) for the length target;
    ``error_map`` the calibration map M (identity without calibration);
    ``calibration`` the model used, if any.
    """

    spec: ToleranceSpec
    poses: FloatArray
    points: FloatArray
    g: FloatArray
    h: FloatArray
    fixed_cov: FloatArray
    residual_cov: FloatArray
    limit_mm: FloatArray
    pairs: npt.NDArray[np.int64]
    lengths_mm: FloatArray
    error_map: FloatArray
    calibration: CalibrationModel | None

    @property
    def rows(self) -> int:
        return int(self.g.shape[0])

    @property
    def dim(self) -> int:
        return int(self.g.shape[1])

    def trace_coefficients(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(m, P), (m, N), (m,): tr Sigma_r = A v + H e + f."""
        a = np.einsum("rdi,rdi->ri", self.g, self.g)
        he = np.einsum("rdj,rdj->rj", self.h, self.h)
        f = np.einsum("rdd->r", self.fixed_cov)
        return a, he, f

    def covariances(self, v: FloatArray, e: FloatArray) -> FloatArray:
        """Sigma_r (m, d, d) for parameter variances v (P,) and encoder variances e (N,)."""
        s = np.einsum("rdi,i,rki->rdk", self.g, v, self.g)
        s += np.einsum("rdj,j,rkj->rdk", self.h, e, self.h)
        s += self.fixed_cov
        out: FloatArray = s
        return out

    def kappa(self, cov: FloatArray, start: FloatArray | None = None) -> FloatArray:
        """The coverage factor of each row for covariances ``cov`` (m, d, d);
        ``start``: nearby factors to start from."""
        t = self.spec.target
        if t.coverage_factor is not None:
            return np.full(self.rows, t.coverage_factor)
        if self.dim == 1:
            return np.full(self.rows, z_two_sided(t.coverage))
        out = np.full(self.rows, z_two_sided(t.coverage))
        tr = np.einsum("rdd->r", cov)
        ok = tr > 0
        if ok.any():
            st = None if start is None else start[ok]
            out[ok] = radius_factor(np.linalg.eigvalsh(cov[ok]), t.coverage, st)
        return out


def build_design(spec: ToleranceSpec, calibration: CalibrationModel | None = None) -> Design:
    """Jacobians over the workspace, mapped through the calibration if any.

    Raises ValueError if the length target finds no pair of poses at least
    ``min_length_mm`` apart.
    """
    poses = spec.workspace.poses()
    pts, jac = Model(spec.params).points_jacobians(poses)
    m_map = calibration.error_map() if calibration is not None else np.eye(jac.shape[2])
    g = jac @ m_map  # what is left of each parameter's error after calibration
    if calibration is not None:
        # a column the calibration absorbs (to rounding) has no effect left at all
        left = np.linalg.norm(g, axis=1) <= 1e-9 * np.linalg.norm(jac, axis=1)
        g = np.where(left[:, None, :], 0.0, g)
    h = jac[:, :, : spec.joints].copy()  # encoder readings: never calibrated away
    cal = (
        np.einsum("pdi,ij,pkj->pdk", jac, calibration.covariance, jac)
        if calibration is not None
        else np.zeros((poses.shape[0], 3, 3))
    )
    res_var = spec.residual_u_mm**2 / 3.0  # isotropic, per axis
    t = spec.target
    if t.quantity == "point":
        res = np.broadcast_to(res_var * np.eye(3), (poses.shape[0], 3, 3)).copy()
        return Design(
            spec,
            poses,
            pts,
            g,
            h,
            cal + res,
            res,
            np.full(poses.shape[0], t.value_mm),
            np.stack([np.arange(poses.shape[0])] * 2, axis=1),
            np.zeros(poses.shape[0]),
            m_map,
            calibration,
        )
    pairs = length_pairs(pts, t.min_length_mm, spec.workspace.seed)
    if pairs.shape[0] == 0:
        raise ValueError(
            f"no pair of workspace poses is at least {t.min_length_mm:g} mm apart: "
            "give more poses or a smaller min_length_mm"
        )
    a, b = pairs[:, 0], pairs[:, 1]
    diff = pts[a] - pts[b]
    lengths = np.linalg.norm(diff, axis=1)
    n = diff / lengths[:, None]
    raw_l = np.abs(np.einsum("rd,rdi->ri", n, jac[a] - jac[b]))
    gl = np.einsum("rd,rdi->ri", n, g[a] - g[b])
    # rounding noise: a rigid motion of the whole arm (theta1, d1) changes no
    # length, exactly; nor does what calibration absorbs
    noise = (np.abs(gl) <= 1e-10 * raw_l.max(axis=1, keepdims=True)) | (np.abs(gl) <= 1e-9 * raw_l)
    gl = np.where(noise, 0.0, gl)[:, None, :]
    hl = np.sqrt(np.einsum("rd,rdj->rj", n, h[a]) ** 2 + np.einsum("rd,rdj->rj", n, h[b]) ** 2)[
        :, None, :
    ]
    dl = np.einsum("rd,rdi->ri", n, jac[a] - jac[b])
    cal_l = (
        np.einsum("ri,ij,rj->r", dl, calibration.covariance, dl)
        if calibration is not None
        else np.zeros(pairs.shape[0])
    )
    res_l = np.full(pairs.shape[0], 2.0 * res_var)  # one probing error at each end
    return Design(
        spec,
        poses,
        pts,
        gl,
        hl,
        (cal_l + res_l)[:, None, None],
        res_l[:, None, None],
        t.limit_mm(lengths),
        pairs,
        lengths,
        m_map,
        calibration,
    )


def length_pairs(points: FloatArray, min_length_mm: float, seed: int) -> npt.NDArray[np.int64]:
    """Pairs of pose indices (k, 2) for the length target.

    The poses are shuffled (seeded) and paired in turn (0-1, 2-3, ...);
    pairs shorter than ``min_length_mm`` are dropped.
    """
    n = points.shape[0]
    order = np.random.default_rng(seed + 7919).permutation(n)
    pairs = order[: 2 * (n // 2)].reshape(-1, 2)
    keep = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1) >= min_length_mm
    out: npt.NDArray[np.int64] = pairs[keep].astype(np.int64)
    return out
