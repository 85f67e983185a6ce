"""Poses from a measurement log, for the Monte Carlo analysis (``aacmm mc --log``).

The files are read by :func:`aacmm.records.logs.read_log` (the one reader of
recorded data; formats in docs/cli.md): an ``aacmm log`` CSV with its
sidecar, or a plain CSV of poses -- ``count1..count6`` (or ``c1..c6``) raw
encoder counts, or ``theta1..theta6`` angles in rad, ``#`` comments allowed,
with an optional sidecar ``<file>.json`` (also ``<stem>.json``) holding
``encoders`` and ``params`` (an arm of N joints: ``count1..countN`` or
``theta1..thetaN``, and a sidecar with its ``params``).

Counts are converted to angles row by row with the encoder configuration of
the parameter set in force for that row. The analysis uses one kinematic
parameter set: a log whose rows were taken with different kinematic
parameters (a reconnect to a device with another set) is refused with a
clear error rather than converted with the wrong set.

Errors: :class:`PoseLogError` (an ``AacmmError`` and a ``ValueError``), one
line naming the file (and line).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from aacmm.arm import Arm
from aacmm.core import EncoderConfig, FloatArray, Params
from aacmm.errors import AacmmError
from aacmm.records.files import RecordError
from aacmm.records.logs import read_log
from aacmm.records.schema import COUNT_ALIASES, COUNT_COLUMNS, THETA_COLUMNS

__all__ = [
    "COUNT_ALIASES",
    "COUNT_COLUMNS",
    "THETA_COLUMNS",
    "PoseLog",
    "PoseLogError",
    "read_pose_log",
]


class PoseLogError(AacmmError, ValueError):
    """A pose log cannot be read or does not follow the contract."""


@dataclass(frozen=True)
class PoseLog:
    """Poses read from a log: ``theta_rad`` (n, N), the columns used, the encoder
    configuration of the first row, the kinematic parameters (None: the file
    names none, use the default; an Arm for an arm of another shape), the sidecar."""

    path: Path
    theta_rad: FloatArray
    columns: tuple[str, ...]
    encoders: EncoderConfig
    params: Params | Arm | None
    sidecar: Path | None


def read_pose_log(path: str | Path, encoders: EncoderConfig | None = None) -> PoseLog:
    """Read the poses of a log CSV (see the module docstring).

    ``encoders`` overrides the encoder configuration of every row.

    Raises:
        PoseLogError: unreadable file, no joint columns, a bad value (with its
            line), an empty log, a bad sidecar, or kinematic parameters that
            change within the log.
    """
    try:
        log = read_log(path, encoders)
        theta = log.angles_rad()
        params = log.single_params("mc --log") if log.params_given else None
    except RecordError as exc:
        raise PoseLogError(str(exc)) from None
    first = log.param_set_of(0)
    return PoseLog(log.path, theta, log.columns, first.encoders, params, log.sidecar)
