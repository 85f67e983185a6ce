"""The client's defaults and limits (timeouts, retries, URL variable) and the timeout check."""

from __future__ import annotations

from typing import Final

from aacmm.protocol import MsgType

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
