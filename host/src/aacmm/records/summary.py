"""What a log or a capture session holds, as the figures ``aacmm summary`` prints.

* :func:`summarize_file` -- a log (``aacmm log``): samples, duration, rate while
  connected, reconnect gaps, lost samples, triggers, parameter sets, the
  extent of the point cloud and the range of the link temperatures;
* :func:`summarize_session` -- a capture session: plan, status, device,
  parameter sets, points per step, the range of the link temperatures the
  device read and the temperatures the capture runs state.

Both read files cut short by kill -9 and return what is damaged in
``damage`` (the caller decides what a damaged file means).

Errors: :class:`aacmm.records.files.RecordError` -- a file that cannot be
read or breaks its format (one line, naming the file and line).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from aacmm.records.logs import log_summary, read_log, temperature_summary
from aacmm.records.measured import stated_temperatures
from aacmm.records.session_reader import read_session

__all__ = ["summarize_file", "summarize_session"]


def summarize_file(path: Path) -> dict[str, Any]:
    """Samples, duration, rate while connected, gaps, lost samples and extent of a log
    (:func:`aacmm.records.logs.log_summary`; works on a log cut short by kill -9).

    Raises:
        RecordError: unreadable file or sidecar, not a log, a bad row.
    """
    return log_summary(read_log(path))


def summarize_session(folder: Path) -> dict[str, Any]:
    """Plan, status, device, parameter sets and points per step of a capture session.

    Raises:
        RecordError: not a session folder, an unknown format, a damaged file
        (:func:`aacmm.records.session_reader.read_session`).
    """
    s = read_session(folder)
    steps = []
    for st in s.plan.steps:
        steps.append(
            {"id": st.id, "procedure": st.procedure, "points": len(s.rows_of(st.index)),
             "of": st.points}
        )  # fmt: skip
    dev = s.device or {}
    return {
        "session": str(folder),
        "status": s.status,
        "plan": s.meta["plan"].get("name", ""),
        "title": s.plan.title,
        "points": len(s.points),
        "of": len(s.plan.slots),
        "complete": s.complete,
        "device_serial_number": dev.get("serial_number"),
        "joints": s.joints,
        "param_sets": [crc for _, crc in s.set_changes()],
        "runs": [r.get("kind") for r in s.meta.get("runs", []) if isinstance(r, dict)],
        "steps": steps,
        "temperature_c": temperature_summary(s.device_temp_c),
        "stated_temperature_c": sorted({t for t in stated_temperatures(s) if t is not None}),
        "warnings": list(s.warnings),
        "damage": list(s.damage),
    }
