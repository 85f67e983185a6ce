"""Statistics of a calibration at its solution: covariance, chi-square check, outliers.

:func:`parameter_covariance` ``(J^T W J)^-1`` in a parametrisation;
:func:`chi_square_check`, which, when the residuals are too large, searches
for the unmodelled error (a once-per-revolution angle error of a joint, as
encoder eccentricity gives); :func:`find_outliers`, the normalised residual
of each probed point (or length position) against a family-wise false-alarm
rate. Used by :mod:`aacmm.calibration.solve`; the public ones are in
:mod:`aacmm.calibration`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from aacmm.calibration.parameters import param_names
from aacmm.calibration.problem import KIND_LENGTH, Evaluation, Problem
from aacmm.calibration.results import ChiSquare, Outlier, Suspect
from aacmm.core import FloatArray

DEFAULT_ALPHA_CHI2 = 0.001
DEFAULT_ALPHA_OUTLIER = 0.01


def parameter_covariance(ev: Evaluation, basis: FloatArray) -> FloatArray:
    """(P, P) covariance of basis @ x from the whitened Jacobian (zero outside the basis).

    From the normal matrix: the basis spans identifiable directions only, so
    it is well conditioned (its condition number squares that of the scaled
    Jacobian, ~1e4, far from rounding trouble).
    """
    if basis.shape[1] == 0:
        return np.zeros((basis.shape[0], basis.shape[0]))
    a = ev.jac @ basis
    cov: FloatArray = basis @ np.linalg.inv(a.T @ a) @ basis.T
    return cov


def _dof(problem: Problem, ev: Evaluation, rank: int) -> int:
    return int(ev.r.size - problem.n_nuisance - rank)


def chi_square_check(
    problem: Problem, ev: Evaluation, basis: FloatArray, rank: int, alpha: float
) -> ChiSquare:
    chi2 = ev.chi2
    dof = _dof(problem, ev, rank)
    if dof <= 0:
        return ChiSquare(chi2, dof, math.nan, alpha, "no dof")
    p = float(stats.chi2.sf(chi2, dof))
    if p < alpha:
        return ChiSquare(chi2, dof, p, alpha, "incomplete", _suspects(problem, ev, basis, dof))
    if float(stats.chi2.cdf(chi2, dof)) < alpha:
        return ChiSquare(chi2, dof, p, alpha, "overstated")
    return ChiSquare(chi2, dof, p, alpha, "consistent")


def _suspects(problem: Problem, ev: Evaluation, basis: FloatArray, dof: int) -> tuple[Suspect, ...]:
    """Once-per-revolution angle errors of the joints that the residuals show.

    The model extended by e_k(q) = s_k sin q_k + c_k cos q_k on every joint (what
    an eccentric encoder disc gives), fitted to the residuals jointly: the
    columns dp/dq_k sin q_k and dp/dq_k cos q_k, projected like the rest and
    made orthogonal to the identifiable columns (so the coefficients are
    those of the joint fit with the arm's parameters, Frisch-Waugh-Lovell).
    A joint is a suspect when its pair is significant given the others (Wald
    statistic over chi-square(2) at 1e-6); the suspects are returned only if
    the extended model explains at least half of the excess chi^2 - dof.
    A joint whose first harmonic the calibration estimates already (``c<j>_1``
    among the parameters) is not searched.
    """
    theta = problem.obs.theta_rad
    modelled = set(param_names(ev.params))
    searched = [k for k in range(theta.shape[1]) if f"c{k + 1}_1" not in modelled]
    joints = len(searched)
    if joints == 0:
        return ()
    extra = np.zeros((theta.shape[0], 3, 2 * joints))
    for i, k in enumerate(searched):
        col = ev.point_jac[:, :, k]  # dp/dq_k
        extra[:, :, 2 * i] = col * np.sin(theta[:, k])[:, None]
        extra[:, :, 2 * i + 1] = col * np.cos(theta[:, k])[:, None]
    ext = problem.evaluate(ev.params, extra_point_jac=extra)
    a = ev.jac @ basis
    b = ext.jac[:, ev.jac.shape[1] :]
    if a.shape[1]:
        q, _ = np.linalg.qr(a)
        b = b - q @ (q.T @ b)
    excess = max(ev.chi2 - dof, 0.0)
    coef, *_ = np.linalg.lstsq(b, ev.r, rcond=None)
    fit = b @ coef
    explained = float(fit @ (2 * ev.r - fit))
    if explained < max(0.5 * excess, 25.0):
        return ()
    cov = np.linalg.pinv(b.T @ b)
    limit = float(stats.chi2.isf(1e-6, 2))
    out = []
    for i, k in enumerate(searched):
        ck = coef[2 * i : 2 * i + 2]
        vk = cov[2 * i : 2 * i + 2, 2 * i : 2 * i + 2]
        wald = float(ck @ np.linalg.pinv(vk) @ ck)
        if wald > limit:
            out.append(
                Suspect(
                    f"joint {k + 1} once-per-revolution angle",
                    wald,
                    excess,
                    float(np.hypot(*ck)),
                    "rad",
                    float(np.sqrt(np.trace(vk) / 2.0)),
                    explained,
                )
            )
    out.sort(key=lambda s: -s.chi2_drop)
    return tuple(out)


def find_outliers(
    problem: Problem, ev: Evaluation, alpha: float = DEFAULT_ALPHA_OUTLIER
) -> tuple[Outlier, ...]:
    """Probed points (or length positions) whose normalised residual is improbable.

    Each unit's statistic is sum(r_i^2 / (1 - h_i)) over its rows (chi-square
    with as many dof as rows if the stated uncertainties hold), divided by a
    robust scale (the median statistic over its expected median, at least 1,
    per kind) so that one understated uncertainty does not flag everything;
    a unit is flagged if its tail probability is below ``alpha`` / units
    (Bonferroni: ``alpha`` is the chance of any false alarm).
    """
    unit = ev.unit
    ok = unit >= 0
    denom = np.clip(1.0 - ev.h[ok], 1e-12, None)
    stat = np.bincount(unit[ok], weights=ev.r[ok] ** 2 / denom, minlength=problem.n_units)
    rows = np.bincount(unit[ok], minlength=problem.n_units)
    size = np.sqrt(
        np.bincount(unit[ok], weights=(ev.r[ok] * ev.sigma[ok]) ** 2, minlength=problem.n_units)
    )
    present = rows > 0
    n_units = int(present.sum())
    if n_units == 0:
        return ()
    scale = np.ones(problem.n_units)
    kinds = problem.unit_kind
    for kind in np.unique(kinds[present]):
        sel = present & (kinds == kind)
        dof = rows[sel]
        med = float(np.median(stat[sel] / stats.chi2.median(dof)))
        scale[sel] = max(1.0, med)
    t = stat / scale
    thr = np.zeros(problem.n_units)
    for dof in np.unique(rows[present]):
        thr[rows == dof] = float(stats.chi2.isf(alpha / n_units, dof))
    out = []
    for i in np.flatnonzero(present & (t > thr)):
        u = problem.unit(int(i))
        label = problem.obs.label(u.poses[0])
        if u.kind == KIND_LENGTH:
            label = f"{label} (length position {u.position + 1})"
        out.append(
            Outlier(
                problem.obs.constraints[u.constraint].name,
                u.kind,
                u.poses,
                label,
                u.position,
                float(t[i]),
                float(thr[i]),
                float(stats.chi2.sf(t[i], rows[i])),
                float(size[i]),
            )
        )
    out.sort(key=lambda o: -o.statistic)
    return tuple(out)
