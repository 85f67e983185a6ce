"""Exit statuses of the ``aacmm`` command, in one place (documented in docs/cli.md).

:func:`exit_code` maps an exception to its status; :func:`aacmm.cli.main`
prints one line for it and returns the status, never a traceback.
"""

from __future__ import annotations

from typing import Final

from aacmm.errors import (
    AacmmError,
    DeviceError,
    DeviceTimeoutError,
    InfeasibleError,
    InitError,
    LinkLostError,
    OperationError,
    VersionMismatchError,
)

OK: Final = 0
"""Success (also: an open-ended ``aacmm log`` stopped with Ctrl-C or SIGTERM)."""
DEVICE: Final = 1
"""The device refused a request, answered nonsense, or read back other values."""
USAGE: Final = 2
"""Bad arguments, a bad URL, a bad or unreadable input file (nothing was sent)."""
PORT: Final = 3
"""The port or bus cannot be opened, or another aacmm process holds it (busy)."""
TIMEOUT: Final = 4
"""The device did not answer in time (after the retries)."""
VERSION: Final = 5
"""The device speaks another protocol version."""
LINK_LOST: Final = 6
"""The link was lost mid-operation (device gone, port closed, samples stopped)."""
NOT_MET: Final = 7
"""The result does not meet the stated requirement (verification verdict FAIL; the
report is still written; ``aacmm plan check --model``: a plan target out of the arm's reach)."""
INFEASIBLE: Final = 8
"""The request cannot be met (a tolerance target no allocation reaches)."""
REFUSED: Final = 9
"""A calibration fails its quality gate (``aacmm calibrate``: one line says why; nothing
is written; ``--override`` writes it anyway, and its provenance says so)."""
WRONG_ARM: Final = 10
"""A file belongs to another arm (its device serial number differs): ``aacmm params set``
of another arm's calibration (``--override`` sends it anyway), ``aacmm demo --check``
with another arm's truth, ``aacmm demo --compare`` of two arms' reports; or to another
arm model than ``--model`` (issue 26): a log of another arm shape (``aacmm mc --log``,
``uncertainty --log``), a spec naming parameters the arm does not have (``aacmm
uncertainty``, ``tolerance``)."""
WORSE: Final = 11
"""A before/after comparison found a figure worse after than before (``aacmm demo
--compare``: the table says which, by what factor)."""
INTERRUPTED: Final = 130
"""Ctrl-C or SIGTERM before the work was done (data written so far is kept)."""

NAMES: Final[dict[int, str]] = {
    OK: "ok",
    DEVICE: "device or operation error",
    USAGE: "usage error or bad input file",
    PORT: "cannot open port, or port busy",
    TIMEOUT: "no answer (timeout)",
    VERSION: "protocol version mismatch",
    LINK_LOST: "link lost mid-operation",
    NOT_MET: "requirement not met (verification FAIL)",
    INFEASIBLE: "infeasible request",
    REFUSED: "calibration refused by its quality gate",
    WRONG_ARM: "a file of another arm",
    WORSE: "worse after than before",
    INTERRUPTED: "interrupted",
}


__all__ = [
    "DEVICE",
    "INFEASIBLE",
    "INTERRUPTED",
    "LINK_LOST",
    "NAMES",
    "NOT_MET",
    "OK",
    "PORT",
    "REFUSED",
    "TIMEOUT",
    "USAGE",
    "VERSION",
    "WORSE",
    "WRONG_ARM",
    "CalibrationRefusedError",
    "UsageError",
    "WrongArmError",
    "exit_code",
]


class UsageError(AacmmError, ValueError):
    """Bad arguments or a bad input file (exit status 2)."""


class CalibrationRefusedError(AacmmError):
    """A calibration failed its quality gate and was not written (exit status 9)."""


class WrongArmError(AacmmError):
    """A calibration, truth or report of another arm than the one at hand (exit status 10)."""


def exit_code(exc: BaseException) -> int:
    """The exit status for an exception that ended a command."""
    if isinstance(exc, KeyboardInterrupt):
        return INTERRUPTED
    if isinstance(exc, VersionMismatchError):
        return VERSION
    if isinstance(exc, CalibrationRefusedError):
        return REFUSED
    if isinstance(exc, WrongArmError):
        return WRONG_ARM
    if isinstance(exc, InfeasibleError):
        return INFEASIBLE
    if isinstance(exc, InitError):
        return PORT
    if isinstance(exc, DeviceTimeoutError):
        return TIMEOUT
    if isinstance(exc, LinkLostError):
        return LINK_LOST
    if isinstance(exc, OperationError) and "link lost" in str(exc):
        return LINK_LOST
    if isinstance(exc, (UsageError, ValueError, TypeError)):
        return USAGE
    if isinstance(exc, (DeviceError, AacmmError)):
        return DEVICE
    return DEVICE
