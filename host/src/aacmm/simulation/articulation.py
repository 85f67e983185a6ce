"""Arm articulations that put the tip on a target, spread the way practice asks.

Calibration with point constraints and the ISO 10360-12 / ASME B89.4.22
articulation tests want the same point probed with the arm in configurations
as different as possible (elbow and wrist on either side, the stylus leaning
in different directions). :func:`candidates` solves the inverse kinematics
(:mod:`aacmm.simulation.ik`) from random postures inside the joint limits,
each with a stylus direction drawn inside the admissible cone of the target
(a seat is probed from above, a surface along its normal);
:func:`most_different` picks the requested number among them by
farthest-point selection in joint space (wrapped angle differences), so each
added articulation is the one farthest from all chosen before.
:func:`joint_spread_deg` measures the result per joint.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aacmm.simulation.ik import ARM_LIMITS, Arm, JointLimits, Solution, solve, wrap

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Approach:
    """Admissible stylus directions at a target: within ``max_tilt_deg`` of ``-axis``.

    ``axis`` points out of the material (a surface normal; straight up for a
    seat), so the stylus, which points from the wrist to the tip, points
    roughly along ``-axis``.
    """

    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    max_tilt_deg: float = 50.0

    def unit_axis(self) -> FloatArray:
        a = np.asarray(self.axis, dtype=np.float64)
        out: FloatArray = a / np.linalg.norm(a)
        return out

    def tilt_deg(self, stylus: npt.ArrayLike) -> float:
        """Angle between a stylus direction and ``-axis``, in degrees."""
        s = np.asarray(stylus, dtype=np.float64)
        c = float(np.clip(-(s @ self.unit_axis()) / np.linalg.norm(s), -1.0, 1.0))
        return math.degrees(math.acos(c))

    def draw(self, rng: np.random.Generator) -> FloatArray:
        """A random stylus direction in the cone (uniform in tilt and azimuth)."""
        w = -self.unit_axis()
        helper = np.zeros(3)
        helper[int(np.argmin(np.abs(w)))] = 1.0
        u = helper - (helper @ w) * w
        u /= np.linalg.norm(u)
        v = np.cross(w, u)
        tilt = math.radians(rng.uniform(0.0, self.max_tilt_deg))
        az = rng.uniform(0.0, 2.0 * math.pi)
        out: FloatArray = math.cos(tilt) * w + math.sin(tilt) * (
            math.cos(az) * u + math.sin(az) * v
        )
        return out


def facing_posture(
    target: npt.ArrayLike, rng: np.random.Generator, limits: JointLimits
) -> FloatArray:
    """A random posture inside the limits with the base turned towards the target
    (joint 1 turns about the base z axis, as in every arm aacmm models)."""
    q = limits.sample(rng)
    t = np.asarray(target, dtype=np.float64)
    q[0] = math.atan2(t[1], t[0]) + rng.normal(0.0, 0.6)
    return wrap(q)


def acceptable(sol: Solution, arm: Arm, approach: Approach, slack_deg: float = 0.5) -> bool:
    """On target (converged), inside the limits, stylus inside the approach cone."""
    return (
        sol.converged
        and sol.within_limits
        and approach.tilt_deg(arm.stylus(sol.theta)) <= approach.max_tilt_deg + slack_deg
    )


def candidates(
    arm: Arm,
    target: npt.ArrayLike,
    approach: Approach,
    count: int,
    rng: np.random.Generator,
    limits: JointLimits = ARM_LIMITS,
    max_tries: int | None = None,
) -> list[Solution]:
    """Up to ``count`` acceptable IK solutions for ``target`` from random starts."""
    out: list[Solution] = []
    tries = max_tries if max_tries is not None else 4 * count + 8
    for _ in range(tries):
        if len(out) >= count:
            break
        q0 = facing_posture(target, rng, limits)
        sol = solve(arm, target, q0, stylus=approach.draw(rng), limits=limits)
        if acceptable(sol, arm, approach):
            out.append(sol)
    return out


def joint_distance(a: npt.ArrayLike, b: npt.ArrayLike) -> float:
    """Euclidean norm of the wrapped joint-angle differences (rad)."""
    d = wrap(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64))
    return float(np.linalg.norm(d))


def most_different(thetas: Sequence[npt.ArrayLike], count: int) -> list[int]:
    """Indices of ``count`` of ``thetas`` by farthest-point selection (the first one first)."""
    if len(thetas) == 0:
        return []
    chosen = [0]
    dist = np.array([joint_distance(q, thetas[0]) for q in thetas])
    while len(chosen) < min(count, len(thetas)):
        k = int(np.argmax(dist))
        chosen.append(k)
        dist = np.minimum(dist, np.array([joint_distance(q, thetas[k]) for q in thetas]))
    return chosen


def joint_spread_deg(thetas: npt.ArrayLike) -> FloatArray:
    """Per joint, the shortest arc (deg) that holds all its angles (0 for one pose)."""
    th = np.atleast_2d(np.asarray(thetas, dtype=np.float64))
    out = np.zeros(th.shape[1])
    for j in range(th.shape[1]):
        a = np.sort(np.mod(th[:, j], 2.0 * math.pi))
        if a.size < 2:
            continue
        gaps = np.diff(np.concatenate([a, [a[0] + 2.0 * math.pi]]))
        out[j] = math.degrees(2.0 * math.pi - float(np.max(gaps)))
    return out
