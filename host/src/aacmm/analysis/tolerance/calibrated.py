"""Allocation for a calibrated arm: what calibration removes, what it leaves.

A calibration identifies some parameters from observations (cones, lengths,
reference points). To first order it sees the parameter error dq through its
identification Jacobian A (m x P, rows weighted by 1/noise; P = 25 for the
paper's arm, any arm's own P) and, solving a least-squares problem on the
identified columns I while the others (F, the
null space named by parameter) stay at nominal, it corrects

    dq_post = (I - G A) dq + e,     G = [A_I^+ ; 0],   e ~ N(0, C)

where e is the calibration's own error (its post-calibration covariance C).
The columns of M = I - G A for the identified parameters are zero: their
manufacturing error is removed whatever it was, so they need no tolerance
(only the calibration's range). The fixed parameters keep an error, but part
of it is absorbed by the identified ones (the calibration fits whatever best
explains the observations): their effective sensitivity at a pose is
J(p) M[:, F], which can be far smaller than J(p)[:, F], and zero where the
measurement cannot see them either.

Encoder reading errors vary from reading to reading, so no parameter
calibration removes them; they keep their full effect.

:class:`CalibrationModel` holds (A, F, C); ``aacmm.calibration`` provides
them for a calibration design or result.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aacmm.arm import Arm
from aacmm.core import PARAM_NAMES, FloatArray, Params

if TYPE_CHECKING:
    from aacmm.analysis.tolerance.request import CalibrationDesign
    from aacmm.calibration import CalibrationResult, Observations
    from aacmm.simulation.ik import JointLimits


@dataclass(frozen=True)
class CalibrationModel:
    """A calibration as the allocation sees it.

    ``jacobian`` (m, P): identification Jacobian at the nominal parameters,
    rows weighted by 1/noise, columns in ``names`` order (the arm's P
    parameters: :data:`aacmm.core.PARAM_NAMES`, the paper's 25, by default;
    any arm's ``param_names``); ``fixed``: the parameters the calibration does
    not identify (left at nominal); ``covariance`` (P, P): the
    post-calibration covariance of the identified parameters (rad, mm; zero
    for the fixed ones; default all zero); ``source``: a description for
    reports.

    Raises ValueError for wrong shapes, unknown names, a covariance that is
    not symmetric positive semi-definite, or identified columns that are
    rank deficient (they would not be identifiable).
    """

    jacobian: FloatArray
    fixed: tuple[str, ...]
    covariance: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    source: str = "calibration"
    names: tuple[str, ...] = PARAM_NAMES

    def __post_init__(self) -> None:
        names = tuple(self.names)
        cols = len(names)
        if cols == 0 or len(set(names)) != cols:
            raise ValueError("the parameter names must be distinct, at least one")
        object.__setattr__(self, "names", names)
        a = np.asarray(self.jacobian, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != cols or not np.all(np.isfinite(a)):
            raise ValueError(f"the identification Jacobian must be finite (m, {cols})")
        bad = [n for n in self.fixed if n not in names]
        if bad:
            raise ValueError(f"unknown parameter name(s) {', '.join(bad)}")
        c = np.asarray(self.covariance, dtype=np.float64)
        if c.size == 0:
            c = np.zeros((cols, cols))
        if c.shape != (cols, cols) or not np.all(np.isfinite(c)):
            raise ValueError(f"the covariance must be finite ({cols}, {cols})")
        if not np.allclose(c, c.T, rtol=1e-9, atol=1e-300):
            raise ValueError("the covariance must be symmetric")
        w = np.linalg.eigvalsh(c)
        if w.size and w.min() < -1e-9 * max(w.max(), 0.0):
            raise ValueError("the covariance must be positive semi-definite")
        object.__setattr__(self, "jacobian", a)
        object.__setattr__(self, "covariance", 0.5 * (c + c.T))
        object.__setattr__(self, "fixed", tuple(n for n in names if n in self.fixed))
        ident = self.identified_mask
        if ident.any():
            ai = a[:, ident]
            scale = np.linalg.norm(ai, axis=0)
            if np.any(scale == 0) or np.linalg.matrix_rank(ai / scale) < ai.shape[1]:
                raise ValueError(
                    "the identified parameters are not identifiable from this Jacobian "
                    "(rank deficient): list the null space in fixed"
                )

    @classmethod
    def from_observations(
        cls,
        obs: Observations,
        params: Params | Arm | None = None,
        free: tuple[str, ...] | None = None,
        source: str = "calibration design",
    ) -> CalibrationModel:
        """A calibration *design*: the data it will take, no measurement yet.

        The identification Jacobian and the predicted covariance come from
        :func:`aacmm.calibration.predicted_covariance` at ``params`` (default
        Table 1; any :class:`aacmm.arm.Arm`: its P parameters); the parameters
        it holds (unobservable from these data) and those outside ``free``
        stay at nominal. Raises ObservationError for unusable observations.
        """
        from aacmm.calibration import Problem, predicted_covariance
        from aacmm.calibration.parameters import param_names

        p: Params | Arm = Params() if params is None else params
        names = param_names(p)
        cov, ident = predicted_covariance(obs, p, free)
        jac = Problem(obs).evaluate(p).jac
        candidates = set(ident.names)
        fixed = tuple(n for n in names if n in ident.held or n not in candidates)
        return cls(jac, fixed, cov, source, names)

    @classmethod
    def from_plan(
        cls,
        design: CalibrationDesign,
        params: Params | Arm | None = None,
        limits: JointLimits | None = None,
    ) -> CalibrationModel:
        """A calibration *plan* at design time: the simulated operator's
        articulations for every slot (:func:`aacmm.simulation.scenario.plan_poses`)
        on the nominal arm (``params``, default Table 1, or any
        :class:`aacmm.arm.Arm`) within ``limits`` (default the paper's arm's,
        :data:`aacmm.simulation.ik.ARM_LIMITS`; another arm needs its own:
        ``JointLimits.from_ranges(model.joint_limits_rad)``), turned into
        observations as a session of that plan would be
        (:func:`aacmm.calibration.sessions.observations_from_plan`).

        Raises ValueError (PlanError, ScenarioError, ObservationError) for a
        missing or unusable plan, or an arm other than the paper's without limits.
        """
        from aacmm.calibration.sessions import observations_from_plan
        from aacmm.plans import load_plan
        from aacmm.simulation.ik import ARM_LIMITS
        from aacmm.simulation.scenario import plan_poses

        p: Params | Arm = Params() if params is None else params
        if limits is None:
            if not isinstance(p, Params):
                raise ValueError(
                    "a calibration plan on an arm other than the paper's needs its joint limits"
                )
            limits = ARM_LIMITS
        plan = load_plan(design.plan)
        theta = plan_poses(plan, p, design.seed, limits)
        obs, _, _ = observations_from_plan(plan, theta, design.sigma_mm, design.base_known)
        src = (
            f"plan {plan.name or design.plan}: {theta.shape[0]} points, "
            f"{design.sigma_mm * 1e3:g} um probing, operator seed {design.seed}"
        )
        return cls.from_observations(obs, p, design.free, source=src)

    @classmethod
    def from_result(
        cls, result: CalibrationResult, source: str = "calibration"
    ) -> CalibrationModel:
        """A finished calibration: its Jacobian at the solution, held and fixed
        parameters and covariance (scaled by chi^2/dof when that exceeds 1), on
        the arm it calibrated (its P parameters)."""
        from aacmm.calibration.parameters import param_names

        names = param_names(result.start)
        fixed = tuple(n for n in names if n in result.held or n in result.fixed)
        return cls(result.after.jac, fixed, result.scaled_covariance, source, names)

    @property
    def identified_mask(self) -> npt.NDArray[np.bool_]:
        """(P,) True for the parameters the calibration identifies."""
        return np.array([n not in self.fixed for n in self.names])

    @property
    def identified(self) -> tuple[str, ...]:
        return tuple(n for n in self.names if n not in self.fixed)

    def error_map(self) -> FloatArray:
        """M (P, P): manufacturing error dq -> error left after calibration (M dq).

        Masked least squares on the identified columns (scaled to unit norm
        for conditioning; the solution does not depend on the scaling).
        """
        a = self.jacobian
        ident = self.identified_mask
        m = np.eye(len(self.names))
        if ident.any():
            ai = a[:, ident]
            scale = np.linalg.norm(ai, axis=0)
            sol, *_ = np.linalg.lstsq(ai / scale, a, rcond=None)
            m[ident, :] -= sol / scale[:, None]
            m[:, ident] = 0.0  # exactly: calibration removes these errors whatever they are
        return m
