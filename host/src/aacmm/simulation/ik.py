"""Inverse kinematics of the (true) arm, in double precision, on the core.

The probe tip of the arm is ``p(theta) = o6(theta) + l * z6(theta)`` (docs/kinematics.md),
so with the core's models for probe lengths ``l`` and ``l + 1`` the stylus
direction is ``u = p_{l+1} - p_l`` and its joint Jacobian the difference of
the two models' theta columns; the theta columns of the core's 3x25 Jacobian
are the positional joint Jacobian. No other kinematics code is involved.
Any :class:`aacmm.arm.Arm` (issue 26) works the same way: N joints, the
stylus the unit vector of its tip (the second model's tip 1 mm further along
it), the first N Jacobian columns the joint Jacobian;
:meth:`JointLimits.around` gives limits for any joint count.

:func:`solve` moves the tip onto a target by damped least squares
(Levenberg-Marquardt steps) with a soft stylus direction and a
preferred posture in the null space, then polishes the position alone with
undamped minimum-norm Gauss-Newton steps until the tip is within
``tol_mm`` (1e-9 mm by default) of the target.

:data:`ARM_LIMITS` are the joint limits of the simulated arm (the paper's
geometry, docs/simulator.md): the three roll joints (1, 3, 5) turn without
limit, the three hinges have ranges centred on their stretched-out position
(pi): shoulder +-120 deg, elbow +-155 deg, wrist +-115 deg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Final

import numpy as np
import numpy.typing as npt

from aacmm.arm import Arm as ArmModel
from aacmm.core import Model, Params

FloatArray = npt.NDArray[np.float64]
TWO_PI: Final = 2.0 * math.pi


def wrap(a: npt.ArrayLike) -> FloatArray:
    """Angles wrapped to [-pi, pi)."""
    out: FloatArray = (np.asarray(a, dtype=np.float64) + math.pi) % TWO_PI - math.pi
    return out


@dataclass(frozen=True)
class JointLimits:
    """Joint ranges as centre +- half range (rad); ``inf`` half range = no limit."""

    centre_rad: tuple[float, ...]
    half_range_rad: tuple[float, ...]

    def __post_init__(self) -> None:
        c = tuple(float(x) for x in self.centre_rad)
        h = tuple(float(x) for x in self.half_range_rad)
        if len(c) != len(h) or not c:
            raise ValueError(
                f"joint limits need one centre and one half range per joint, got "
                f"{len(c)} and {len(h)}"
            )
        if not all(math.isfinite(x) for x in c) or any(math.isnan(x) or x <= 0 for x in h):
            raise ValueError("joint limits need finite centres and half ranges > 0 (inf: none)")
        object.__setattr__(self, "centre_rad", c)
        object.__setattr__(self, "half_range_rad", h)

    @classmethod
    def around(
        cls, centre_deg: tuple[float, ...], half_range_deg: tuple[float | None, ...]
    ) -> JointLimits:
        """Limits from degrees, one per joint; ``None`` half range: no limit (a roll)."""
        return cls(
            tuple(math.radians(c) for c in centre_deg),
            tuple(math.inf if h is None else math.radians(h) for h in half_range_deg),
        )

    @classmethod
    def from_ranges(cls, ranges_rad: tuple[tuple[float, float], ...]) -> JointLimits:
        """Limits from (lowest, highest) pairs in rad, one per joint; ``(-inf, inf)``:
        no limit (an arm model's ``joint_limits_rad``, :mod:`aacmm.models`)."""
        centre, half = [], []
        for lo, hi in ranges_rad:
            if math.isinf(lo) or math.isinf(hi):
                centre.append(0.0)
                half.append(math.inf)
            else:
                centre.append(0.5 * (lo + hi))
                half.append(0.5 * (hi - lo))
        return cls(tuple(centre), tuple(half))

    @property
    def joints(self) -> int:
        """The number of joints limited."""
        return len(self.centre_rad)

    def canonical(self, theta: npt.ArrayLike) -> FloatArray:
        """The angles in each joint's own interval: centre + wrap(theta - centre)."""
        c = np.asarray(self.centre_rad)
        out: FloatArray = c + wrap(np.asarray(theta, dtype=np.float64) - c)
        return out

    def margin_rad(self, theta: npt.ArrayLike) -> FloatArray:
        """Distance to the nearest limit per joint (negative: outside; inf: unlimited)."""
        c = np.asarray(self.centre_rad)
        out: FloatArray = np.asarray(self.half_range_rad) - np.abs(
            wrap(np.asarray(theta, dtype=np.float64) - c)
        )
        return out

    def contains(self, theta: npt.ArrayLike) -> bool:
        return bool(np.all(self.margin_rad(theta) >= 0.0))

    def sample(self, rng: np.random.Generator, shrink: float = 0.9) -> FloatArray:
        """A random posture inside ``shrink`` times the ranges (rolls: any angle)."""
        half = np.minimum(np.asarray(self.half_range_rad), math.pi) * shrink
        out: FloatArray = np.asarray(self.centre_rad) + rng.uniform(-1.0, 1.0, self.joints) * half
        return wrap(out)


#: Joint limits of the simulated arm (module doc). Rolls: 1, 3, 5; hinges: 2, 4, 6.
ARM_LIMITS: Final = JointLimits(
    centre_rad=(0.0, math.pi, 0.0, math.pi, 0.0, math.pi),
    half_range_rad=(
        math.inf,
        math.radians(120.0),
        math.inf,
        math.radians(155.0),
        math.inf,
        math.radians(115.0),
    ),
)


def _longer(params: Params | ArmModel) -> Params | ArmModel:
    """The same arm with its tip 1 mm further along the stylus (the tip's direction)."""
    if isinstance(params, Params):
        return replace(params, l_mm=params.l_mm + 1.0)
    t = np.asarray(params.tip_mm)
    norm = float(np.linalg.norm(t))
    if norm == 0.0:
        raise ValueError("an arm whose tip is at the last frame's origin has no stylus direction")
    longer = t + t / norm
    return replace(params, tip_mm=(float(longer[0]), float(longer[1]), float(longer[2])))


class Arm:
    """Tip, stylus direction and their joint Jacobians of one arm (core, double):
    the paper's :class:`~aacmm.core.Params` or any :class:`aacmm.arm.Arm`."""

    def __init__(self, params: Params | ArmModel) -> None:
        self.params = params
        self.model = Model(params)
        self._longer = Model(_longer(params))
        self.joints = self.model.joints

    def tip(self, theta: npt.ArrayLike) -> FloatArray:
        """Probe tip (3,) in mm at joint angles ``theta`` (N,)."""
        return self.model.point(np.asarray(theta, dtype=np.float64))

    def tip_jacobian(self, theta: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Tip (3,) and d tip / d theta (3, N)."""
        p, j = self.model.point_jacobian(np.asarray(theta, dtype=np.float64))
        return p, j[:, : self.joints]

    def pose(self, theta: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Tip, d tip/d theta, stylus direction u (unit, base to tip) and d u/d theta."""
        th = np.asarray(theta, dtype=np.float64)
        n = self.joints
        p, j = self.model.point_jacobian(th)
        p1, j1 = self._longer.point_jacobian(th)
        return p, j[:, :n], p1 - p, (j1 - j)[:, :n]

    def stylus(self, theta: npt.ArrayLike) -> FloatArray:
        """The stylus direction (3,), a unit vector from the wrist towards the tip."""
        th = np.asarray(theta, dtype=np.float64)
        out: FloatArray = self._longer.point(th) - self.model.point(th)
        return out


@dataclass(frozen=True)
class Solution:
    """A result of :func:`solve`."""

    theta: FloatArray  #: joint angles (N,), canonical in the limits' intervals
    error_mm: float  #: |tip - target| at ``theta``
    stylus_error_rad: float  #: angle between the stylus and the wanted direction (0 if none)
    iterations: int
    converged: bool  #: error_mm <= tol_mm
    within_limits: bool


def _dls(a: FloatArray, b: FloatArray, damping: float) -> tuple[FloatArray, FloatArray]:
    """Damped least-squares step ``A^T (A A^T + d^2 I)^-1 b`` and the damped
    null-space projector ``I - A^T (A A^T + d^2 I)^-1 A`` (``damping`` > 0)."""
    m = a @ a.T + damping * damping * np.eye(a.shape[0])
    x = np.linalg.solve(m, np.column_stack([b, a]))
    step: FloatArray = a.T @ x[:, 0]
    null: FloatArray = np.eye(a.shape[1]) - a.T @ x[:, 1:]
    return step, null


def solve(
    arm: Arm,
    target_mm: npt.ArrayLike,
    theta0: npt.ArrayLike,
    *,
    stylus: npt.ArrayLike | None = None,
    stylus_weight_mm: float = 300.0,
    posture: npt.ArrayLike | None = None,
    posture_gain: float = 0.5,
    limits: JointLimits = ARM_LIMITS,
    tol_mm: float = 1e-9,
    max_iter: int = 200,
    max_step_rad: float = 0.35,
) -> Solution:
    """Joint angles that put the tip of ``arm`` on ``target_mm``.

    ``limits`` must have the arm's joint count (:data:`ARM_LIMITS`: the
    paper's arm); raises ValueError if not.

    Starting from ``theta0``, damped least-squares steps on the tip position
    and, if given, on the stylus direction ``stylus`` (weighted by
    ``stylus_weight_mm``: a soft goal), pulling the remaining freedom towards
    ``posture`` (default ``theta0``); then undamped minimum-norm steps on the
    position alone until ``|tip - target| <= tol_mm``. When the goals outnumber
    the joints (a stylus direction for an arm of fewer than 6 joints) the first
    phase ends once its steps stall (below 1e-6 rad): the position then still
    differs from the target by the compromise with the stylus.
    """
    n = arm.joints
    if limits.joints != n:
        raise ValueError(f"the joint limits are for {limits.joints} joints, the arm has {n}")
    target = np.asarray(target_mm, dtype=np.float64).reshape(3)
    th = np.asarray(theta0, dtype=np.float64).reshape(n).copy()
    pref = th.copy() if posture is None else np.asarray(posture, dtype=np.float64).reshape(n)
    want = None
    if stylus is not None:
        want = np.asarray(stylus, dtype=np.float64).reshape(3)
        want = want / np.linalg.norm(want)
    iterations = 0
    # Phase 1: position + soft stylus direction + posture in the null space.
    err = math.inf
    while iterations < max_iter:
        iterations += 1
        p, jp, u, ju = arm.pose(th)
        rp = target - p
        err = float(np.linalg.norm(rp))
        if want is not None:
            a = np.vstack([jp, stylus_weight_mm * ju])
            b = np.concatenate([rp, stylus_weight_mm * (want - u)])
        else:
            a, b = jp, rp
        damping = min(1.0, max(err, 1e-3))  # mm: strong far away, small on target
        step, null = _dls(a, b, damping)
        step += null @ (posture_gain * wrap(pref - th))
        big = float(np.max(np.abs(step)))
        if big > max_step_rad:
            step *= max_step_rad / big
        th = th + step
        if err < 1e-6 and big < 1e-4:
            break
        if a.shape[0] > n and big < 1e-6:
            # more goals than joints (the stylus direction of an arm of 4 or 5 joints):
            # the compromise between position and stylus is found, phase 2 ends on target
            break
    # Phase 2: the position alone, minimum-norm Gauss-Newton to tol_mm.
    for _ in range(50):
        p, jp = arm.tip_jacobian(th)
        rp = target - p
        err = float(np.linalg.norm(rp))
        if err <= tol_mm:
            break
        step = np.asarray(np.linalg.lstsq(jp, rp, rcond=None)[0], dtype=np.float64)
        big = float(np.max(np.abs(step)))
        if big > max_step_rad:
            step *= max_step_rad / big
        th = th + step
        iterations += 1
    th = limits.canonical(th)
    err = float(np.linalg.norm(arm.tip(th) - target))
    s_err = 0.0
    if want is not None:
        cosang = float(np.clip(arm.stylus(th) @ want, -1.0, 1.0))
        s_err = math.acos(cosang)
    return Solution(
        theta=th,
        error_mm=err,
        stylus_error_rad=s_err,
        iterations=iterations,
        converged=err <= tol_mm,
        within_limits=limits.contains(th),
    )
