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
tests may feed it synthetic samples; :mod:`aacmm.records.session_writer`);
:func:`read_session` reads one into a :class:`Session`
(:mod:`aacmm.records.session_reader`); the file names and columns are in
:mod:`aacmm.records.session_format`. This module re-exports them all.
Every accepted point is durable (written and fsynced) before
:meth:`SessionWriter.record` returns, so a capture killed at any moment
loses no acknowledged point; an undo rewrites ``points.csv`` atomically.
"""

from aacmm.records.session_format import (
    COUNT_COLUMNS,
    EVENT_COLUMNS,
    EVENTS,
    EVENTS_CSV,
    LABEL_COLUMNS,
    POINT_COLUMNS,
    POINTS_CSV,
    PROGRESS,
    PROGRESS_FORMAT,
    SAMPLE_COLUMNS,
    SESSION_FORMAT,
    SIDECAR,
    STATUSES,
    UNITS,
)
from aacmm.records.session_reader import CapturedPoint, Session, read_session, session_exists
from aacmm.records.session_writer import SessionWriter

__all__ = [
    "COUNT_COLUMNS",
    "EVENTS",
    "EVENTS_CSV",
    "EVENT_COLUMNS",
    "LABEL_COLUMNS",
    "POINTS_CSV",
    "POINT_COLUMNS",
    "PROGRESS",
    "PROGRESS_FORMAT",
    "SAMPLE_COLUMNS",
    "SESSION_FORMAT",
    "SIDECAR",
    "STATUSES",
    "UNITS",
    "CapturedPoint",
    "Session",
    "SessionWriter",
    "read_session",
    "session_exists",
]
