"""The simulated operator: moves the true arm and presses its buttons.

An :class:`Operator` holds the simulator's control channel
(:mod:`aacmm.simulation.control`) and the arm's :class:`~aacmm.simulation.truth.Truth`.
It moves the arm along smooth joint-space trajectories (minimum-jerk
profiles, the roll joints the short way round, the hinges inside their
limits), sending the true encoders' counts at :attr:`Pace.update_hz`, and
probes a point the way a person does: to a point short of the target along
the stylus, onto the target, a short dwell, press, hold, release, back.

What is true and what is measured at a probed point:

1. the tip is put on ``target + probing noise`` (the truth's ``probing``
   sigma, isotropic, a fresh draw per press) by inverse kinematics on the
   true model (:mod:`aacmm.simulation.ik`) at the links' temperatures
   (``temperatures_c``: the truth's thermal profile scales its lengths), to
   within 1e-9 mm;
2. the counts are the true encoders' readings of those angles: eccentricity
   plus a fresh draw of encoder noise for every update sent
   (:meth:`Truth.counts`); the press is taken with the counts in force;
3. the device computes with its own stored parameter set.

:class:`Pace` sets the timing: about 1 s per point by default; ``fast``
sends each move's end pose only and never sleeps (tests).

The operator talks to anything with the :class:`Channel` methods: the
simulator's :class:`~aacmm.simulation.control.ControlChannel`, or a
:class:`RecordingChannel` (no device: it keeps the counts in force at each
press), with which a library user or a test runs the operator of any arm
(issue 26: N joints, the truth's encoders, the given joint limits) without
the device simulator.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from aacmm.core import Params
from aacmm.errors import AacmmError
from aacmm.protocol import Button
from aacmm.simulation.articulation import Approach
from aacmm.simulation.ik import ARM_LIMITS, Arm, JointLimits, solve, wrap
from aacmm.simulation.thermal import params_at
from aacmm.simulation.truth import Truth

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Pace:
    """Timing of the operator's motions (seconds, rad/s)."""

    fast: bool = False  #: no sleeping: move ends only (tests)
    update_hz: float = 500.0  #: counts sent per second while moving or holding
    joint_speed_rad_s: float = 3.5  #: peak speed of the fastest joint in a move
    min_move_s: float = 0.3
    approach_mm: float = 15.0  #: probe approach: start this far back along the stylus
    approach_s: float = 0.12
    dwell_s: float = 0.12  #: still on the target before the press
    hold_s: float = 0.08  #: button held
    reaction_s: float = 1.0  #: from "a client listens" to the first move

    def move_duration(self, delta: FloatArray) -> float:
        """A min-jerk move's duration: peak speed 1.875 * max|delta| / T."""
        if self.fast:
            return 0.0
        return max(self.min_move_s, 1.875 * float(np.max(np.abs(delta))) / self.joint_speed_rad_s)


FAST = Pace(fast=True, reaction_s=0.3)


class Channel(Protocol):
    """What the operator needs of the device's encoder and button inputs."""

    @property
    def closed(self) -> bool: ...

    def set_counts(self, counts: Sequence[int]) -> None: ...

    def press(self, button: int = 0) -> None: ...

    def release(self, button: int = 0) -> None: ...


@dataclass
class RecordingChannel:
    """A :class:`Channel` without a device: it keeps the counts in force and, per
    press, the button and those counts (what a device would read at the edge)."""

    counts: tuple[int, ...] = ()
    presses: list[tuple[int, tuple[int, ...]]] = field(default_factory=list)
    updates: int = 0
    temperatures: list[tuple[float | None, ...]] = field(default_factory=list)
    """Every ``temps`` the operator sent, in order."""

    @property
    def closed(self) -> bool:
        return False

    def set_temperatures(self, temps_c: Sequence[float | None]) -> None:
        self.temperatures.append(tuple(temps_c))

    def set_counts(self, counts: Sequence[int]) -> None:
        self.counts = tuple(int(c) for c in counts)
        self.updates += 1

    def press(self, button: int = 0) -> None:
        self.presses.append((button, self.counts))

    def release(self, button: int = 0) -> None:
        pass


#: The paper's arm's start posture (deg): upper arm up, forearm level, wrist down.
PAPER_HOME_DEG: tuple[float, ...] = (0.0, 135.0, 0.0, 90.0, 0.0, 180.0)


class Stopped(AacmmError):
    """The operator was asked to stop (a signal) or the simulator went away."""


@dataclass
class Press:
    """One press of a button, as the operator made it (the truth of a trigger)."""

    button: int
    label: str
    target_mm: FloatArray  #: where the tip was meant to be (the plan's target)
    probed_mm: FloatArray  #: where the true tip was (target + probing noise + any misprobe)
    theta_rad: FloatArray  #: the true, unquantised joint angles (encoder model input)
    counts: tuple[int, ...]  #: the readings in force at the press
    ik_error_mm: float  #: |true tip(theta) - probed_mm|
    misprobe_mm: float = 0.0
    slot: int | None = None
    extra: dict[str, object] = field(default_factory=dict)


def min_jerk(s: npt.ArrayLike) -> FloatArray:
    """The minimum-jerk profile 10 s^3 - 15 s^4 + 6 s^5 on [0, 1]."""
    x = np.clip(np.asarray(s, dtype=np.float64), 0.0, 1.0)
    out: FloatArray = x * x * x * (10.0 - 15.0 * x + 6.0 * x * x)
    return out


def home_posture(truth: Truth[Any], limits: JointLimits) -> FloatArray:
    """Where the operator starts: :data:`PAPER_HOME_DEG` for the paper's arm, else
    each joint at the centre of its range."""
    if isinstance(truth.params, Params) and limits.joints == len(PAPER_HOME_DEG):
        return np.array([math.radians(d) for d in PAPER_HOME_DEG])
    return np.asarray(limits.centre_rad, dtype=np.float64)


class Operator:
    """Drives the true arm through a :class:`Channel` (see the module doc).

    ``limits`` must have the truth's joint count (:data:`ARM_LIMITS`: the
    paper's arm); raises ValueError if not.
    """

    def __init__(
        self,
        chan: Channel,
        truth: Truth[Any],
        rng: np.random.Generator,
        pace: Pace = Pace(),
        limits: JointLimits = ARM_LIMITS,
        start: npt.ArrayLike | None = None,
        stop: threading.Event | None = None,
        temperatures_c: Sequence[float] | None = None,
        temperatures_at: Callable[[float], Sequence[float]] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if limits.joints != truth.joints:
            raise ValueError(
                f"the joint limits are for {limits.joints} joints, the arm has {truth.joints}"
            )
        self.chan = chan
        self.truth = truth
        #: the links' temperatures (degC, one per link; None: the truth's reference)
        self.temperatures_c = None if temperatures_c is None else tuple(temperatures_c)
        #: the true arm the poses are solved on: the truth's lengths at the links'
        #: temperatures (its thermal profile, :func:`~aacmm.simulation.thermal.params_at`)
        self.arm = Arm(
            truth.params
            if self.temperatures_c is None
            else params_at(truth.params, truth.thermal, self.temperatures_c)
        )
        #: a temperature profile: the links' temperatures (degC) ``s`` seconds after the
        #: operator started; followed at every probe (the arm rescaled, the device told)
        self.temperatures_at = temperatures_at
        self._clock = clock
        self._t0 = clock()
        self.rng = rng
        self.pace = pace
        self.limits = limits
        self.stop = stop or threading.Event()
        self.tick: Callable[[], None] | None = None  #: called at every update while moving
        home = home_posture(truth, limits) if start is None else np.asarray(start)
        self.theta = limits.canonical(home)
        self.presses: list[Press] = []
        self.buttons = 0
        self.last_counts: tuple[int, ...] = ()

    # ------------------------------------------------------------ sending

    def check(self) -> None:
        """Raise :class:`Stopped` if a stop was asked for or the simulator ended."""
        if self.stop.is_set():
            raise Stopped("stopped")
        if self.chan.closed:
            raise Stopped("the simulator ended")

    def pause(self, seconds: float) -> None:
        """Wait ``seconds`` (raises :class:`Stopped` when asked to stop)."""
        self._pause(seconds)

    def _pause(self, seconds: float) -> None:
        self.check()
        if self.stop.wait(seconds):
            raise Stopped("stopped")

    def send_pose(self, theta: npt.ArrayLike) -> tuple[int, ...]:
        """Send the true encoders' readings at ``theta`` (a fresh noise draw)."""
        counts = tuple(int(c) for c in self.truth.counts(np.asarray(theta), self.rng)[0])
        self.chan.set_counts(counts)
        self.last_counts = counts
        return counts

    def hold(self, seconds: float) -> None:
        """Stay still for ``seconds``, the encoders read as noisy as they are."""
        if self.pace.fast or seconds <= 0:
            return
        period = 1.0 / self.pace.update_hz
        end = time.monotonic() + seconds
        while True:
            left = end - time.monotonic()
            if left <= 0:
                break
            self._pause(min(period, left))
            self.send_pose(self.theta)

    def move_to(self, goal: npt.ArrayLike, duration: float | None = None) -> None:
        """Move smoothly from the current angles to ``goal`` (canonical intervals)."""
        start = self.limits.canonical(self.theta)
        end = self.limits.canonical(np.asarray(goal, dtype=np.float64))
        rolls = ~np.isfinite(np.asarray(self.limits.half_range_rad))
        delta = end - start
        delta[rolls] = wrap(delta[rolls])  # the short way round
        t_move = self.pace.move_duration(delta) if duration is None else duration
        if self.pace.fast or t_move <= 0:
            self.check()
            self.theta = end
            self.send_pose(end)
            return
        period = 1.0 / self.pace.update_hz
        t0 = time.monotonic()
        while True:
            s = (time.monotonic() - t0) / t_move
            if s >= 1.0:
                break
            self.theta = start + float(min_jerk(s)) * delta
            self.send_pose(self.theta)
            if self.tick is not None:
                self.tick()
            self._pause(period)
        self.theta = end
        self.send_pose(end)

    # ------------------------------------------------------------ buttons

    def press_and_release(self, button: int) -> tuple[int, ...]:
        """Press ``button`` with the arm still, hold, release; the counts of the press."""
        counts = self.last_counts
        self.chan.press(button)
        self.hold(self.pace.hold_s)
        self.chan.release(button)
        return counts

    # ------------------------------------------------------------ probing

    def reach(
        self, target: npt.ArrayLike, theta_hint: npt.ArrayLike, stylus: npt.ArrayLike | None = None
    ) -> tuple[FloatArray, float]:
        """True joint angles putting the tip on ``target`` near ``theta_hint``; and the error."""
        sol = solve(
            self.arm, target, theta_hint, posture=theta_hint, stylus=stylus, limits=self.limits
        )
        return sol.theta, sol.error_mm

    def probe(
        self,
        target_mm: npt.ArrayLike,
        theta: npt.ArrayLike,
        label: str,
        slot: int | None = None,
        misprobe_mm: float = 0.0,
        button: int = Button.CAPTURE,
    ) -> Press:
        """Probe ``target_mm`` from the articulation ``theta`` (on the target already).

        Approach from ``approach_mm`` back along the stylus, settle on
        ``target + probing noise`` (plus ``misprobe_mm`` in a random direction,
        a deliberate bad point), dwell, press, hold, release, back off.
        """
        self.follow_temperatures()
        target = np.asarray(target_mm, dtype=np.float64).reshape(3)
        th = np.asarray(theta, dtype=np.float64).reshape(self.truth.joints)
        stylus = self.arm.stylus(th)
        back = th
        if not self.pace.fast:  # the approach along the stylus (no time to see it at --fast)
            back, _ = self.reach(target - self.pace.approach_mm * stylus, th, stylus)
            self.move_to(back)
        offset = self.truth.probing_offset_mm(self.rng)
        if misprobe_mm > 0:
            d = self.rng.normal(size=3)
            offset = offset + misprobe_mm * d / np.linalg.norm(d)
        probed = target + offset
        on, _ = self.reach(probed, th, stylus)
        self.move_to(on, duration=None if self.pace.fast else self.pace.approach_s)
        self.hold(self.pace.dwell_s)
        counts = self.press_and_release(button)
        press = Press(
            button=button,
            label=label,
            target_mm=target,
            probed_mm=probed,
            theta_rad=on.copy(),
            counts=counts,
            ik_error_mm=float(np.linalg.norm(self.arm.tip(on) - probed)),
            misprobe_mm=misprobe_mm,
            slot=slot,
        )
        if self.temperatures_c is not None:
            press.extra["temperatures_c"] = list(self.temperatures_c)
        self.presses.append(press)
        if not self.pace.fast:
            self.move_to(back, duration=self.pace.approach_s)
        return press

    def follow_temperatures(self) -> None:
        """With a profile (:attr:`temperatures_at`): the links at its temperatures now
        (to 0.01 degC): the true arm's lengths rescaled and the device's sensors told,
        when they changed."""
        if self.temperatures_at is None:
            return
        now = tuple(round(float(t), 2) for t in self.temperatures_at(self._clock() - self._t0))
        if now == self.temperatures_c:
            return
        self.temperatures_c = now
        self.arm = Arm(params_at(self.truth.params, self.truth.thermal, now))
        send = getattr(self.chan, "set_temperatures", None)
        if send is not None:
            send(list(now))

    def undo(self, label: str = "undo") -> Press:
        """Press and release the undo button (1) where the arm is."""
        counts = self.press_and_release(Button.UNDO)
        press = Press(
            button=Button.UNDO,
            label=label,
            target_mm=np.full(3, np.nan),
            probed_mm=self.arm.tip(self.theta),
            theta_rad=self.theta.copy(),
            counts=counts,
            ik_error_mm=0.0,
        )
        self.presses.append(press)
        return press


def approach_for(normal: npt.ArrayLike | None, seat_tilt_deg: float = 50.0) -> Approach:
    """The admissible stylus cone: along a surface normal (within 30 deg), or a
    seat probed from above (within ``seat_tilt_deg`` of vertical)."""
    if normal is None:
        return Approach((0.0, 0.0, 1.0), seat_tilt_deg)
    n = np.asarray(normal, dtype=np.float64)
    return Approach((float(n[0]), float(n[1]), float(n[2])), 30.0)
