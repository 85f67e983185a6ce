"""Shared pieces of the fitters: errors, the fit result, frames, the Gauss-Newton engine.

The iterative fits (sphere, circle, cylinder) run on batches: every array has
a leading batch axis ``B`` so that a thousand small fits cost one numpy loop
(see :func:`aacmm.geometry.fit_spheres`). A single fit is a batch of one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

import numpy as np
import numpy.typing as npt

from aacmm.errors import AacmmError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: A fit is refused as degenerate when the smallest singular value of its
#: (column-scaled) Jacobian is below this fraction of the largest.
RANK_TOL = 1e-9
#: Gauss-Newton stops when no parameter moves by more than this fraction of the
#: data's extent (angles: this many radians).
STEP_TOL = 1e-13
#: Below this relative step a step that no longer shrinks ends the iteration.
STALL_TOL = 1e-11
MAX_ITER = 200
#: Points spread less than this (rms, mm) across a direction a feature needs
#: are degenerate there: 0.1 um is the arm's point resolution on the link, so
#: a smaller spread is rounding, not geometry (collinear "plane" points, ...).
SPREAD_MM = 1e-4


class GeometryError(AacmmError, ValueError):
    """Points from which the requested feature cannot be fitted."""


class TooFewPointsError(GeometryError):
    """Fewer points than the feature needs."""


class DegenerateGeometryError(GeometryError):
    """The points do not determine the feature (collinear points for a plane, ...)."""


class ConvergenceError(GeometryError):
    """The iterative fit did not converge."""


F = TypeVar("F")


@dataclass(frozen=True)
class Fit(Generic[F]):
    """A least-squares fit of one feature.

    ``feature`` is the fitted surface after probe-ball compensation (see the
    fit functions). ``residuals`` are the signed orthogonal distances of the
    given points from the fitted (uncompensated, ball-centre) feature in mm,
    positive outwards/away from the material; for a circle the in-plane
    radial deviations, for a line and a point the distances (>= 0). ``form``
    is defined per feature in :mod:`aacmm.geometry` (the range of the
    residuals for surfaces). ``covariance`` is the parameter covariance
    ``s^2 (J^T J)^-1`` in the parameters named by ``parameter_names`` (local
    to the fitted feature: see docs/verification.md), with ``s^2`` the
    residual sum of squares over the degrees of freedom (NaN when there are
    none); ``ssr`` is the minimised sum of squares (for a circle it includes
    the out-of-plane distances, for a line both perpendicular components).
    ``std`` holds the standard uncertainties of the quantities users
    read (``x``, ``y``, ``z``, ``radius``, ``tilt`` in rad, ...).
    """

    kind: str
    feature: F
    residuals: FloatArray
    form: float
    rms: float
    ssr: float
    covariance: FloatArray
    parameter_names: tuple[str, ...]
    std: dict[str, float]
    n_points: int
    dof: int
    iterations: int = 0
    probe_radius: float = 0.0
    extra: dict[str, float] = field(default_factory=dict)

    @property
    def sigma(self) -> float:
        """Residual standard deviation ``s`` (mm), NaN without degrees of freedom."""
        return float(np.sqrt(self.ssr / self.dof)) if self.dof > 0 else float("nan")


def make_fit(
    kind: str,
    feature: F,
    residuals: FloatArray,
    cov: FloatArray,
    names: tuple[str, ...],
    dof: int,
    *,
    ssr: float | None = None,
    form: float | None = None,
    iterations: int = 0,
    probe_radius: float = 0.0,
    extra: dict[str, float] | None = None,
) -> Fit[F]:
    """A :class:`Fit` with the derived numbers filled in.

    ``form`` defaults to the range of the residuals, ``ssr`` to their sum of
    squares; ``std`` is the square root of the covariance diagonal.
    """
    return Fit(
        kind=kind,
        feature=feature,
        residuals=residuals,
        form=float(np.ptp(residuals)) if form is None else form,
        rms=float(np.sqrt(np.mean(residuals**2))),
        ssr=float(np.sum(residuals**2)) if ssr is None else ssr,
        covariance=cov,
        parameter_names=names,
        std=dict(zip(names, map(float, np.sqrt(np.diag(cov))), strict=True)),
        n_points=len(residuals),
        dof=dof,
        iterations=iterations,
        probe_radius=float(probe_radius),
        extra=extra or {},
    )


def as_points(points: npt.ArrayLike, need: int, what: str) -> FloatArray:
    """``points`` as a finite (n, 3) float array with n >= need.

    Raises:
        ValueError: wrong shape or a non-finite coordinate.
        TooFewPointsError: fewer than ``need`` points.
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("points contain NaN or infinite coordinates")
    if p.shape[0] < need:
        raise TooFewPointsError(f"a {what} needs at least {need} points, got {p.shape[0]}")
    return p


def extent(points: FloatArray) -> float:
    """Largest distance of a point from the centroid (>= a tiny floor), the fit's length scale."""
    c = points.mean(axis=-2, keepdims=True)
    return float(max(np.sqrt(np.max(np.sum((points - c) ** 2, axis=-1))), 1e-300))


def unit(v: FloatArray) -> FloatArray:
    out: FloatArray = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return out


def canonical_sign(v: FloatArray) -> FloatArray:
    """Flip unit vectors (..., 3) so that their largest-magnitude component is positive."""
    idx = np.argmax(np.abs(v), axis=-1)
    s = np.sign(np.take_along_axis(v, idx[..., None], axis=-1))
    s[s == 0] = 1.0
    out: FloatArray = v * s
    return out


def frame(w: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Unit ``u``, ``v`` making ``(u, v, w)`` right-handed orthonormal; ``w`` is (..., 3)."""
    # cross with the coordinate axis least aligned with w: never near-parallel
    e = np.zeros_like(w)
    idx = np.argmin(np.abs(w), axis=-1)
    np.put_along_axis(e, idx[..., None], 1.0, axis=-1)
    u = unit(np.cross(e, w))
    v = np.cross(w, u)
    return u, v


def spreads(points: FloatArray) -> FloatArray:
    """Rms spreads (..., 3) of point sets (..., n, 3) along their principal directions,
    largest first."""
    q = points - points.mean(axis=-2, keepdims=True)
    out: FloatArray = np.linalg.svd(q, compute_uv=False) / np.sqrt(points.shape[-2])
    return out


def rank_check(jac: FloatArray, what: str, reason: str) -> None:
    """Refuse a (B, m, p) Jacobian whose column-scaled singular values span > 1/RANK_TOL.

    Raises:
        DegenerateGeometryError: with ``reason`` as the message.
    """
    norms = np.linalg.norm(jac, axis=-2, keepdims=True)
    norms[norms == 0] = 1.0
    s = np.linalg.svd(jac / norms, compute_uv=False)
    bad = s[..., -1] <= RANK_TOL * s[..., 0]
    if np.any(bad):
        raise DegenerateGeometryError(f"{what}: {reason}")


def covariance(jac: FloatArray, res: FloatArray) -> tuple[FloatArray, int]:
    """``s^2 (J^T J)^-1`` for (B, m, p) Jacobians and (B, m) residuals, and the dof."""
    m, p = jac.shape[-2], jac.shape[-1]
    dof = m - p
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    inv = np.einsum("...ki,...k,...kj->...ij", vt, 1.0 / s**2, vt)
    if dof > 0:
        s2 = np.sum(res**2, axis=-1) / dof
    else:
        s2 = np.full(res.shape[:-1], np.nan)
    out: FloatArray = inv * s2[..., None, None]
    return out, dof


State = tuple[FloatArray, ...]
Linearise = Callable[[State], tuple[FloatArray, FloatArray]]
Update = Callable[[State, FloatArray], State]


def _select(mask: BoolArray, new: State, old: State) -> State:
    out = []
    for a, b in zip(new, old, strict=True):
        m = mask.reshape(mask.shape + (1,) * (a.ndim - 1))
        out.append(np.where(m, a, b))
    return tuple(out)


def gauss_newton(
    state: State,
    linearise: Linearise,
    update: Update,
    scale: FloatArray,
    what: str,
    max_iter: int = MAX_ITER,
) -> tuple[State, FloatArray, FloatArray, int]:
    """Minimise the sum of squared residuals over a batch by damped Gauss-Newton.

    ``linearise(state)`` returns residuals (B, m) and their Jacobian (B, m, p)
    with respect to a local parameter increment; ``update(state, dx)`` applies
    an increment (B, p). Each step is the least-squares solution of the
    linearised problem (SVD); a step that raises the cost is halved until it
    does not (each batch member on its own). ``scale`` (p,) or (B, p) makes
    increments relative (1/extent for lengths, 1 for angles in rad).

    A member stops when its relative step falls below :data:`STEP_TOL`, or
    below :data:`STALL_TOL` without shrinking (the rounding floor: near the
    optimum of a fit with large residuals the cost is too flat for its
    changes to be resolved, so the steps, not the cost, decide).

    Returns the final state, its residuals and Jacobian, and the iterations.

    Raises:
        ConvergenceError: not converged after ``max_iter`` steps.
    """
    res, jac = linearise(state)
    cost = np.sum(res**2, axis=-1)
    batch = res.shape[0]
    done = np.zeros(batch, dtype=bool)
    prev = np.full(batch, np.inf)
    for it in range(1, max_iter + 1):
        u, s, vt = np.linalg.svd(jac, full_matrices=False)
        dx = -np.einsum("...ki,...k->...i", vt, np.einsum("...mk,...m->...k", u, res) / s)
        dx[done] = 0.0
        size = np.max(np.abs(dx) * scale, axis=-1)
        lam = np.ones(batch)
        for _ in range(60):
            trial = update(state, dx * lam[:, None])
            r_t, j_t = linearise(trial)
            c_t = np.sum(r_t**2, axis=-1)
            # steps at the rounding floor may not lower the cost: take them
            worse = (c_t > cost * (1.0 + 1e-12)) & (size * lam > STALL_TOL)
            if not np.any(worse):
                break
            lam[worse] *= 0.5
        ok = ~worse & ~done
        state = _select(ok, trial, state)
        res = np.where(ok[:, None], r_t, res)
        jac = np.where(ok[:, None, None], j_t, jac)
        cost = np.where(ok, c_t, cost)
        moved = size * lam
        done |= (moved <= STEP_TOL) | ((moved <= STALL_TOL) & (moved > 0.9 * prev)) | worse
        prev = np.where(ok, moved, prev)
        if np.all(done):
            return state, res, jac, it
    raise ConvergenceError(f"{what}: the fit did not converge in {max_iter} iterations")


def to_dict(fit: Fit[Any]) -> dict[str, Any]:
    """A JSON-ready summary of a fit (feature values, form, uncertainties)."""
    from dataclasses import asdict, is_dataclass

    feat: dict[str, Any] = {}
    if is_dataclass(fit.feature) and not isinstance(fit.feature, type):
        for k, v in asdict(fit.feature).items():
            feat[k] = np.asarray(v).tolist() if isinstance(v, np.ndarray | tuple) else v
    return {
        "kind": fit.kind,
        "feature": feat,
        "n_points": fit.n_points,
        "dof": fit.dof,
        "form_mm": fit.form,
        "rms_mm": fit.rms,
        # no degrees of freedom (2 points on a line): no sigma, no uncertainties;
        # null, not NaN, which is not JSON
        "sigma_mm": fit.sigma if fit.dof > 0 else None,
        "std": {k: (float(v) if np.isfinite(v) else None) for k, v in fit.std.items()},
        "probe_radius_mm": fit.probe_radius,
        "iterations": fit.iterations,
        "parameter_names": list(fit.parameter_names),
        "covariance": [
            [float(x) if np.isfinite(x) else None for x in row] for row in fit.covariance
        ],
        **({"extra": dict(fit.extra)} if fit.extra else {}),
    }
