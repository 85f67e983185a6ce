"""The probe-point uncertainty a calibration of any arm leaves (issue 26).

:func:`aacmm.calibration.report.point_uncertainty` propagates the calibrated
parameters' covariance to the probe point. For the paper's arm it runs
:func:`aacmm.uncertainty.propagate`, which takes the paper's 25 parameters;
for any other :class:`~aacmm.arm.Arm` it runs :func:`propagate_arm` here:
the same two methods on the arm's P parameters,

* linear (GUM): Sigma_p = J Sigma J^T with the core's 3 x P Jacobian at the
  calibrated parameters, the 95 % interval +-1.96 u;
* Monte Carlo (JCGM 101): ``trials`` correlated normal draws of the
  parameters (x = L z, L L^T = Sigma), every draw's probe points computed
  with the C core (:func:`aacmm.core.perturbed_points`), the standard
  deviation and the 2.5 / 97.5 % quantiles of the deviations;

at random workspace poses (every joint uniform in [-pi, pi), seeded as
:func:`aacmm.uncertainty.propagate` seeds them: ``seed + 1``) and at given
poses. Each pose is a :class:`aacmm.uncertainty.report.PoseResult`, so the
figure and the JSON are those of the paper's arm.

Pure library code; ValueError for bad arguments, KinematicsError for a drawn
arm the core refuses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from aacmm.arm import Arm
from aacmm.core import FloatArray, Model, perturbed_points
from aacmm.uncertainty.report import PoseResult

K95 = 1.959963984540054
#: Trials per batch of draws (bounds the memory: trials x poses x 3 doubles per batch).
_CHUNK = 2048


@dataclass(frozen=True)
class ArmPointUncertainty:
    """The point uncertainty of an arm's calibration: ``given`` then ``workspace`` poses.

    ``names``/``units``: the arm's parameters (column order); ``u``: their
    standard uncertainties (sqrt of the covariance's diagonal).
    """

    names: tuple[str, ...]
    units: tuple[str, ...]
    u: FloatArray
    trials: int
    seed: int
    given: tuple[PoseResult, ...]
    workspace: tuple[PoseResult, ...]

    @property
    def poses(self) -> tuple[PoseResult, ...]:
        return self.given + self.workspace

    def valid_fraction(self) -> float:
        ps = self.poses
        return sum(p.valid for p in ps) / len(ps) if ps else 0.0


def _tolerance(u: FloatArray, ndig: int = 1) -> FloatArray:
    """JCGM 101 section 8: half a unit of the ``ndig``-th significant digit of u."""
    out = np.zeros_like(u)
    nz = u > 0
    out[nz] = 0.5 * 10.0 ** (np.floor(np.log10(u[nz])) - ndig + 1)
    return out


def propagate_arm(
    arm: Arm,
    covariance: FloatArray,
    trials: int = 20_000,
    workspace: int = 100,
    seed: int = 0,
    poses_rad: FloatArray | None = None,
) -> ArmPointUncertainty:
    """The covariance (P, P; rad, mm) of ``arm``'s parameters propagated to its probe
    point, linear and Monte Carlo (module doc).

    Raises ValueError for a covariance of another size or not finite, trials < 2,
    workspace < 0, or no pose at all.
    """
    p = arm.n_params
    cov = np.asarray(covariance, dtype=np.float64)
    if cov.shape != (p, p) or not np.all(np.isfinite(cov)):
        raise ValueError(f"the covariance must be a finite {p} x {p} matrix")
    if trials < 2 or workspace < 0:
        raise ValueError(f"trials must be >= 2 and workspace >= 0, got {trials}, {workspace}")
    given = (
        np.empty((0, arm.n_joints))
        if poses_rad is None
        else np.asarray(poses_rad, dtype=np.float64).reshape(-1, arm.n_joints)
    )
    ws = np.random.default_rng(seed + 1).uniform(-math.pi, math.pi, (workspace, arm.n_joints))
    poses = np.concatenate([given, ws])
    if poses.shape[0] == 0:
        raise ValueError("no poses: give poses or a workspace size > 0")
    p_nom, jac = Model(arm).points_jacobians(poses)
    split = jac * (jac @ cov)  # (n, 3, P): J_ak (Sigma J^T)_ka
    var_lin = split.sum(axis=2)
    contrib = split.sum(axis=1)
    lam, vec = np.linalg.eigh(0.5 * (cov + cov.T))
    root = vec * np.sqrt(np.clip(lam, 0.0, None))
    rng = np.random.default_rng(seed)
    dev = np.empty((trials, poses.shape[0], 3))
    for start in range(0, trials, _CHUNK):
        m = min(_CHUNK, trials - start)
        draws = rng.standard_normal((m, p)) @ root.T
        dev[start : start + m] = perturbed_points(arm, draws, poses) - p_nom[None]
    u_mc = dev.std(axis=0, ddof=1)
    bias = dev.mean(axis=0)
    q = np.quantile(dev, (0.025, 0.975), axis=0)  # (2, n, 3)
    r95 = np.quantile(np.linalg.norm(dev, axis=2), 0.95, axis=0)
    out = []
    for i in range(poses.shape[0]):
        ul = np.sqrt(np.clip(var_lin[i], 0.0, None))
        ci_l = np.stack([-K95 * ul, K95 * ul], axis=1)
        ci_m = q[:, i, :].T.copy()
        delta = _tolerance(ul)
        out.append(
            PoseResult(
                poses[i].copy(),
                p_nom[i].copy(),
                ul,
                u_mc[i].copy(),
                bias[i].copy(),
                ci_l,
                ci_m,
                float(np.sqrt(ul @ ul)),
                float(np.sqrt(u_mc[i] @ u_mc[i])),
                float(r95[i]),
                contrib[i].copy(),
                delta,
                bool(np.all(np.abs(ci_l - ci_m) <= delta[:, None])),
            )
        )
    k = given.shape[0]
    return ArmPointUncertainty(
        arm.param_names,
        arm.param_units,
        np.sqrt(np.clip(np.diag(cov), 0.0, None)),
        trials,
        seed,
        tuple(out[:k]),
        tuple(out[k:]),
    )


def to_json(res: ArmPointUncertainty) -> dict[str, Any]:
    """JSON-ready data (mm, rad), with the keys of :func:`aacmm.uncertainty.to_json`'s
    poses and parameters."""

    def pose(p: PoseResult) -> dict[str, Any]:
        return {
            "theta_rad": p.theta_rad.tolist(),
            "point_mm": p.point_mm.tolist(),
            "u_lin_mm": p.u_lin.tolist(),
            "u_mc_mm": p.u_mc.tolist(),
            "bias_mc_mm": p.bias_mc.tolist(),
            "ci95_lin_mm": p.ci_lin.tolist(),
            "ci95_mc_mm": p.ci_mc.tolist(),
            "u3_lin_mm": p.u3_lin,
            "u3_mc_mm": p.u3_mc,
            "r95_mc_mm": p.r95_mc,
            "jcgm101_delta_mm": p.delta.tolist(),
            "agree": p.valid,
        }

    return {
        "trials": res.trials,
        "seed": res.seed,
        "uncertainties": {
            n: {"u": float(u), "unit": unit, "distribution": "normal"}
            for n, unit, u in zip(res.names, res.units, res.u, strict=True)
        },
        "given_poses": [pose(p) for p in res.given],
        "workspace_poses": [pose(p) for p in res.workspace],
        "agreement": {"valid_fraction": res.valid_fraction()},
    }
