"""Running the simulated operator: a scenario in step with a capture client,
or the true arm wandering on its own.

:class:`ScenarioRun` performs a :class:`~aacmm.simulation.scenario.Choreography`
(docs/simulator.md, "Scenarios"):

1. it waits until a client streams from the device (the control channel
   reports STREAM_START; ``aacmm capture`` streams while it listens), so no
   press is made before anyone listens;
2. it probes the slots in plan order -- or, following a capture session
   (``follow``), always the slot the session's ``progress.json`` names next,
   waiting after each press until the session has taken it, and starting
   over from the progress file whenever the client restarts its stream (a
   resumed capture);
3. deliberate mis-probes (:class:`Misprobe`): the point probed off target,
   then undone with the second button and probed again (or kept, an outlier);
4. when every point is done it waits until the client stops streaming (and does
   not start again within a second).

:class:`Wander` moves the true arm through random postures instead (the
``walk`` motion of a simulator with a truth), optionally pressing button 0
every so often; :data:`STATIC_POSE_RAD` is the pose of its ``static`` motion.

Both are pure library code: they report through a ``say`` callback.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aacmm.errors import AacmmError
from aacmm.protocol import Button
from aacmm.simulation.articulation import joint_spread_deg
from aacmm.simulation.control import ControlChannel
from aacmm.simulation.operator import Operator, Press, Stopped
from aacmm.simulation.scenario import Choreography, PlannedPoint

#: The true arm's pose for the ``static`` motion of a simulator with a truth (rad,
#: joints 1..6; :meth:`~aacmm.simulation.ik.JointLimits.canonical` maps it into the
#: joints' intervals).
STATIC_POSE_RAD = (0.5, 0.6 + math.pi, -0.9, 0.4 + math.pi, 1.2, -0.3 + math.pi)

PROGRESS = "progress.json"
PROGRESS_FORMAT = "aacmm-progress-1"
POLL_S = 0.05


@dataclass(frozen=True)
class Misprobe:
    """A deliberate bad point: slot ``slot`` first probed ``offset_mm`` off target,
    then undone (button 1) and probed properly, unless ``keep`` (an outlier)."""

    slot: int
    offset_mm: float
    keep: bool = False


@dataclass(frozen=True)
class Progress:
    """What ``SESSION/progress.json`` says (written by ``aacmm capture``)."""

    next_slot: int
    points: int
    complete: bool


def read_progress(folder: Path, plan_sha256: str) -> Progress | None:
    """The session's progress, or None while it does not exist or is being written.

    Raises:
        AacmmError: the session belongs to another plan.
    """
    try:
        data = json.loads((folder / PROGRESS).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("format") != PROGRESS_FORMAT:
        return None
    if data.get("plan_sha256") != plan_sha256:
        raise AacmmError(f"{folder}: the session was captured with another plan")
    try:
        return Progress(int(data["next_slot"]), int(data["points"]), bool(data["complete"]))
    except (KeyError, TypeError, ValueError):
        return None


class ScenarioRun:
    """The operator performing a choreography (module doc)."""

    def __init__(
        self,
        operator: Operator,
        choreography: Choreography,
        plan_sha256: str,
        *,
        follow: Path | None = None,
        misprobes: tuple[Misprobe, ...] = (),
        say: Callable[[str], None] = lambda text: None,
        say_press: Callable[[str], None] | None = None,
        ack_timeout_s: float = 30.0,
    ) -> None:
        if not isinstance(operator.chan, ControlChannel):
            raise ValueError(
                "a scenario run follows a capture client: it needs the simulator's control channel"
            )
        self.op = operator
        self.chan: ControlChannel = operator.chan
        self.points = choreography.points
        self.choreography = choreography
        self.plan_sha256 = plan_sha256
        self.follow = follow
        self.misprobes = {m.slot: m for m in misprobes}
        self.stop = operator.stop
        self.say = say
        self.say_press = say_press
        self.ack_timeout_s = ack_timeout_s
        self.done_misprobes: set[int] = set()

    # ------------------------------------------------------------ waiting

    def _check(self) -> None:
        if self.stop.is_set():
            raise Stopped("stopped")
        if self.chan.closed:
            raise Stopped("the simulator ended")

    def wait_listening(self) -> None:
        """Until some link streams (a client listens), then a person's reaction time."""
        if any(s.active for s in self.chan.streams().values()):
            return
        self.say("waiting for a client to stream from the device (e.g. aacmm capture) ...")
        while not self.chan.wait_stream(True, timeout=POLL_S * 4):
            self._check()
        self.op.pause(self.op.pace.reaction_s)

    def wait_quiet(self, grace_s: float = 1.0) -> None:
        """Until no link streams any more (the client finished) and none starts
        again for ``grace_s`` (the client may still ask something, or resume)."""
        while True:
            while not self.chan.wait_stream(False, timeout=POLL_S * 4):
                self._check()
            starts = self.chan.starts()
            if not self.chan.wait_stream(after_starts=starts, timeout=grace_s):
                self._check()
                return

    def _progress(self) -> Progress:
        assert self.follow is not None
        while True:
            p = read_progress(self.follow, self.plan_sha256)
            if p is not None:
                return p
            self._check()
            time.sleep(POLL_S)

    def _wait_ack(self, before: Progress, starts: int) -> bool:
        """Until the session moved on from ``before``; False on a stream restart or timeout."""
        end = time.monotonic() + self.ack_timeout_s
        while time.monotonic() < end:
            self._check()
            p = read_progress(self.follow, self.plan_sha256) if self.follow else None
            if p is not None and (p.next_slot, p.points) != (before.next_slot, before.points):
                return True
            if self.chan.starts() != starts:
                return False
            time.sleep(POLL_S)
        self.say(f"no acknowledgement within {self.ack_timeout_s:g} s; reading the session again")
        return False

    # ------------------------------------------------------------ probing

    def _probe(self, p: PlannedPoint, offset_mm: float = 0.0) -> Press:
        s = p.slot
        label = f"{s.step_id} point {s.point_index + 1}"
        if s.end is not None:
            label += f" end {s.end}"
        return self.op.probe(p.target_mm, p.theta, label, slot=s.index, misprobe_mm=offset_mm)

    def _say_slot(self, p: PlannedPoint, what: str = "") -> None:
        """Each press, only to ``say_press``: the capture prompting for the same point
        (often in the same terminal) says it already."""
        if self.say_press is not None:
            k, n = p.slot.index + 1, len(self.points)
            self.say_press(f"operator presses {k}/{n}: {what}{p.slot.text}")

    def run(self) -> list[Press]:
        """Perform the choreography; the presses made (also in ``operator.presses``).

        Raises:
            Stopped: a stop was asked for or the simulator ended.
        """
        self.wait_listening()
        if self.follow is None:
            self._sequential()
        else:
            self._following()
        self.say("all points probed; waiting for the client to stop streaming")
        self.wait_quiet()
        return self.op.presses

    def _sequential(self) -> None:
        for p in self.points:
            self.wait_listening()
            self._check()
            m = self.misprobes.get(p.slot.index)
            if m is not None:
                self._say_slot(p, f"mis-probe {m.offset_mm:g} mm: ")
                self._probe(p, m.offset_mm)
                if m.keep:
                    continue
                self.op.undo(f"undo {p.slot.step_id} point {p.slot.point_index + 1}")
            self._say_slot(p)
            self._probe(p)

    def _following(self) -> None:
        bad_slot: int | None = None  # a mis-probe the session took and must undo
        while True:
            done = read_progress(self.follow, self.plan_sha256) if self.follow else None
            if done is not None and (done.complete or done.next_slot >= len(self.points)):
                return
            self.wait_listening()
            starts = self.chan.starts()
            prog = self._progress()
            if bad_slot is not None:
                if prog.next_slot == bad_slot + 1:  # still in the session: undo it
                    p = self.points[bad_slot]
                    self.op.undo(f"undo {p.slot.step_id} point {p.slot.point_index + 1}")
                    if not self._wait_ack(prog, starts):
                        continue
                bad_slot = None
                continue
            if prog.complete or prog.next_slot >= len(self.points):
                return
            p = self.points[prog.next_slot]
            m = self.misprobes.get(p.slot.index)
            if m is not None and p.slot.index not in self.done_misprobes:
                self.done_misprobes.add(p.slot.index)
                self._say_slot(p, f"mis-probe {m.offset_mm:g} mm: ")
                self._probe(p, m.offset_mm)
                if not m.keep:
                    bad_slot = p.slot.index
                self._wait_ack(prog, starts)
                continue
            self._say_slot(p)
            self._probe(p)
            self._wait_ack(prog, starts)

    # ------------------------------------------------------------ report

    def report(self) -> dict[str, Any]:
        """Everything the operator did, JSON-ready (docs/simulator.md, "Report")."""
        presses = []
        for pr in self.op.presses:
            presses.append(
                {
                    "slot": pr.slot,
                    "label": pr.label,
                    "button": int(pr.button),
                    "target_mm": _floats(pr.target_mm),
                    "probed_mm": _floats(pr.probed_mm),
                    "theta_rad": _floats(pr.theta_rad),
                    "counts": list(pr.counts),
                    "ik_error_mm": pr.ik_error_mm,
                    "misprobe_mm": pr.misprobe_mm,
                }
            )
        pressed = [
            pr.theta_rad
            for pr in self.op.presses
            if pr.button == Button.CAPTURE and pr.slot is not None
        ]
        return {
            "format": "aacmm-sim-report-1",
            "plan_sha256": self.plan_sha256,
            "points": len(self.points),
            "joint_spread_deg": self.choreography.spread_deg,
            "joint_spread_pressed_deg": [round(float(v), 2) for v in joint_spread_deg(pressed)]
            if pressed
            else [],
            "max_ik_error_mm": max((pr.ik_error_mm for pr in self.op.presses), default=0.0),
            "presses": presses,
        }


def _floats(a: Any) -> list[float | None]:
    return [None if not math.isfinite(float(v)) else float(v) for v in np.asarray(a).reshape(-1)]


class Wander:
    """The true arm moving through random postures inside its limits (``walk``),
    a new one every ``period_s``, pressing button 0 every ``button_every_s``."""

    def __init__(
        self, operator: Operator, period_s: float = 4.0, button_every_s: float | None = None
    ) -> None:
        self.op = operator
        self.period_s = period_s
        self.button_every_s = button_every_s
        self._next_press = math.inf

    def _tick(self) -> None:
        if time.monotonic() >= self._next_press:
            self.op.press_and_release(Button.CAPTURE)
            self._next_press = time.monotonic() + (self.button_every_s or math.inf)

    def run(self) -> None:
        """Until the operator is stopped (raises :class:`Stopped` then)."""
        op = self.op
        op.send_pose(op.theta)
        if self.button_every_s:
            self._next_press = time.monotonic() + self.button_every_s
        op.tick = self._tick
        while True:
            op.move_to(op.limits.sample(op.rng), duration=self.period_s)
