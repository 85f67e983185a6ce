"""Shared fixtures for the vcan suites.

Tests that need a SocketCAN interface take the ``vcan_iface`` fixture. Under
tests/vcan/run-in-vcan.sh (AACMM_VCAN is set) a missing interface is an error;
a plain ``pytest`` run on a host without vcan0 skips those tests instead.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

INSIDE_RUNNER = bool(os.environ.get("AACMM_VCAN"))

# The runner's own tests start the runner (and VMs); they run on the host,
# never inside the runner.
collect_ignore = ["test_runner.py"] if INSIDE_RUNNER else []


def _iface_up(name: str) -> bool:
    try:
        flags = int(Path(f"/sys/class/net/{name}/flags").read_text(), 16)
    except (OSError, ValueError):
        return False
    return bool(flags & 0x1)  # IFF_UP


@pytest.fixture(scope="session")
def vcan_iface() -> str:
    name = os.environ.get("AACMM_VCAN_IFACES", "vcan0").split()[0]
    if not _iface_up(name):
        msg = f"SocketCAN interface {name} is not up"
        if INSIDE_RUNNER:
            pytest.fail(msg)
        pytest.skip(f"{msg}; run through tests/vcan/run-in-vcan.sh")
    return name
