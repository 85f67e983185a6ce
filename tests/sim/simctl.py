"""Test helper of the simulation suites: a simulator driven through its control
channel (``aacmm-sim --control FD``)."""

from __future__ import annotations

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
