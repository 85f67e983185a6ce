"""From a measurement plan to the operator's articulations (the choreography).

:func:`choreograph` gives every slot of an :class:`aacmm.plans.Plan` the true
joint angles the simulated operator will probe it with, on the true arm,
before anything moves (docs/simulator.md, "Scenarios"):

- **cone** steps (a seat probed in N articulations, single-point articulation
  and pivot practice): N articulations as different as possible
  (:func:`~aacmm.simulation.articulation.most_different` among about 2N
  solutions, the stylus within 50 deg of vertical);
- **articulation** steps (ISO 10360-12 articulated location): one such
  articulation per group, its points probed from it;
- **sphere, plane, points, length** steps: the arm moves from point to point
  as a person would, each point solved from the previous articulation; the
  first point of a step (and of each ball-bar position) starts from a random
  articulation, so positions are probed in varied arm configurations.

Stylus directions: into a seat from above (within 50 deg of vertical); onto a
surface within 30 deg of its normal. The true tip is put on each slot's
``target.tip_mm`` (the probe-ball centre: the seat point, or the surface point
offset by the ball radius along the normal) by :func:`~aacmm.simulation.ik.solve`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aacmm.arm import Arm as ArmModel
from aacmm.core import Params
from aacmm.errors import AacmmError
from aacmm.plans import Plan, Slot
from aacmm.simulation.articulation import (
    acceptable,
    candidates,
    joint_distance,
    joint_spread_deg,
    most_different,
)
from aacmm.simulation.ik import ARM_LIMITS, Arm, JointLimits, solve
from aacmm.simulation.operator import approach_for

FloatArray = npt.NDArray[np.float64]


class ScenarioError(AacmmError, ValueError):
    """A plan the simulated operator cannot perform (exit status 2 in the CLI)."""


@dataclass(frozen=True)
class PlannedPoint:
    """One slot with the true articulation it is probed from."""

    slot: Slot
    target_mm: FloatArray
    theta: FloatArray  #: true joint angles with the tip exactly on the target


@dataclass(frozen=True)
class Choreography:
    """Every slot's articulation, and each step's joint spread (deg)."""

    points: tuple[PlannedPoint, ...]
    spread_deg: dict[str, list[float]]  #: step id -> spread of joints 1..N


def _target(plan: Plan, slot: Slot) -> FloatArray:
    if slot.target is None:
        art = f"artefact {slot.artefact!r}" if slot.artefact else "its free points"
        raise ScenarioError(
            f"{_where(plan)}: step {slot.step_id!r}: {art} has no nominal location "
            "(location_mm); the simulated operator needs one"
        )
    return np.asarray(slot.target.tip_mm, dtype=np.float64)


def _where(plan: Plan) -> str:
    """The plan's name in a message: its file, else its name (never its text)."""
    return str(plan.path) if plan.path is not None else plan.name


def choreograph(
    plan: Plan,
    arm: Arm,
    rng: np.random.Generator,
    limits: JointLimits = ARM_LIMITS,
    progress: Callable[[int, int], None] | None = None,
) -> Choreography:
    """The articulation of every slot of ``plan`` on ``arm`` (module doc), within
    ``limits`` (one per joint of the arm: :data:`~aacmm.simulation.ik.ARM_LIMITS`
    for the paper's arm, any :class:`~aacmm.simulation.ik.JointLimits` for another).

    Raises:
        ScenarioError: a slot without a nominal target, or a target the arm
            cannot reach within its limits.
    """
    if limits.joints != arm.joints:
        raise ValueError(
            f"the joint limits are for {limits.joints} joints, the arm has {arm.joints}"
        )
    out: dict[int, PlannedPoint] = {}
    total = len(plan.slots)

    def done(p: PlannedPoint) -> None:
        out[p.slot.index] = p
        if progress is not None:
            progress(len(out), total)

    def fresh(slot: Slot, count: int) -> list[FloatArray]:
        target = _target(plan, slot)
        normal = slot.target.normal if slot.target is not None else None
        found = candidates(arm, target, approach_for(normal), count, rng, limits, 12 * count + 24)
        if not found:
            raise ScenarioError(
                f"{_where(plan)}: step {slot.step_id!r} point {slot.point_index + 1}: "
                f"target {np.round(target, 3).tolist()} mm is out of the arm's reach"
            )
        return [s.theta for s in found]

    def follow(slot: Slot, theta: FloatArray) -> FloatArray:
        """Solve ``slot`` from ``theta`` (a nearby articulation), else afresh near it."""
        target = _target(plan, slot)
        normal = slot.target.normal if slot.target is not None else None
        approach = approach_for(normal)
        want = -approach.unit_axis()
        sol = solve(arm, target, theta, posture=theta, stylus=want, limits=limits)
        if acceptable(sol, arm, approach):
            return sol.theta
        options = fresh(slot, 8)
        return min(options, key=lambda q: joint_distance(q, theta))

    for step in plan.steps:
        slots = plan.step_slots(step.index)
        if not slots:
            continue
        if step.procedure == "cone":
            found = fresh(slots[0], 2 * len(slots) + 8)
            if len(found) < len(slots):
                raise ScenarioError(
                    f"{_where(plan)}: step {step.id!r}: only {len(found)} of {len(slots)} "
                    "articulations reach the seat within the joint limits"
                )
            chosen = _tour([found[k] for k in most_different(found, len(slots))])
            for slot, k in zip(slots, range(len(chosen)), strict=True):
                done(PlannedPoint(slot, _target(plan, slot), chosen[k]))
        elif step.procedure == "articulation":
            groups: dict[int, list[Slot]] = {}
            for slot in slots:
                groups.setdefault(slot.articulation_index or 0, []).append(slot)
            found = fresh(slots[0], 2 * len(groups) + 8)
            picked = _tour([found[k] for k in most_different(found, len(groups))])
            if len(picked) < len(groups):
                raise ScenarioError(
                    f"{_where(plan)}: step {step.id!r}: only {len(picked)} articulations found"
                )
            for theta, members in zip(picked, groups.values(), strict=False):
                for slot in members:
                    done(PlannedPoint(slot, _target(plan, slot), follow(slot, theta)))
        else:
            prev: FloatArray | None = None
            position: int | None = None
            for slot in slots:
                if prev is None or slot.position_index != position:
                    options = fresh(slot, 6)
                    theta = options[int(rng.integers(len(options)))]
                else:
                    theta = follow(slot, prev)
                position = slot.position_index
                prev = theta
                done(PlannedPoint(slot, _target(plan, slot), theta))

    points = tuple(out[i] for i in range(total))
    spread: dict[str, list[float]] = {}
    for step in plan.steps:
        th = [p.theta for p in points if p.slot.step_index == step.index]
        if th:
            spread[step.id] = [round(float(v), 2) for v in joint_spread_deg(th)]
    return Choreography(points, spread)


def _tour(thetas: list[FloatArray]) -> list[FloatArray]:
    """The same articulations in the order a person would take them: each next
    one the nearest in joint space to the one before (greedy tour)."""
    if not thetas:
        return []
    left = list(thetas[1:])
    out = [thetas[0]]
    while left:
        k = min(range(len(left)), key=lambda i: joint_distance(left[i], out[-1]))
        out.append(left.pop(k))
    return out


def plan_poses(
    plan: Plan,
    params: Params | ArmModel,
    seed: int = 0,
    limits: JointLimits = ARM_LIMITS,
) -> FloatArray:
    """The joint angles (n_slots, N) in rad the simulated operator probes every
    slot of ``plan`` with, on an arm of structural parameters ``params`` (the
    paper's form or any arm, with its ``limits``), with no noise: the
    articulations of ``aacmm sim --scenario PLAN --seed SEED`` on that arm (a
    pure function of its arguments).

    Raises:
        ScenarioError: as :func:`choreograph`.
    """
    choreo = choreograph(plan, Arm(params), np.random.default_rng(seed), limits)
    return np.array([p.theta for p in choreo.points])
