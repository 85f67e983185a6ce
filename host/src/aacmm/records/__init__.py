"""Recorded data: logs and capture sessions, one family of files, one module.

Writers and readers of everything aacmm records, the schema versions, and the
parameter set in force per row (each row names its set by CRC; the sidecar
holds every set with its encoder configuration). ``aacmm log``, ``summary``,
``mc --log``, ``capture`` and the analysis commands read and write through
here, so a format change is made in one place. Formats: docs/cli.md (logs)
and docs/plans.md (sessions).

Main names:

* :class:`ParamSetRecord` -- one parameter set in force (CRC, ``core.Params``,
  ``core.EncoderConfig``).
* :class:`Recorded` -- rows of counts with their sets: :meth:`Recorded.angles_rad`,
  :meth:`Recorded.points_mm` (recompute with each row's set, or given parameters).
* :class:`SessionWriter`, :func:`read_session`, :class:`Session`,
  :class:`CapturedPoint` -- capture sessions.
* :class:`RecordError` -- a file that cannot be read or breaks its format
  (one line, naming the file and line).

A pure library: no printing, no argparse.
"""

from aacmm.records.files import RecordError, crc_hex, fmt_point
from aacmm.records.paramsets import ParamSetRecord
from aacmm.records.rows import Recorded
from aacmm.records.sessions import (
    EVENT_COLUMNS,
    POINT_COLUMNS,
    SESSION_FORMAT,
    CapturedPoint,
    Session,
    SessionWriter,
    read_session,
    session_exists,
)

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
]
