"""Test helper of the simulation suites: a simulator driven through its control
channel (``aacmm-sim --control FD``)."""

from __future__ import annotations

import itertools
import os
from pathlib import Path

from aacmm.commands.sim import SimProcess
from aacmm.simulation.control import ControlChannel

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
    trigger took a number; no trigger sample among the stream samples; and
    the rate, from numbers and device time, the one asked for."""
    assert all(b > a for a, b in itertools.pairwise(seqs)), "repeated or reordered"
    for k in range(1, len(seqs)):
        if seqs[k] - seqs[k - 1] != 1:
            assert flags[k] & OVERRUN, f"gap before seq {seqs[k]} without OVERRUN"
    assert not any(f & TRIGGER_EVENT for f in flags), "a trigger sample in the stream"
    span_s = (times_us[-1] - times_us[0]) * 1e-6
    rate = (seqs[-1] - seqs[0]) / span_s
    assert abs(rate / rate_hz - 1.0) <= 0.005, f"stream rate {rate:.2f} Hz, asked {rate_hz} Hz"
