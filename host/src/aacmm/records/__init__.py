"""Recorded data: logs and capture sessions, one family of files, one module.

Writers and readers of everything aacmm records, the schema versions, and the
parameter set in force per row (each row names its set by CRC; the sidecar
holds every set with its encoder configuration). ``aacmm log``, ``summary``,
``mc --log``, ``capture`` and the analysis commands read and write through
here, so a format change is made in one place. Formats: docs/cli.md (logs)
and docs/plans.md (sessions).

Main names:

* :class:`ParamSetRecord` -- one parameter set in force (CRC, the model:
  ``core.Params`` for the paper's shape or an ``arm.Arm`` of 4 to 7 joints,
  ``core.EncoderConfig``).
* :class:`Recorded` -- rows of N counts with their sets (readers refuse
  counts that do not match the sets' arm; :meth:`Recorded.check_model`):
  :meth:`Recorded.angles_rad`, :meth:`Recorded.points_mm` (recompute with each
  row's set, or given parameters).
* :class:`SessionWriter`, :func:`read_session`, :class:`Session`,
  :class:`CapturedPoint` -- capture sessions.
* :func:`summarize_file`, :func:`summarize_session` -- what a log or a session
  holds (``aacmm summary``).
* :class:`RecordError` -- a file that cannot be read or breaks its format
  (one line, naming the file and line).

A pure library: no printing, no argparse.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aacmm.records.files import RecordError as RecordError
    from aacmm.records.files import crc_hex as crc_hex
    from aacmm.records.files import fmt_point as fmt_point
    from aacmm.records.paramsets import ParamSetRecord as ParamSetRecord
    from aacmm.records.rows import Recorded as Recorded
    from aacmm.records.session_format import EVENT_COLUMNS as EVENT_COLUMNS
    from aacmm.records.session_format import POINT_COLUMNS as POINT_COLUMNS
    from aacmm.records.session_format import SESSION_FORMAT as SESSION_FORMAT
    from aacmm.records.session_reader import CapturedPoint as CapturedPoint
    from aacmm.records.session_reader import Session as Session
    from aacmm.records.session_reader import read_session as read_session
    from aacmm.records.session_reader import session_exists as session_exists
    from aacmm.records.session_writer import SessionWriter as SessionWriter
    from aacmm.records.summary import summarize_file as summarize_file
    from aacmm.records.summary import summarize_session as summarize_session

# Loaded on first use, so that importing a light submodule (aacmm.records.files,
# .schema) from a command's top level does not pull numpy and the C core in.
_WHERE = {
    "RecordError": "files",
    "crc_hex": "files",
    "fmt_point": "files",
    "ParamSetRecord": "paramsets",
    "Recorded": "rows",
    "EVENT_COLUMNS": "session_format",
    "POINT_COLUMNS": "session_format",
    "SESSION_FORMAT": "session_format",
    "CapturedPoint": "session_reader",
    "Session": "session_reader",
    "SessionWriter": "session_writer",
    "read_session": "session_reader",
    "session_exists": "session_reader",
    "summarize_file": "summary",
    "summarize_session": "summary",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(importlib.import_module(f"aacmm.records.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'aacmm.records' has no attribute {name!r}")


__all__ = [
    "EVENT_COLUMNS",
    "POINT_COLUMNS",
    "SESSION_FORMAT",
    "CapturedPoint",
    "ParamSetRecord",
    "RecordError",
    "Recorded",
    "Session",
    "SessionWriter",
    "crc_hex",
    "fmt_point",
    "read_session",
    "session_exists",
    "summarize_file",
    "summarize_session",
]
