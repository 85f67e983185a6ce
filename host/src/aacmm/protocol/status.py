"""Status codes shared with the firmware (``firmware/include/aacmm/status.h``).

The values travel in error responses and must never be renumbered; a test
compares this enum with the C header.
"""

from __future__ import annotations

from enum import IntEnum


class Status(IntEnum):
    """``aacmm_status_t``: 0 is success, every error is negative."""

    OK = 0
    ERR_NULL = -1
    ERR_RANGE = -2
    ERR_NOT_FINITE = -3
    ERR_BUFFER = -4
    ERR_CRC = -5
    ERR_FRAME = -6
    ERR_LENGTH = -7
    ERR_UNKNOWN_TYPE = -8
    ERR_TIMEOUT = -9
    ERR_BUSY = -10
    ERR_STORAGE = -11
    ERR_UNSUPPORTED = -12
    ERR_STATE = -13
    ERR_OVERFLOW = -14
    ERR_IO = -15
    ERR_VERSION = -16


def status_name(code: int) -> str:
    """A readable name for a status code, also for codes this version does not know."""
    try:
        return Status(code).name
    except ValueError:
        return f"status {code}"
