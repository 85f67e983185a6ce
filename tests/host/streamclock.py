"""Does a stream keep its rate? Judged from the device's own timestamps, in a way a
loaded machine cannot fool (standard library only: tests/device/sim_smoke.py runs
it with the system's Python).

Stream sample ``k`` is read at its deadline ``t0 + k / rate`` or later: late when
the device (the simulator process, or QEMU) was descheduled, and a late sample keeps
its number and carries the time it was read (docs/architecture.md "Streams"). So
``(seq, time)`` pairs over a window cannot give the rate as ``samples / time span``:
one late sample at either end of the window moves that figure by its lateness. The
earliest ``time - seq / rate`` of a stretch of the stream, though, is the schedule's
origin, whatever the lateness of the others; comparing it between the first and the
second half of the stream gives how far the schedule moved (0 to microseconds when
the device keeps the rate asked for; the accumulated difference when it does not).
"""

from __future__ import annotations

from collections.abc import Sequence


def schedule_drift_us(seqs: Sequence[int], times_us: Sequence[int], rate_hz: float) -> float:
    """How far the schedule moved between the two halves of the stream, in us.

    ``seqs`` and ``times_us`` are the samples' numbers and device times, in order
    (at least two samples).
    """
    if len(seqs) != len(times_us) or len(seqs) < 2:
        raise ValueError("need at least two samples, each with a number and a time")
    period_us = 1e6 / rate_hz
    offsets = [t - s * period_us for s, t in zip(seqs, times_us, strict=True)]
    half = len(offsets) // 2
    return min(offsets[half:]) - min(offsets[:half])


def schedule_rate_hz(seqs: Sequence[int], times_us: Sequence[int], rate_hz: float) -> float:
    """The rate the device's schedule kept (``rate_hz`` when it did not drift)."""
    span_us = (seqs[-1] - seqs[0]) * 1e6 / rate_hz
    return rate_hz / (1.0 + schedule_drift_us(seqs, times_us, rate_hz) / span_us)
