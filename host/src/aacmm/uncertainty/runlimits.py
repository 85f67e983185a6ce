"""How long and how large an analysis run will be, and the limits it must stay within.

The Monte Carlo commands (``aacmm mc``, ``uncertainty``, ``tolerance``) take
a number of trials a person types, and 10^12 is as easy to type as 10^4.
Before the bulk of a run, its time is estimated from the run itself
(:class:`RunClock`: the rate over its first half second, so the estimate is
this machine's, at its present load) and its memory from its sizes; a run
that would exceed :data:`MAX_RUN_S` (a day, unless the caller gives another
limit) or half the memory available is refused with the estimate
(:class:`RunLimitError`), at once instead of after hours or in a traceback.

Pure: numbers in, numbers out or an exception; the commands print.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from typing import Final

from aacmm.errors import AacmmError

__all__ = [
    "LONG_RUN_S",
    "MAX_RUN_S",
    "MEMORY_FRACTION",
    "RunClock",
    "RunEstimate",
    "RunLimitError",
    "available_memory",
    "check_memory",
    "format_bytes",
    "format_count",
    "format_duration",
]

MAX_RUN_S: Final = 86_400.0
"""Longest run accepted by default: a day (the commands' ``--max-hours``)."""
LONG_RUN_S: Final = 10.0
"""A run estimated at least this long is announced with its estimate first."""
MEMORY_FRACTION: Final = 0.5
"""Largest share of the memory available (MemAvailable) a run may plan to use."""
WARM_UP_S: Final = 0.5
"""Seconds of a run measured before its time is estimated."""


class RunLimitError(AacmmError, ValueError):
    """A run would exceed the time or memory limit (the message gives the estimate)."""


def format_duration(seconds: float) -> str:
    """``"45 s"``, ``"12 min"``, ``"3 h 20 min"``, ``"2.5 days"``, ``"31 years"``."""
    s = float(seconds)
    if not math.isfinite(s):
        return "forever"
    if s < 60:
        return f"{max(s, 0.0):.0f} s"
    if s < 3600:
        return f"{s / 60:.0f} min"
    if s <= 86_400:
        h, m = divmod(round(s / 60), 60)
        return f"{h} h {m} min" if m else f"{h} h"
    if s < 365 * 86_400:
        return f"{s / 86_400:.1f} days"
    return f"{s / (365.25 * 86_400):.3g} years"


def format_bytes(n: float) -> str:
    """``"512 MiB"``, ``"3.8 GiB"``, ``"182 TiB"``."""
    for unit, size in (("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size:
            v = n / size
            return f"{v:.1f} {unit}" if v < 10 else f"{v:.0f} {unit}"
    return f"{n:.0f} bytes"


def format_count(n: float) -> str:
    """A count as a person reads it: ``"100000"``, ``"10^12"``, ``"3.5e11"``."""
    if n < 1e6:
        return f"{n:.0f}"
    e = math.floor(math.log10(n))
    mant = float(f"{n / 10**e:.2g}")
    if mant >= 10:
        mant, e = mant / 10, e + 1
    return f"10^{e}" if mant == 1.0 else f"{mant:g}e{e}"


def available_memory() -> int:
    """Bytes of memory available to this process (MemAvailable, else physical)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (OSError, ValueError, AttributeError):
        return 1 << 34


def check_memory(need_bytes: float, what: str, hint: str) -> None:
    """Refuse a run planning more than :data:`MEMORY_FRACTION` of the memory available.

    ``what``: the run (``"the Monte Carlo check of 10^12 arms"``); ``hint``:
    what to do instead (``"use fewer --trials"``).

    Raises:
        RunLimitError: with the estimate and the memory available.
    """
    avail = available_memory()
    if need_bytes > MEMORY_FRACTION * avail:
        raise RunLimitError(
            f"{what} needs about {format_bytes(need_bytes)} of memory, more than half the "
            f"{format_bytes(avail)} available: {hint}"
        )


@dataclass(frozen=True)
class RunEstimate:
    """The time a run is expected to take, measured on its first part.

    ``seconds``: the whole run; ``remaining_s``: from now; ``rate``: units of
    work per second; ``total``: units of work; ``unit``: their name.
    """

    total: float
    unit: str
    rate: float
    seconds: float
    remaining_s: float

    def describe(self) -> str:
        """``"about 1 h 20 min (10^12 poses at 7.2 million per second)"``."""
        return (
            f"about {format_duration(self.seconds)} ({format_count(self.total)} {self.unit} "
            f"at {_rate_text(self.rate)} per second)"
        )


def _rate_text(rate: float) -> str:
    for word, size in (("billion", 1e9), ("million", 1e6), ("thousand", 1e3)):
        if rate >= size:
            return f"{rate / size:.3g} {word}"
    return f"{rate:.3g}"


class RunClock:
    """Times a run from its progress and refuses one that would exceed ``limit_s``.

    Call :meth:`update` with the units of work done (poses, trials) as they
    finish. After :data:`WARM_UP_S` seconds of work it estimates the whole
    run from the rate since the first update (so start-up costs do not count)
    and returns the estimate once (:attr:`estimate` keeps it); a run whose
    estimate exceeds ``limit_s`` raises :class:`RunLimitError` there, before
    the bulk of the work. ``what`` names the run in that message and
    ``hint`` says what to do instead.
    """

    def __init__(
        self,
        total: float,
        unit: str,
        limit_s: float = MAX_RUN_S,
        what: str = "the run",
        hint: str = "ask for less",
        warm_up_s: float = WARM_UP_S,
        clock: object = None,
    ) -> None:
        if not (total > 0 and math.isfinite(total)):
            raise ValueError(f"total work must be positive and finite, got {total!r}")
        if not limit_s > 0:
            raise ValueError(f"the time limit must be positive, got {limit_s!r}")
        self.total = float(total)
        self.unit = unit
        self.limit_s = float(limit_s)
        self.what = what
        self.hint = hint
        self.warm_up_s = warm_up_s
        self._now = clock if callable(clock) else time.monotonic
        self.t0 = float(self._now())
        self.done = 0.0
        self._first: tuple[float, float] | None = None
        self.estimate: RunEstimate | None = None

    def elapsed(self) -> float:
        return float(self._now()) - self.t0

    def current(self) -> RunEstimate | None:
        """The estimate from the progress so far (None before any measurable progress)."""
        if self._first is None:
            return None
        t_first, d_first = self._first
        now = float(self._now())
        dt, dd = now - t_first, self.done - d_first
        if dt <= 0 or dd <= 0:
            return None
        rate = dd / dt
        remaining = max(self.total - self.done, 0.0) / rate
        return RunEstimate(self.total, self.unit, rate, now - self.t0 + remaining, remaining)

    def preset(self, seconds: float) -> RunEstimate:
        """Take an estimate made another way (a pilot run) for the whole run.

        Raises:
            RunLimitError: it exceeds the limit.
        """
        self.estimate = RunEstimate(
            self.total, self.unit, self.total / max(seconds, 1e-9), seconds, seconds
        )
        self._check(self.estimate)
        return self.estimate

    def _check(self, est: RunEstimate) -> None:
        if est.seconds > self.limit_s:
            raise RunLimitError(
                f"{self.what} would take {est.describe()}, more than the limit of "
                f"{format_duration(self.limit_s)}: {self.hint}"
            )

    def update(self, n: float) -> RunEstimate | None:
        """Add ``n`` units done; the estimate the first time one is made, else None.

        Raises:
            RunLimitError: the first estimate exceeds the limit.
        """
        now = float(self._now())
        if self._first is None:
            self._first = (now, self.done + n)
        self.done += n
        if self.estimate is not None or self.done >= self.total:
            return None
        if now - self.t0 < self.warm_up_s or now - self._first[0] <= 0:
            return None
        est = self.current()
        if est is None:
            return None
        self.estimate = est
        self._check(est)
        return est
