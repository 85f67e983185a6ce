"""Writing a capture session: :class:`SessionWriter` creates, resumes and extends one durably.

Every accepted point is written and fsynced before
:meth:`SessionWriter.record` returns; an undo rewrites ``points.csv``
atomically. The folder's layout: :mod:`aacmm.records.session_format`;
:class:`SessionWriter` is public as ``aacmm.records.SessionWriter``.
"""

from __future__ import annotations

import platform
import time
from pathlib import Path
from typing import Any

from aacmm import __version__
from aacmm.plans import Plan, Slot
from aacmm.protocol import Sample
from aacmm.records.files import DurableAppender, RecordError, utc_iso, write_json_atomic
from aacmm.records.paramsets import ParamSetRecord
from aacmm.records.session_format import (
    EVENTS_CSV,
    JOINTS,
    POINTS_CSV,
    PROGRESS,
    PROGRESS_FORMAT,
    SESSION_FORMAT,
    SIDECAR,
    STATUSES,
    event_columns,
    label_fields,
    opt_field,
    point_columns,
    sample_columns,
    sample_fields,
    units,
)
from aacmm.records.session_reader import read_session


class SessionWriter:
    """Writes a session folder. Make one with :meth:`create` or :meth:`resume`.

    Not thread-safe: call it from one thread.
    """

    def __init__(self, folder: Path, plan: Plan, meta: dict[str, Any], lines: list[str]) -> None:
        self.folder = folder
        self.plan = plan
        self.meta = meta
        self._lines = lines  # points.csv rows, in order
        j = meta.get("joints", JOINTS)
        #: N: the joints of the session's arm (its count columns).
        self.joints = j if isinstance(j, int) and not isinstance(j, bool) else JOINTS
        #: the session's rows carry the link temperatures (a session written before
        #: device temperatures keeps its columns when resumed)
        cols = meta.get("columns")
        self.temps = not isinstance(cols, list) or "temp1_c" in cols
        self._sets: dict[int, ParamSetRecord] = {}
        for i, d in enumerate(meta.get("param_sets", [])):
            ps = ParamSetRecord.from_json(d, f"{folder / SIDECAR}: param_sets[{i}]")
            self._sets[ps.crc32] = ps
        self.current: ParamSetRecord | None = None
        self.undos = 0
        #: The session's status when it was opened (``running`` for a new one; for a
        #: resumed one what the last run left: ``running`` after a kill).
        self.opened_status = str(meta.get("status", "running"))
        self._points = DurableAppender(
            folder / POINTS_CSV, point_columns(self.joints, self.temps), create=not lines
        )
        self._events = DurableAppender(
            folder / EVENTS_CSV,
            event_columns(self.joints, self.temps),
            create=not (folder / EVENTS_CSV).exists(),
        )

    # ---------------------------------------------------------- opening

    @classmethod
    def create(
        cls,
        folder: str | Path,
        plan: Plan,
        *,
        source: str = "capture",
        device: dict[str, Any] | None = None,
        port: str | None = None,
        transport: str | None = None,
        joints: int = JOINTS,
    ) -> SessionWriter:
        """A new session in ``folder`` (created; it may exist only if empty) of an
        arm of ``joints`` joints (its count columns; the parameter sets given to
        :meth:`set_param_set` must be arms of as many joints).

        Raises:
            FileExistsError: ``folder`` exists and is not empty.
            OSError: it cannot be created.
            ValueError: ``joints`` outside 4..7.
        """
        if isinstance(joints, bool) or not 4 <= joints <= 7:
            raise ValueError(f"an arm has 4 to 7 joints, got {joints}")
        path = Path(folder)
        if path.exists() and (not path.is_dir() or any(path.iterdir())):
            raise FileExistsError(f"{path} exists and is not an empty folder")
        path.mkdir(parents=False, exist_ok=True)
        now = time.time()
        meta: dict[str, Any] = {
            "format": SESSION_FORMAT,
            "status": "running",
            "source": source,
            "created": utc_iso(now),
            "updated": utc_iso(now),
            "plan": {
                "name": plan.name,
                "title": plan.title,
                "sha256": plan.sha256,
                "points": len(plan.slots),
                "source": plan.source,
            },
            "device": device,
            "port": port,
            "transport": transport,
            "joints": joints,
            "param_sets": [],
            "points_csv": POINTS_CSV,
            "events_csv": EVENTS_CSV,
            "columns": list(point_columns(joints)),
            "event_columns": list(event_columns(joints)),
            "units": units(joints),
            "accepted": 0,
            "runs": [],
            "host": {
                "aacmm": __version__,
                "python": platform.python_version(),
                "node": platform.node(),
            },
        }
        write_json_atomic(path / SIDECAR, meta)
        return cls(path, plan, meta, [])

    @classmethod
    def resume(cls, folder: str | Path, plan: Plan | None = None) -> SessionWriter:
        """Reopen a session to continue it. A row cut short by a kill is dropped
        (it was never acknowledged).

        Raises:
            RecordError: not a session, damaged, or ``plan`` differs from the
                session's plan.
        """
        path = Path(folder)
        s = read_session(path, repair=True)
        if plan is not None and plan.sha256 != s.plan.sha256:
            raise RecordError(
                f"{path}: the session was captured with another plan "
                f"({s.meta['plan'].get('name')}, sha256 {s.plan.sha256[:12]}...); "
                f"{plan.name} differs (sha256 {plan.sha256[:12]}...)"
            )
        text = (path / POINTS_CSV).read_text(encoding="utf-8")
        lines = [line + "\n" for line in text.split("\n")[1:] if line]
        if len(lines) != len(s.points):
            raise RecordError(f"{path / POINTS_CSV}: comment or blank lines in a points file")
        w = cls(path, s.plan, dict(s.meta), lines)
        w.meta["status"] = "running"
        return w

    # ---------------------------------------------------------- state

    @property
    def accepted(self) -> int:
        """Points accepted so far."""
        return len(self._lines)

    @property
    def next_slot(self) -> Slot | None:
        """The slot the next point goes to (None: the plan is complete)."""
        n = len(self._lines)
        return self.plan.slots[n] if n < len(self.plan.slots) else None

    @property
    def param_sets(self) -> dict[int, ParamSetRecord]:
        return dict(self._sets)

    def set_param_set(self, ps: ParamSetRecord) -> bool:
        """Make ``ps`` the set in force for the points that follow; True if it is
        new to this session (then the sidecar is rewritten).

        Raises:
            RecordError: ``ps`` is an arm of another joint count than the session's.
        """
        if ps.joints != self.joints:
            raise RecordError(
                f"{self.folder}: the parameter set {ps.crc_hex} is an arm of {ps.joints} "
                f"joints; this session holds an arm of {self.joints}: start a new session"
            )
        self.current = ps
        if ps.crc32 in self._sets:
            return False
        self._sets[ps.crc32] = ps
        d = ps.to_json()
        d["first_seen"] = utc_iso(time.time())
        d["first_slot"] = self.accepted
        self.meta["param_sets"].append(d)
        self._event("params", detail=ps.crc_hex)
        self.write_meta()
        return True

    def begin_run(self, kind: str, **info: Any) -> None:
        """Note the start of a capture run (``capture``, ``resume``, ``from-log``)."""
        run = {"kind": kind, "start": utc_iso(time.time()), "first_slot": self.accepted, **info}
        self.meta["runs"].append(run)
        self.meta["status"] = "running"
        self._event("run", detail=kind)
        self.write_meta()
        self.write_progress()

    def write_progress(self) -> None:
        """Replace ``progress.json`` atomically: the slot capture expects next (what a
        simulated operator following the session reads; docs/plans.md)."""
        write_json_atomic(
            self.folder / PROGRESS,
            {
                "format": PROGRESS_FORMAT,
                "plan_sha256": self.plan.sha256,
                "next_slot": self.accepted,
                "points": self.accepted,
                "complete": self.next_slot is None,
                "undos": self.undos,
                "status": self.meta.get("status", "running"),
            },
        )

    def write_meta(self) -> None:
        self.meta["updated"] = utc_iso(time.time())
        self.meta["accepted"] = self.accepted
        write_json_atomic(self.folder / SIDECAR, self.meta)

    # ---------------------------------------------------------- points

    def record(self, sample: Sample, host_time: float, button: int = 0) -> Slot:
        """Accept ``sample`` as the point of :attr:`next_slot`; durable on return.

        Raises:
            RecordError: the plan is complete, or no parameter set is in force.
        """
        slot = self.next_slot
        if slot is None:
            raise RecordError(f"{self.folder}: the plan is complete; no slot for another point")
        if self.current is None:
            raise RecordError(f"{self.folder}: no parameter set in force (set_param_set first)")
        fields = sample_fields(sample, host_time, button, self.current.crc32, self.temps)
        self._event("point", slot=slot.index, pressed=1, fields=fields)
        line = ",".join(label_fields(slot) + fields) + "\n"
        self._points.append(line)
        self._lines.append(line)
        self.write_progress()
        return slot

    def undo(self, host_time: float | None = None) -> Slot | None:
        """Remove the last accepted point (durable on return); the slot it had, or None."""
        if not self._lines:
            self._event("ignored", detail="undo with no point", host_time=host_time)
            return None
        slot = self.plan.slots[len(self._lines) - 1]
        self._event("undo", slot=slot.index, host_time=host_time)
        self._lines.pop()
        self._points.rewrite(self._lines)
        self.undos += 1
        self.write_progress()
        return slot

    def confirm(
        self, sample: Sample | None, host_time: float, button: int | None, how: str
    ) -> None:
        """Journal the operator's confirmation that the complete plan ends here (a
        press of ``button`` with its ``sample``, or a key: ``sample`` None)."""
        fields = None
        if sample is not None and button is not None:
            crc = self.current.crc32 if self.current is not None else 0
            fields = sample_fields(sample, host_time, button, crc, self.temps)
        pressed = None if fields is None else 1
        self._event("confirm", pressed=pressed, fields=fields, detail=how, host_time=host_time)

    def ignored(
        self, sample: Sample | None, host_time: float, button: int, pressed: bool, why: str
    ) -> None:
        """Journal a button event that did not change the session."""
        fields = None
        if sample is not None:
            crc = self.current.crc32 if self.current is not None else 0
            fields = sample_fields(sample, host_time, button, crc, self.temps)
        self._event("ignored", pressed=int(pressed), fields=fields, detail=why, host_time=host_time)

    def _event(
        self,
        event: str,
        *,
        slot: int | None = None,
        pressed: int | None = None,
        fields: list[str] | None = None,
        detail: str = "",
        host_time: float | None = None,
    ) -> None:
        t = time.time() if host_time is None else host_time
        sample = (
            fields if fields is not None else [""] * len(sample_columns(self.joints, self.temps))
        )
        row = [f"{t:.6f}", event, opt_field(slot), opt_field(pressed), *sample, _csv_text(detail)]
        self._events.append(",".join(row) + "\n")

    def close(self, status: str, reason: str = "") -> None:
        """End the run: status (``complete`` when every slot is filled), sidecar rewritten."""
        if status not in STATUSES:
            raise ValueError(f"unknown session status {status!r}")
        if self.meta["runs"]:
            self.meta["runs"][-1]["end"] = utc_iso(time.time())
            self.meta["runs"][-1]["end_reason"] = reason or status
            self.meta["runs"][-1]["last_slot"] = self.accepted
        self.meta["status"] = status
        self._event("end", detail=f"{status} {reason}".strip())
        self.write_meta()
        self.write_progress()
        self._points.close()
        self._events.close()


def _csv_text(s: str) -> str:
    """A free-text CSV field (quoted when needed, one line)."""
    s = s.replace("\n", " ").replace("\r", " ")
    return '"' + s.replace('"', '""') + '"' if ("," in s or '"' in s) else s
