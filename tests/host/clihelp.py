"""Helpers shared by the CLI tests of the host suites: run the installed
``aacmm`` command, check a one-line error, and a simulator fixture."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from aacmm.commands.sim import SimProcess, find_simulator
from aacmm.errors import AacmmError

AACMM = Path(sys.executable).with_name("aacmm")


def cli_env() -> dict[str, str]:
    """The environment without ``$AACMM_PORT`` (each test names its port)."""
    return {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}


def run(
    *args: str, timeout: float = 60, cwd: Path | None = None
) -> subprocess.CompletedProcess[str]:
    """Run ``aacmm ARGS`` to the end; output captured as text."""
    return subprocess.run(
        [str(AACMM), *args], capture_output=True, text=True, timeout=timeout, env=cli_env(), cwd=cwd
    )


def one_error_line(p: subprocess.CompletedProcess[str], code: int, *words: str) -> str:
    """Exit status ``code`` and exactly one line on stderr naming ``words``."""
    assert p.returncode == code, (p.returncode, p.stdout, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    assert lines[0].startswith("aacmm "), lines
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])
    return lines[0]


def sim_fixture(*args: str) -> Any:
    """A module-scoped ``sim`` fixture: one simulator on a pty (``make sim``
    builds it), with extra simulator options ``args``. Use in a test module as
    ``sim = sim_fixture()``."""

    @pytest.fixture(scope="module", name="sim")
    def _sim() -> Iterator[SimProcess]:
        try:
            find_simulator()
        except AacmmError as exc:
            pytest.fail(f"{exc} (the suite's make target builds it)")
        with SimProcess(["--serial", "pty", "--quiet", *args]) as s:
            yield s

    return _sim
