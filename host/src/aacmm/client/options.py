"""The client's defaults and limits (timeouts, retries, URL variable, link temperatures)
and the checks of timeouts and temperatures."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Final

from aacmm.protocol import MsgType
from aacmm.protocol.constants import TEMP_UNIT_C

ENV_PORT: Final = "AACMM_PORT"
"""Environment variable with the default device URL."""
DEFAULT_TIMEOUT: Final = 1.0
TIMEOUT_MAX: Final = 3600.0
"""Longest wait (s) a timeout may name: longer ones are refused (``inf`` would
overflow the clocks of the waits; no device takes an hour to answer)."""
DEFAULT_RETRIES: Final = 2
TRIGGER_QUEUE: Final = 1024

IDEMPOTENT_REQUESTS: Final = frozenset(
    {
        MsgType.PING_REQ,
        MsgType.INFO_REQ,
        MsgType.GET_PARAMS_REQ,
        MsgType.MEASURE_REQ,
        MsgType.COMPUTE_REQ,
        MsgType.STREAM_START_REQ,
        MsgType.STREAM_STOP_REQ,
        MsgType.DIAG_REQ,
    }
)
"""Requests that may be sent again after a timeout; the others are sent once."""


def check_timeout(value: object, name: str = "timeout", *, poll: bool = False) -> float:
    """``value`` as a float of seconds in (0, :data:`TIMEOUT_MAX`] (``[0, ...]`` with
    ``poll``: waits for something already queued may be 0, "do not wait").

    Raises:
        ValueError: not a number, not finite, negative or zero, or above the maximum.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name} must be a number of seconds, got {value!r}")
    t = float(value)
    lo_ok = t >= 0.0 if poll else t > 0.0
    if not (lo_ok and t <= TIMEOUT_MAX):  # also refuses nan
        bracket = "[" if poll else "("
        raise ValueError(f"{name} must be in {bracket}0, {TIMEOUT_MAX:g}] seconds, got {value!r}")
    return t


TEMP_MIN_WIRE = -4000
"""The coldest link temperature COMPUTE_REQ takes (0.01 degC: -40 degC)."""
TEMP_MAX_WIRE = 8500
"""The warmest (85 degC)."""


def wire_temperatures(temps_c: Sequence[float], joints: int) -> tuple[int, ...]:
    """Link temperatures in degC as COMPUTE_REQ carries them (i16 of 0.01 degC,
    rounded half away from zero).

    Raises:
        ValueError: not ``joints`` values, or one not finite or outside -40 .. 85 degC.
    """
    values = list(temps_c)
    if len(values) != joints:
        raise ValueError(f"need {joints} link temperatures (one a joint), got {len(values)}")
    out = []
    for i, t in enumerate(values):
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
            raise ValueError(f"link {i + 1}'s temperature must be a finite number of degC")
        q = math.floor(round(abs(t) / TEMP_UNIT_C, 6) + 0.5)
        w = int(-q if t < 0 else q)
        if not TEMP_MIN_WIRE <= w <= TEMP_MAX_WIRE:
            raise ValueError(f"link {i + 1}'s temperature {t:g} C is outside -40 .. 85 C")
        out.append(w)
    return tuple(out)
