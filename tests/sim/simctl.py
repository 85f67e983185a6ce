"""Test helper of the simulation suites: a simulator driven through its control
channel (``aacmm-sim --control FD``)."""

from __future__ import annotations

import itertools
import os
from pathlib import Path

from aacmm.simulation.control import ControlChannel
from aacmm.simulation.process import SimProcess

REPO = Path(__file__).resolve().parents[2]
os.environ.setdefault("AACMM_SIM", str(REPO / "build" / "sim" / "aacmm-sim"))


class ControlledSim:
    """``aacmm-sim --control`` with its channel; a context manager."""

    def __init__(self, *args: str) -> None:
        self.chan, fd = ControlChannel.pair()
        try:
            self.sim = SimProcess([*args, "--control", str(fd)], pass_fds=[fd])
        finally:
            self.chan.child_started()
        self.chan.hello()

    @property
    def url(self) -> str:
        return self.sim.url

    def __enter__(self) -> ControlledSim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.chan.close()
        self.sim.stop()


OVERRUN = 0x20
TRIGGER_EVENT = 0x80


def check_stream(seqs: list[int], flags: list[int], times_us: list[int], rate_hz: float) -> None:
    """A stream as docs/protocol.md 2.7 and 2.4 have it: numbers strictly
    increasing; a gap only where the device says it dropped samples (OVERRUN
    on the next one, e.g. a stale sample under heavy load), never because a
    trigger took a number; no trigger sample among the stream samples; and the
    numbers keep time with the clock at the rate asked for.

    The last check does not depend on load: sample k is read at its deadline
    or later (a late one keeps its number, docs/architecture.md "Streams"), so
    the earliest ``time - seq / rate`` of the first half and of the second half
    of the stream agree to less than a period (to microseconds on a quiet
    machine). A stream whose numbers run ahead of its clock (each trigger
    taking a number: the tests press at least twice in each half; or a rate
    other than the one asked for) moves the second one by whole periods.
    """
    assert all(b > a for a, b in itertools.pairwise(seqs)), "repeated or reordered"
    for k in range(1, len(seqs)):
        if seqs[k] - seqs[k - 1] != 1:
            assert flags[k] & OVERRUN, f"gap before seq {seqs[k]} without OVERRUN"
    assert not any(f & TRIGGER_EVENT for f in flags), "a trigger sample in the stream"
    period_us = 1e6 / rate_hz
    offsets = [t - s * period_us for s, t in zip(seqs, times_us, strict=True)]
    half = len(offsets) // 2
    drift = min(offsets[half:]) - min(offsets[:half])
    span = (seqs[-1] - seqs[0]) * period_us
    assert abs(drift) < period_us, (
        f"the numbers drift {drift:.0f} us against the clock over {span / 1e6:.2f} s "
        f"({rate_hz / (1 + drift / span):.2f} Hz, asked {rate_hz} Hz)"
    )
