"""The session folder's format: file names, columns and units, and a point's row fields.

Shared by :mod:`aacmm.records.session_writer` and
:mod:`aacmm.records.session_reader` (docs/plans.md). A capture session is one
folder (format ``aacmm-session-1``)::


    SESSION/
      session.json   the sidecar: plan (its full text), device identity, port,
                     every parameter set in force (with CRC and encoder
                     configuration), status, runs (capture, resume, ...)
      points.csv     the accepted points, one row per point in plan order, labelled
      events.csv     the journal: every button event, undo and run, append-only
      progress.json  the slot expected next (replaced atomically after every change)

:class:`~aacmm.records.session_writer.SessionWriter` makes and extends
sessions (``aacmm capture`` uses it; tests may feed it synthetic samples);
:func:`~aacmm.records.session_reader.read_session` reads one into a
:class:`~aacmm.records.session_reader.Session`. Every accepted point is
durable (written and fsynced) before ``SessionWriter.record`` returns, so a
capture killed at any moment loses no acknowledged point; an undo rewrites
``points.csv`` atomically.

A session of an arm of N joints (4 to 7) has the count columns
``count1..countN`` in ``points.csv`` and ``events.csv`` and ``"joints": N``
in its sidecar; a session without ``joints`` (written before arms of other
joint counts) is of the paper's six. After the counts come the device's link
temperatures ``temp1_c..tempN_c`` (degC; empty where the sample has none);
sessions written before device temperatures lack these columns, and a
resumed one keeps its columns. The functions below give the columns
for N; the constants are the paper's arm's.
"""

from __future__ import annotations

from aacmm.plans import Slot
from aacmm.protocol import Sample
from aacmm.records.files import crc_hex, fmt_point
from aacmm.records.schema import temp_columns, temp_fields

SESSION_FORMAT = "aacmm-session-1"
SIDECAR = "session.json"
POINTS_CSV = "points.csv"
EVENTS_CSV = "events.csv"
PROGRESS = "progress.json"
PROGRESS_FORMAT = "aacmm-progress-1"
JOINTS = 6
"""The joint count of a session whose sidecar names none (the paper's arm)."""
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


def count_columns(joints: int = JOINTS) -> tuple[str, ...]:
    """``count1 .. countN``."""
    return tuple(f"count{i}" for i in range(1, joints + 1))


def sample_columns(joints: int = JOINTS, temps: bool = True) -> tuple[str, ...]:
    """The latched sample's columns (in ``points.csv`` and ``events.csv``); ``temps``:
    with the device's link temperatures ``temp1_c .. tempN_c`` (every session written
    since device temperatures; older ones have none)."""
    return (
        "seq",
        "device_time_us",
        "host_time",
        "button",
        *count_columns(joints),
        *(temp_columns(joints) if temps else ()),
        "x_mm",
        "y_mm",
        "z_mm",
        "flags",
        "param_crc32",
    )


def point_columns(joints: int = JOINTS, temps: bool = True) -> tuple[str, ...]:
    """The columns of ``points.csv`` of an arm of ``joints`` joints."""
    return LABEL_COLUMNS + sample_columns(joints, temps)


def event_columns(joints: int = JOINTS, temps: bool = True) -> tuple[str, ...]:
    """The columns of ``events.csv`` of an arm of ``joints`` joints."""
    return ("event_time", "event", "slot", "pressed", *sample_columns(joints, temps), "detail")


def units(joints: int = JOINTS) -> dict[str, str]:
    """The sidecar's ``units`` for ``joints`` joints."""
    names = {
        "count1..count6": f"count1..count{joints}",
        "temp1_c..temp6_c": f"temp1_c..temp{joints}_c",
    }
    return {names.get(k, k): v for k, v in UNITS.items()}


COUNT_COLUMNS: tuple[str, ...] = count_columns()
SAMPLE_COLUMNS: tuple[str, ...] = sample_columns()
POINT_COLUMNS: tuple[str, ...] = point_columns()
EVENT_COLUMNS: tuple[str, ...] = event_columns()
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
    "temp1_c..temp6_c": "the device's link temperatures, degC (0.01); empty: no reading "
    "(a sensor that did not answer, or a device without sensors)",
    "x_mm,y_mm,z_mm": "probe point computed by the device, mm (resolution 0.0001 mm)",
    "flags": "sample status bits (docs/protocol.md 2.4)",
    "param_crc32": "CRC of the parameter set in force (session.json param_sets)",
}
STATUSES: tuple[str, ...] = ("running", "complete", "interrupted", "link_lost", "error")


def opt_field(v: int | None) -> str:
    """An optional index as a CSV field (empty for None)."""
    return "" if v is None else str(v)


def sample_fields(
    sample: Sample, host_time: float, button: int, crc: int, temps: bool = True
) -> list[str]:
    """The :func:`sample_columns` fields of a latched sample."""
    x, y, z = sample.point_100nm
    return [
        str(sample.seq),
        str(sample.timestamp_us),
        f"{host_time:.6f}",
        str(button),
        *(str(c) for c in sample.counts),
        *(temp_fields(sample.temp, len(sample.counts)) if temps else ()),
        fmt_point(x),
        fmt_point(y),
        fmt_point(z),
        str(sample.status),
        crc_hex(crc),
    ]


def label_fields(slot: Slot) -> list[str]:
    """The :data:`LABEL_COLUMNS` fields of a plan slot."""
    return [
        str(slot.index),
        str(slot.step_index),
        slot.step_id,
        slot.procedure,
        slot.artefact or "",
        opt_field(slot.position_index),
        slot.end or "",
        opt_field(slot.articulation_index),
        str(slot.point_index),
    ]
