"""The live view: the arm from the device's samples, and a capture's progress.

:class:`LiveFeed` takes every sample the caller reads from the device
(:meth:`LiveFeed.on_sample`: a reference kept, nothing computed, so a 1 kHz
stream costs its reader almost nothing) and, on a thread of its own, at
``fps`` frames per second takes the newest one, turns its counts into joint
angles (:func:`aacmm.core.counts_to_angles`) and the joints' frames
(:func:`aacmm.view.arm.chain`), appends the tip to the trail and pushes a ``frame``
message to every page. Decimation is by time: whatever the device's rate,
pages get at most ``fps`` frames a second, each the newest sample.

During a capture, :meth:`LiveFeed.session_changed` (after every point, undo
or confirmation) makes the same thread re-read the session folder -- the
points on disk are the ones acknowledged, so the page never shows a point
capture has not made durable -- refit every step's feature and push a
``capture`` message: plan, step, artefact, the point expected next, every
point with its residual, the last event (recorded, undone), and for steps
that ask for a new articulation the previous articulations' joint angles.
Each frame then says which joints are still close to an articulation
already taken (:func:`articulation_advice`). A frame of a device that reads
its link temperatures carries them, and during a capture whose plan states a
stability band, whether they and the capture's range so far are within it
(:func:`temperature_band`).

The feed never writes to the device or the session: it reads samples it is
given and files capture wrote.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aacmm.arm import Arm
from aacmm.records.schema import temps_c
from aacmm.view.arm import chain
from aacmm.view.options import FPS_DEFAULT, FPS_RANGE, TRAIL_DEFAULT
from aacmm.view.scene import arm_dict, points_scene

FloatArray = npt.NDArray[np.float64]

#: A joint within this many degrees of the same joint of an articulation already
#: taken has not been turned enough (ISO 10360-12 and calibration practice want
#: articulations as different as possible).
TURN_DEG = 20.0
#: A pose counts as a new articulation when at least this many joints differ by
#: TURN_DEG or more from every articulation already taken.
NEW_JOINTS = 2
#: Re-reads of the session (one a frame) before showing what is there.
RETRIES = 40


def _r(a: Any, nd: int = 4) -> list[float]:
    return [round(x, nd) for x in np.asarray(a, dtype=np.float64).reshape(-1).tolist()]


def articulation_advice(theta_rad: npt.ArrayLike, taken_rad: list[list[float]]) -> dict[str, Any]:
    """How the pose ``theta_rad`` differs from the articulations ``taken_rad``.

    Returns ``nearest`` (1-based number of the closest articulation taken, by the
    norm of the wrapped joint differences), ``delta_deg`` (per joint, to it),
    ``turn`` (1-based joints within :data:`TURN_DEG` of it) and ``ready`` (at least
    :data:`NEW_JOINTS` joints differ by TURN_DEG from every articulation taken).
    """
    th = np.asarray(theta_rad, dtype=np.float64)
    if not taken_rad:
        return {"nearest": None, "delta_deg": None, "turn": [], "ready": True}
    t = np.asarray(taken_rad, dtype=np.float64)
    d = np.degrees(np.angle(np.exp(1j * (th[None, :] - t))))  # wrapped to (-180, 180]
    k = int(np.argmin(np.linalg.norm(d, axis=1)))
    far = np.abs(d) >= TURN_DEG
    return {
        "nearest": k + 1,
        "delta_deg": _r(d[k], 1),
        "turn": [int(j) + 1 for j in np.flatnonzero(~far[k])],
        "ready": bool(np.all(far.sum(axis=1) >= NEW_JOINTS)),
    }


def temperature_band(
    temps: Sequence[float | None], plan: Any, seen: tuple[float, float] | None = None
) -> dict[str, Any] | None:
    """The plan's stability band against one sample's link temperatures (degC, None: no
    reading) and those seen before in the capture (``seen``: their lowest and highest,
    None: none yet): ``band_c``, ``ref_c`` (the plan's test temperature or None),
    ``range_c`` ([lowest, highest] reading of the capture so far, these included; None
    while no link has read), ``problem`` (why these readings break the band,
    :meth:`aacmm.plans.model.Verification.band_problem`, or that a link gave none;
    else why the capture's range does, the rule ``aacmm capture`` warns by; None:
    within the band). None without a plan or a band."""
    verification = getattr(plan, "verification", None)
    band = getattr(verification, "temperature_band_c", None)
    if verification is None or band is None:
        return None
    read = [t for t in temps if t is not None]
    missing = [j for j, t in enumerate(temps, 1) if t is None]
    lo_hi = [*read, *(seen or ())]
    span = [min(lo_hi), max(lo_hi)] if lo_hi else None
    problem = (
        f"link {missing[0]} gives no temperature" if missing else verification.band_problem(read)
    )
    if problem is None and span is not None:
        drift = verification.band_problem(span)
        problem = None if drift is None else f"since the capture started, {drift}"
    return {
        "band_c": band,
        "ref_c": verification.temperature_c,
        "range_c": span,
        "problem": problem,
    }


def _new_articulation(slot: Any, step: Any) -> bool:
    if slot.procedure == "cone":
        return True
    if slot.procedure == "articulation":
        m = step.points_per_articulation or 1
        return bool(slot.point_index % m == 0)
    return False


def capture_message(folder: Path, plan: Any, previous: int | None) -> dict[str, Any]:
    """The ``capture`` message for the session in ``folder`` as it is on disk."""
    from aacmm.records import read_session

    s = read_session(folder)
    n = len(s.points)
    pts = s.points_mm() if n else np.empty((0, 3))
    scene = points_scene(s.plan, s.points, pts, f"capture {folder.name}: {s.plan.title}")
    total = len(s.plan.slots)
    nxt = s.plan.slots[n] if n < total else None
    event = None
    if previous is not None and n > previous:
        p = s.points[-1]
        event = {
            "kind": "recorded",
            "text": f"recorded {n}/{total}",
            "slot": p.slot,
            "xyz": _r(pts[-1]),
        }
    elif previous is not None and n < previous:
        sl = s.plan.slots[n]
        event = {"kind": "undone", "text": f"undone {n + 1}/{total}: {sl.text}", "slot": n}
    msg: dict[str, Any] = {
        "type": "capture",
        "plan": {
            "name": s.plan.name,
            "title": s.plan.title,
            "points": total,
            "steps": len(s.plan.steps),
        },
        "folder": str(folder),
        "accepted": n,
        "status": s.status,
        "complete": nxt is None,
        "points": scene["points"],
        "steps": scene["steps"],
        "event": event,
        "next": None,
        "articulations": [],
        "updated_ms": time.time() * 1000.0,
    }
    if nxt is not None:
        st = s.plan.steps[nxt.step_index]
        in_step = [p for p in s.points if p.step_index == st.index]
        msg["next"] = {
            "slot": nxt.index,
            "number": nxt.index + 1,
            "text": nxt.text,
            "step": st.id,
            "step_number": st.index + 1,
            "procedure": st.procedure,
            "artefact": st.artefact,
            "artefact_type": getattr(s.plan.artefacts.get(st.artefact or ""), "type", None),
            "point_in_step": len(in_step) + 1,
            "points_in_step": st.points,
            "note": st.note,
            "new_articulation": _new_articulation(nxt, st),
            "articulation": None if nxt.articulation_index is None else nxt.articulation_index + 1,
            "articulations": st.articulations,
        }
        if msg["next"]["new_articulation"] and in_step:
            rows = [i for i, p in enumerate(s.points) if p.step_index == st.index]
            theta = s.angles_rad()[rows]
            firsts = [k for k, i in enumerate(rows) if _new_articulation(s.plan.slots[i], st)]
            msg["articulations"] = [_r(theta[k], 6) for k in firsts]
    return msg


class LiveFeed:
    """Frames of the arm for a :class:`aacmm.view.server.ViewServer` (see the module).

    ``params``, ``encoders``: the device's :class:`aacmm.core.Params` and
    :class:`aacmm.core.EncoderConfig`; ``push(kind, message)``: where messages
    go; ``fps``: frames per second (30-120); ``trail``: tip positions kept.
    """

    def __init__(
        self,
        params: Any,
        encoders: Any,
        push: Any,
        fps: int = FPS_DEFAULT,
        trail: int = TRAIL_DEFAULT,
        info: dict[str, Any] | None = None,
    ) -> None:
        lo, hi = FPS_RANGE
        if not lo <= fps <= hi:
            raise ValueError(f"fps must be in {lo}..{hi}, got {fps}")
        if trail < 0:
            raise ValueError("the trail cannot be negative")
        self.params = params
        self.encoders = encoders
        #: The arm drawn (an :class:`aacmm.arm.Arm`; a Params is the paper's arm in 25 values).
        self.arm: Arm = params if isinstance(params, Arm) else params.to_arm()
        #: The farthest the tip can be from the base (the sum of the lengths): the scene's extent.
        self.reach_mm = float(
            sum(abs(j.d_mm) + abs(j.a_mm) for j in self.arm.joints) + math.hypot(*self.arm.tip_mm)
        )
        self._push = push
        self.fps = fps
        self.info = info or {}
        self.trail: deque[list[float]] = deque(maxlen=max(1, trail))
        self._trail_on = trail > 0
        self._latest: tuple[Any, float] | None = None
        self._received = 0
        self._published_seq: int | None = None
        self.frames = 0
        self.last_frame: dict[str, Any] | None = None
        self._capture: dict[str, Any] | None = None
        self._capture_dirty = threading.Event()
        self._folder: Path | None = None
        self._plan: Any = None
        self._temps_seen: tuple[float, float] | None = None  # the capture's range, degC
        self._accepted: int | None = None
        self._expected: int | None = None
        self._retries = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="aacmm-view-feed", daemon=True)
        self.errors = 0
        self.last_error: str | None = None

    # ---------------------------------------------------------- caller side

    def on_sample(self, sample: Any) -> None:
        """The caller read ``sample`` from the device (cheap: any rate)."""
        self._latest = (sample, time.time())
        self._received += 1

    def follow_session(self, folder: str | Path, plan: Any) -> None:
        """Show the capture session in ``folder`` (re-read on :meth:`session_changed`)."""
        self._folder = Path(folder)
        self._plan = plan
        self._temps_seen = None
        self.session_changed()

    def session_changed(self, accepted: int | None = None) -> None:
        """Capture accepted, undid or confirmed something: re-read the session.

        ``accepted``: the points capture holds now; the feed reads the folder
        again (each frame, up to :data:`RETRIES` times) until it sees as many.
        """
        self._expected = accepted
        self._retries = 0
        self._capture_dirty.set()

    def start(self) -> LiveFeed:
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(5.0)

    def state(self) -> dict[str, Any]:
        """The page's starting document: device, settings, trail, capture, last frame."""
        return {
            "format": "aacmm-view-1",
            "kind": "live",
            "title": self.info.get("title", "live view"),
            "subtitle": self.info.get("subtitle", ""),
            "fps": self.fps,
            "reach_mm": self.reach_mm,
            "trail_max": self.trail.maxlen if self._trail_on else 0,
            "trail": list(self.trail),
            "frame": self.last_frame,
            "capture": self._capture,
            "device": self.info.get("device"),
            "read_only": True,
        }

    # ---------------------------------------------------------- feed thread

    def _frame(self, sample: Any, host_time: float) -> dict[str, Any]:
        from aacmm.core import counts_to_angles

        theta = counts_to_angles(np.array([sample.counts], dtype=np.int64), self.encoders)[0]
        pose = chain(self.arm, theta)
        valid = bool(sample.status & 1)
        tip = list(sample.point_mm) if valid else _r(pose.tip_mm)
        frame: dict[str, Any] = {
            "type": "frame",
            "seq": sample.seq,
            "device_time_us": sample.timestamp_us,
            "status": sample.status,
            "valid": valid,
            "tip": [round(float(x), 4) for x in tip],
            "theta_deg": _r(np.degrees(theta), 7),
            "arm": arm_dict(pose),
            "host_ms": host_time * 1000.0,
            "received": self._received,
            "frame": self.frames + 1,  # frames made so far, this one included
        }
        temps = temps_c(getattr(sample, "temp", None))
        if temps is not None:  # the device's link temperatures, degC (None: no reading)
            frame["temps_c"] = list(temps)
            band = temperature_band(temps, self._plan, self._temps_seen)
            if band is not None:
                frame["temp_band"] = band
                if band["range_c"] is not None:
                    self._temps_seen = (band["range_c"][0], band["range_c"][1])
        cap = self._capture
        if (
            cap is not None
            and cap.get("articulations")
            and (cap.get("next") or {}).get("new_articulation")
        ):
            frame["advice"] = articulation_advice(theta, cap["articulations"])
        return frame

    def _refresh_capture(self) -> None:
        if self._folder is None:
            return
        try:
            msg = capture_message(self._folder, self._plan, self._accepted)
        except Exception as exc:  # a file being replaced: try again at the next frame
            self.errors += 1
            self.last_error = str(exc)
            if self._retries < RETRIES:
                self._retries += 1
                self._capture_dirty.set()
            return
        if self._expected is not None and msg["accepted"] != self._expected:
            if self._retries < RETRIES:  # a row still on its way to the file
                self._retries += 1
                self._capture_dirty.set()
                return
        self._accepted = msg["accepted"]
        self._capture = msg
        self._push("capture", msg)

    def _run(self) -> None:
        period = 1.0 / self.fps
        next_t = time.monotonic()
        while not self._stop.is_set():
            if self._capture_dirty.is_set():
                self._capture_dirty.clear()
                self._refresh_capture()
            latest = self._latest
            if latest is not None and latest[0].seq != self._published_seq:
                sample, host_time = latest
                try:
                    frame = self._frame(sample, host_time)
                except Exception as exc:  # a reading the model rejects: skip it, count it
                    self.errors += 1
                    self.last_error = str(exc)
                else:
                    self._published_seq = sample.seq
                    if self._trail_on and frame["valid"]:
                        self.trail.append(frame["tip"])
                    frame["sent_ms"] = time.time() * 1000.0
                    self.frames += 1
                    self.last_frame = frame
                    self._push("frame", frame)
            next_t += period
            delay = next_t - time.monotonic()
            if delay < -period:  # fell behind (the machine was busy): do not catch up
                next_t = time.monotonic()
                delay = 0.0
            if delay > 0:
                self._stop.wait(delay)
        if self._capture_dirty.is_set():  # the last change (a capture's end) still goes out
            self._refresh_capture()
