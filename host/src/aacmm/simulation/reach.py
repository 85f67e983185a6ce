"""Which targets of a measurement plan an arm cannot reach within its joint limits.

:func:`check_reach` takes a plan (:mod:`aacmm.plans`) and an arm (an arm model
of :mod:`aacmm.models`, with its joint limits, or an :class:`aacmm.arm.Arm` or
the paper's :class:`~aacmm.core.Params` with :class:`~aacmm.simulation.ik.JointLimits`)
and tries every distinct target of the plan the way the simulated operator
does (:mod:`aacmm.simulation.articulation`): inverse kinematics
(:func:`~aacmm.simulation.ik.solve`) from random postures inside the limits,
the base turned towards the target, the stylus drawn inside the target's
approach cone (a seat from above, within 50 deg of vertical; a surface within
30 deg of its normal). A target is reachable when one solution puts the tip
on it (1e-9 mm), inside every joint limit, with the stylus in the cone.

The items are the plan's distinct targets in plan order: a cone step's seat
is one item (all its articulations probe the same point), each end of each
position of a length step one, each point of a sphere, plane or points step
one (an articulation step's groups probe the same points: each point once).
Steps without a nominal target (an artefact without ``location_mm``) cannot
be checked and are listed apart (:attr:`ReachReport.unchecked`).

A pure function of its arguments (``seed`` fixes the random starts); no
printing. ``aacmm plan check PLAN --model NAME`` prints its result
(docs/plans.md, "Does a plan fit an arm").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np
import numpy.typing as npt

from aacmm.arm import Arm as ArmGeometry
from aacmm.core import Params
from aacmm.models import ArmModel
from aacmm.plans import Plan, Slot
from aacmm.simulation.articulation import acceptable, facing_posture
from aacmm.simulation.ik import ARM_LIMITS, Arm, JointLimits, solve
from aacmm.simulation.operator import approach_for

FloatArray = npt.NDArray[np.float64]

#: Random starts tried per target before it is called unreachable.
REACH_TRIES: Final = 40


@dataclass(frozen=True)
class ReachItem:
    """One distinct target of a plan and whether the arm reaches it.

    ``number`` counts the plan's items from 1 in plan order; ``slots`` are
    the plan's slot indices (from 0) that probe this target; ``theta_rad``
    a solution (N joint readings, rad) inside the limits with the stylus in
    the approach cone when ``reachable``, else None; ``reason`` says why not
    ("" when reachable); ``closest_mm`` is the smallest tip-to-target
    distance any start found (0 within 1e-9 mm when reachable).
    """

    number: int
    step_id: str
    label: str
    slots: tuple[int, ...]
    target_mm: tuple[float, float, float]
    reachable: bool
    theta_rad: tuple[float, ...] | None
    reason: str
    closest_mm: float


@dataclass(frozen=True)
class ReachReport:
    """The result of :func:`check_reach`: every item, and the steps not checked."""

    plan: str
    items: tuple[ReachItem, ...]
    unchecked: tuple[str, ...]  #: step ids without a nominal target

    @property
    def unreachable(self) -> tuple[ReachItem, ...]:
        """The items the arm cannot reach, in plan order."""
        return tuple(i for i in self.items if not i.reachable)

    @property
    def ok(self) -> bool:
        """True when the arm reaches every item."""
        return not self.unreachable


def _label(slot: Slot) -> str:
    if slot.procedure == "cone":
        return f"step {slot.step_id}: cone seat {slot.artefact}"
    if slot.procedure == "length":
        pos = (slot.position_index or 0) + 1
        return f"step {slot.step_id}: {slot.artefact} position {pos}, end {slot.end}"
    return f"step {slot.step_id}: point {slot.point_index + 1}"


def _items(plan: Plan) -> tuple[list[tuple[Slot, list[int]]], list[str]]:
    """The distinct targets (first slot, every slot index) and the unchecked steps."""
    items: list[tuple[Slot, list[int]]] = []
    unchecked: list[str] = []
    for step in plan.steps:
        seen: dict[tuple[float, ...], int] = {}
        for slot in plan.step_slots(step.index):
            if slot.target is None:
                if step.id not in unchecked:
                    unchecked.append(step.id)
                continue
            key = tuple(round(x, 9) for x in slot.target.tip_mm)
            if key in seen:
                items[seen[key]][1].append(slot.index)
            else:
                seen[key] = len(items)
                items.append((slot, [slot.index]))
    return items, unchecked


def _arm_and_limits(
    arm: ArmModel | ArmGeometry | Params, limits: JointLimits | None
) -> tuple[Arm, JointLimits]:
    if isinstance(arm, ArmModel):
        return Arm(arm.arm), limits or JointLimits.from_ranges(arm.joint_limits_rad)
    if limits is None:
        if isinstance(arm, Params):
            return Arm(arm), ARM_LIMITS
        raise ValueError("an aacmm.arm.Arm needs its joint limits (limits=JointLimits(...))")
    return Arm(arm), limits


def check_reach(
    plan: Plan,
    arm: ArmModel | ArmGeometry | Params,
    limits: JointLimits | None = None,
    *,
    seed: int = 0,
    tries: int = REACH_TRIES,
) -> ReachReport:
    """Every distinct target of ``plan`` and whether ``arm`` reaches it (module doc).

    ``limits``: the joint limits (default: an arm model's own; the simulator's
    :data:`~aacmm.simulation.ik.ARM_LIMITS` for the paper's ``Params``; required
    for an :class:`aacmm.arm.Arm`). ``tries`` random starts per target.

    Raises:
        ValueError: limits of another joint count, no limits for an Arm, or
            ``tries`` < 1.
    """
    if tries < 1:
        raise ValueError(f"tries must be at least 1, got {tries}")
    ik_arm, lim = _arm_and_limits(arm, limits)
    if lim.joints != ik_arm.joints:
        raise ValueError(
            f"the joint limits are for {lim.joints} joints, the arm has {ik_arm.joints}"
        )
    rng = np.random.default_rng(seed)
    found, unchecked = _items(plan)
    out: list[ReachItem] = []
    for number, (slot, indices) in enumerate(found, start=1):
        assert slot.target is not None
        target = np.asarray(slot.target.tip_mm, dtype=np.float64)
        approach = approach_for(slot.target.normal)
        closest = math.inf
        on_target = inside = False
        theta: tuple[float, ...] | None = None
        for _ in range(tries):
            q0 = facing_posture(target, rng, lim)
            sol = solve(ik_arm, target, q0, stylus=approach.draw(rng), limits=lim)
            closest = min(closest, sol.error_mm)
            on_target |= sol.converged
            inside |= sol.converged and sol.within_limits
            if acceptable(sol, ik_arm, approach):
                theta = tuple(float(t) for t in sol.theta)
                closest = sol.error_mm
                break
        if theta is not None:
            reason = ""
        elif inside:
            cone = "vertical (into a seat)" if slot.target.normal is None else "the surface normal"
            reason = (
                f"reached only with the stylus more than {approach.max_tilt_deg:g} deg from {cone}"
            )
        elif on_target:
            reason = "reached only outside the joint limits"
        else:
            reason = f"out of reach: the tip comes no closer than {closest:.1f} mm"
        out.append(
            ReachItem(
                number=number,
                step_id=slot.step_id,
                label=_label(slot),
                slots=tuple(indices),
                target_mm=(float(target[0]), float(target[1]), float(target[2])),
                reachable=theta is not None,
                theta_rad=theta,
                reason=reason,
                closest_mm=float(closest),
            )
        )
    return ReachReport(plan.name, tuple(out), tuple(unchecked))
