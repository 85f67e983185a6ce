"""Fixtures of the simulation suites."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from simctl import ControlledSim


@pytest.fixture
def controlled() -> Iterator[ControlledSim]:
    """A simulator on a pty driven through its control channel."""
    with ControlledSim("--serial", "pty", "--quiet") as s:
        yield s
