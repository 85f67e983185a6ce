"""Capture sessions: one folder per session (format ``aacmm-session-1``, docs/plans.md).

::

    SESSION/
      session.json   the sidecar: plan (its full text), device identity, port,
                     every parameter set in force (with CRC and encoder
                     configuration), status, runs (capture, resume, ...)
      points.csv     the accepted points, one row per point in plan order, labelled
      events.csv     the journal: every button event, undo and run, append-only
      progress.json  the slot expected next (replaced atomically after every change)

:class:`SessionWriter` makes and extends sessions (``aacmm capture`` uses it;
tests may feed it synthetic samples); :func:`read_session` reads one into a
:class:`Session`. Every accepted point is durable (written and fsynced)
before :meth:`SessionWriter.record` returns, so a capture killed at any
moment loses no acknowledged point; an undo rewrites ``points.csv``
atomically.
"""

from __future__ import annotations

import platform
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aacmm import __version__
from aacmm.plans import Plan, PlanError, Slot, loads_plan
from aacmm.protocol import Sample
from aacmm.records.files import (
    CsvTable,
    DurableAppender,
    RecordError,
    crc_hex,
    fmt_point,
    read_json,
    truncate_partial_line,
    utc_iso,
    write_json_atomic,
)
from aacmm.records.paramsets import ParamSetRecord
from aacmm.records.rows import Recorded

SESSION_FORMAT = "aacmm-session-1"
SIDECAR = "session.json"
POINTS_CSV = "points.csv"
EVENTS_CSV = "events.csv"
PROGRESS = "progress.json"
PROGRESS_FORMAT = "aacmm-progress-1"
COUNT_COLUMNS: tuple[str, ...] = tuple(f"count{i}" for i in range(1, 7))
LABEL_COLUMNS: tuple[str, ...] = (
    "slot",
    "step_index",
    "step_id",
    "procedure",
    "artefact",
    "position_index",
    "end",
    "articulation_index",
    "point_index",
)
SAMPLE_COLUMNS: tuple[str, ...] = (
    "seq",
    "device_time_us",
    "host_time",
    "button",
    *COUNT_COLUMNS,
    "x_mm",
    "y_mm",
    "z_mm",
    "flags",
    "param_crc32",
)
POINT_COLUMNS: tuple[str, ...] = LABEL_COLUMNS + SAMPLE_COLUMNS
EVENT_COLUMNS: tuple[str, ...] = (
    "event_time",
    "event",
    "slot",
    "pressed",
    *SAMPLE_COLUMNS,
    "detail",
)
#: Journal event names.
EVENTS: tuple[str, ...] = ("run", "point", "undo", "ignored", "confirm", "params", "end")
UNITS: dict[str, str] = {
    "slot": "index of the point in the plan (Plan.slots), from 0",
    "step_index,position_index,articulation_index,point_index": "indices from 0 "
    "(empty: not applicable to the procedure)",
    "end": "A or B on a length step, else empty",
    "seq": "device sample counter of the latched sample",
    "device_time_us": "us, device clock",
    "host_time": "s since the Unix epoch (UTC), host clock at the button event",
    "event_time": "events.csv: s since the Unix epoch (UTC), when the event was journaled",
    "button": "0 front (capture), 1 second button",
    "count1..count6": "raw encoder counts (u32)",
    "x_mm,y_mm,z_mm": "probe point computed by the device, mm (resolution 0.0001 mm)",
    "flags": "sample status bits (docs/protocol.md 2.4)",
    "param_crc32": "CRC of the parameter set in force (session.json param_sets)",
}
STATUSES: tuple[str, ...] = ("running", "complete", "interrupted", "link_lost", "error")


def _opt(v: int | None) -> str:
    return "" if v is None else str(v)


def _sample_fields(sample: Sample, host_time: float, button: int, crc: int) -> list[str]:
    x, y, z = sample.point_100nm
    return [
        str(sample.seq),
        str(sample.timestamp_us),
        f"{host_time:.6f}",
        str(button),
        *(str(c) for c in sample.counts),
        fmt_point(x),
        fmt_point(y),
        fmt_point(z),
        str(sample.status),
        crc_hex(crc),
    ]


def _label_fields(slot: Slot) -> list[str]:
    return [
        str(slot.index),
        str(slot.step_index),
        slot.step_id,
        slot.procedure,
        slot.artefact or "",
        _opt(slot.position_index),
        slot.end or "",
        _opt(slot.articulation_index),
        str(slot.point_index),
    ]


@dataclass(frozen=True)
class CapturedPoint:
    """One accepted point of a session: its labels (see :class:`aacmm.plans.Slot`),
    the latched sample and the parameter set in force."""

    slot: int
    step_index: int
    step_id: str
    procedure: str
    artefact: str | None
    position_index: int | None
    end: str | None
    articulation_index: int | None
    point_index: int
    seq: int
    device_time_us: int
    host_time: float
    button: int
    counts: tuple[int, ...]
    point_mm: tuple[float, float, float]
    flags: int
    param_set: ParamSetRecord


@dataclass(frozen=True, eq=False)
class Session(Recorded):
    """A session read from its folder (:func:`read_session`).

    ``points`` in plan order; the arrays (``counts``, ``param_crc32`` from
    :class:`Recorded`, and the others below) have one row per point.
    ``recompute``: use :meth:`points_mm` (each point with its own set in force,
    double precision) or ``points_mm(params)`` with other parameters.
    """

    meta: dict[str, Any]
    plan: Plan
    points: tuple[CapturedPoint, ...]
    device_points_mm: npt.NDArray[np.float64]
    device_time_us: npt.NDArray[np.int64]
    step_index: npt.NDArray[np.int64]
    point_index: npt.NDArray[np.int64]
    warnings: tuple[str, ...] = ()

    @property
    def status(self) -> str:
        return str(self.meta.get("status", "unknown"))

    @property
    def device(self) -> dict[str, Any] | None:
        d = self.meta.get("device")
        return d if isinstance(d, dict) else None

    @property
    def complete(self) -> bool:
        """Every slot of the plan has its point."""
        return len(self.points) == len(self.plan.slots)

    def rows_of(self, step: int | str) -> npt.NDArray[np.intp]:
        """Row numbers of the points of one step (by index or id)."""
        i = self.plan.step(step).index
        return np.flatnonzero(self.step_index == i)

    def points_of(self, step: int | str) -> tuple[CapturedPoint, ...]:
        """The captured points of one step (by index or id)."""
        return tuple(self.points[int(r)] for r in self.rows_of(step))


# ---------------------------------------------------------------- writer


class SessionWriter:
    """Writes a session folder. Make one with :meth:`create` or :meth:`resume`.

    Not thread-safe: call it from one thread.
    """

    def __init__(self, folder: Path, plan: Plan, meta: dict[str, Any], lines: list[str]) -> None:
        self.folder = folder
        self.plan = plan
        self.meta = meta
        self._lines = lines  # points.csv rows, in order
        self._sets: dict[int, ParamSetRecord] = {}
        for i, d in enumerate(meta.get("param_sets", [])):
            ps = ParamSetRecord.from_json(d, f"{folder / SIDECAR}: param_sets[{i}]")
            self._sets[ps.crc32] = ps
        self.current: ParamSetRecord | None = None
        self.undos = 0
        #: The session's status when it was opened (``running`` for a new one; for a
        #: resumed one what the last run left: ``running`` after a kill).
        self.opened_status = str(meta.get("status", "running"))
        self._points = DurableAppender(folder / POINTS_CSV, POINT_COLUMNS, create=not lines)
        self._events = DurableAppender(
            folder / EVENTS_CSV, EVENT_COLUMNS, create=not (folder / EVENTS_CSV).exists()
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
    ) -> SessionWriter:
        """A new session in ``folder`` (created; it may exist only if empty).

        Raises:
            FileExistsError: ``folder`` exists and is not empty.
            OSError: it cannot be created.
        """
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
            "param_sets": [],
            "points_csv": POINTS_CSV,
            "events_csv": EVENTS_CSV,
            "columns": list(POINT_COLUMNS),
            "event_columns": list(EVENT_COLUMNS),
            "units": UNITS,
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
        new to this session (then the sidecar is rewritten)."""
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
        fields = _sample_fields(sample, host_time, button, self.current.crc32)
        self._event("point", slot=slot.index, pressed=1, fields=fields)
        line = ",".join(_label_fields(slot) + fields) + "\n"
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
            fields = _sample_fields(sample, host_time, button, crc)
        pressed = None if fields is None else 1
        self._event("confirm", pressed=pressed, fields=fields, detail=how, host_time=host_time)

    def ignored(
        self, sample: Sample | None, host_time: float, button: int, pressed: bool, why: str
    ) -> None:
        """Journal a button event that did not change the session."""
        fields = None
        if sample is not None:
            crc = self.current.crc32 if self.current is not None else 0
            fields = _sample_fields(sample, host_time, button, crc)
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
        sample = fields if fields is not None else [""] * len(SAMPLE_COLUMNS)
        row = [f"{t:.6f}", event, _opt(slot), _opt(pressed), *sample, _csv_text(detail)]
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


# ---------------------------------------------------------------- reader


def _int(t: CsvTable, line: int, name: str, v: str, lo: int, hi: int) -> int:
    try:
        x = int(v)
    except ValueError:
        raise t.fail(line, f"{name}: {v!r} is not an integer") from None
    if not lo <= x <= hi:
        raise t.fail(line, f"{name}: {x} outside {lo}..{hi}")
    return x


def _opt_int(t: CsvTable, line: int, name: str, v: str) -> int | None:
    return None if v == "" else _int(t, line, name, v, 0, 1 << 31)


def read_session(folder: str | Path, repair: bool = False) -> Session:
    """Read a session folder.

    Every row is checked: its labels must be those of its slot in the
    session's plan, in plan order, and its parameter set must be one the
    sidecar lists (whose values match its CRC). A last row cut short by a
    kill is dropped (with ``repair``, also from the file).

    Raises:
        RecordError: not a session folder, an unknown format, a damaged or
            inconsistent file (message names the file and line).
    """
    path = Path(folder)
    side = path / SIDECAR
    if not path.is_dir():
        raise RecordError(f"{path}: not a session folder")
    if not side.is_file():
        raise RecordError(f"{path}: not a session folder (no {SIDECAR})")
    meta = read_json(side)
    fmt = meta.get("format")
    if fmt != SESSION_FORMAT:
        raise RecordError(f"{side}: format {fmt!r} is not {SESSION_FORMAT!r}")
    pm = meta.get("plan")
    if not isinstance(pm, dict) or not isinstance(pm.get("source"), str):
        raise RecordError(f"{side}: no plan in the sidecar")
    try:
        plan = loads_plan(pm["source"], f"{side}: plan {pm.get('name', '')}".rstrip())
    except PlanError as exc:
        raise RecordError(f"the session's plan is invalid: {exc}") from None
    sets_raw = meta.get("param_sets")
    if not isinstance(sets_raw, list):
        raise RecordError(f"{side}: param_sets must be a list")
    sets = {
        ps.crc32: ps
        for ps in (
            ParamSetRecord.from_json(d, f"{side}: param_sets[{i}]") for i, d in enumerate(sets_raw)
        )
    }
    pts_path = path / POINTS_CSV
    warnings: list[str] = []
    if not pts_path.exists():
        raise RecordError(f"{path}: no {POINTS_CSV}")
    if repair and truncate_partial_line(pts_path):
        warnings.append(f"{pts_path}: dropped a last row cut short (never acknowledged)")
    t = CsvTable(pts_path, "points file")
    if t.cut_short:
        warnings.append(f"{pts_path}: ignored a last row cut short (never acknowledged)")
    if tuple(t.header) != POINT_COLUMNS:
        raise RecordError(f"{pts_path}:{t.header_line}: header is not that of {SESSION_FORMAT}")
    points: list[CapturedPoint] = []
    for n, (line, row) in enumerate(t):
        if len(row) != len(POINT_COLUMNS):
            raise t.fail(line, f"{len(row)} fields, expected {len(POINT_COLUMNS)}")
        f = dict(zip(POINT_COLUMNS, row, strict=True))
        slot_i = _int(t, line, "slot", f["slot"], 0, 1 << 31)
        if slot_i != n:
            raise t.fail(line, f"slot {slot_i} where slot {n} was expected (rows out of order)")
        if n >= len(plan.slots):
            raise t.fail(line, f"more points than the plan's {len(plan.slots)}")
        slot = plan.slots[n]
        if row[: len(LABEL_COLUMNS)] != _label_fields(slot):
            raise t.fail(line, f"labels do not match slot {n} of the plan ({slot.text})")
        crc_s = f["param_crc32"]
        try:
            crc = int(crc_s, 16) if crc_s.startswith("0x") else -1
        except ValueError:
            crc = -1
        if crc not in sets:
            raise t.fail(line, f"parameter set {crc_s!r} is not listed in {SIDECAR}")
        counts = tuple(_int(t, line, c, f[c], 0, 0xFFFFFFFF) for c in COUNT_COLUMNS)
        try:
            xyz = (float(f["x_mm"]), float(f["y_mm"]), float(f["z_mm"]))
            host_time = float(f["host_time"])
        except ValueError:
            raise t.fail(line, "bad number in host_time or x_mm, y_mm, z_mm") from None
        points.append(
            CapturedPoint(
                slot=n,
                step_index=slot.step_index,
                step_id=slot.step_id,
                procedure=slot.procedure,
                artefact=slot.artefact,
                position_index=slot.position_index,
                end=slot.end,
                articulation_index=slot.articulation_index,
                point_index=slot.point_index,
                seq=_int(t, line, "seq", f["seq"], 0, 0xFFFFFFFF),
                device_time_us=_int(t, line, "device_time_us", f["device_time_us"], 0, 1 << 64),
                host_time=host_time,
                button=_int(t, line, "button", f["button"], 0, 255),
                counts=counts,
                point_mm=xyz,
                flags=_int(t, line, "flags", f["flags"], 0, 0xFFFFFFFF),
                param_set=sets[crc],
            )
        )
    n = len(points)
    return Session(
        path=path,
        counts=np.array([p.counts for p in points], dtype=np.uint64).reshape(n, 6),
        param_crc32=np.array([p.param_set.crc32 for p in points], dtype=np.uint32),
        param_sets=sets,
        meta=meta,
        plan=plan,
        points=tuple(points),
        device_points_mm=np.array([p.point_mm for p in points], dtype=np.float64).reshape(n, 3),
        device_time_us=np.array([p.device_time_us for p in points], dtype=np.int64),
        step_index=np.array([p.step_index for p in points], dtype=np.int64),
        point_index=np.array([p.point_index for p in points], dtype=np.int64),
        warnings=tuple(warnings),
    )


def session_exists(folder: str | Path) -> bool:
    """True if ``folder`` holds a session sidecar."""
    return (Path(folder) / SIDECAR).is_file()


__all__ = [
    "EVENTS",
    "EVENTS_CSV",
    "EVENT_COLUMNS",
    "POINTS_CSV",
    "POINT_COLUMNS",
    "SESSION_FORMAT",
    "SIDECAR",
    "CapturedPoint",
    "Session",
    "SessionWriter",
    "read_session",
    "session_exists",
]
