"""The serial port lock lives in the transport (issue 14 item 2, first half).

Before, only the CLI locked the port (with its own flock), so a script
calling ``aacmm.client.connect('serial://...')`` while ``aacmm log`` ran
opened the same pty, stole frames (its requests timed out) and made the
logger lose samples. Now the transport opens the port exclusively (pyserial
``exclusive=True``): API and CLI are refused alike, with PortBusyError (exit
status 3 in the CLI).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from aacmm.client import connect
from aacmm.commands import exitcodes
from aacmm.errors import InitError, PortBusyError
from aacmm.simulation.process import SimProcess
from aacmm.transport import SerialTransport
from clihelp import AACMM, cli_env, sim_fixture

pytestmark = pytest.mark.timeout(120)
sim = sim_fixture("--seed", "7")


@pytest.fixture
def pty_path() -> Iterator[str]:
    master, slave = os.openpty()
    try:
        yield os.ttyname(slave)
    finally:
        os.close(master)
        os.close(slave)


def test_second_transport_on_a_port_is_refused(pty_path: str) -> None:
    first = SerialTransport(pty_path)
    try:
        with pytest.raises(PortBusyError, match="busy"):
            SerialTransport(pty_path)  # same process, another connection
        with pytest.raises(PortBusyError):
            connect(f"serial://{pty_path}")
    finally:
        first.close()
    SerialTransport(pty_path).close()  # free again once closed
    assert issubclass(PortBusyError, InitError)
    assert exitcodes.exit_code(PortBusyError("x")) == exitcodes.PORT


def test_lock_is_refused_to_another_process(pty_path: str) -> None:
    holder = SerialTransport(pty_path)
    try:
        code = (
            "from aacmm.errors import PortBusyError\n"
            "from aacmm.transport import SerialTransport\n"
            f"try:\n    SerialTransport({pty_path!r})\n"
            "except PortBusyError as e:\n    print('busy:', e)\n"
        )
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        assert out.stdout.startswith("busy: serial port"), out
    finally:
        holder.close()


def test_script_connecting_while_log_runs_fails_clearly(sim: SimProcess, tmp_path: Path) -> None:
    """The issue's repro: the script is refused; the logger loses nothing."""
    out = tmp_path / "run.csv"
    env = cli_env()
    proc = subprocess.Popen(
        [str(AACMM), "log", str(out), "--port", sim.url, "-r", "500", "-d", "3"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            if out.exists() and out.read_text().count("\n") > 20:
                break
            time.sleep(0.05)
        else:
            raise AssertionError("the logger wrote no rows")
        refused = 0
        for _ in range(5):  # a script trying again and again
            with pytest.raises(PortBusyError, match="busy"):
                connect(sim.url, timeout=0.5)
            refused += 1
        busy = subprocess.run(
            [str(AACMM), "info", "--port", sim.url], capture_output=True, text=True, env=env
        )
        assert busy.returncode == exitcodes.PORT, busy
        assert len(busy.stderr.strip().splitlines()) == 1 and "busy" in busy.stderr
        _, stderr = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 0, stderr
    assert refused == 5
    meta = json.loads(out.with_name(out.name + ".json").read_text())
    assert meta["status"] == "complete"
    assert meta["lost_samples"] == 0, meta["lost_detail"]
    rows = out.read_text().splitlines()[1:]
    seqs = [int(r.split(",")[0]) for r in rows]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # no gap, no duplicate
    with connect(sim.url) as c:  # free again
        assert c.info().protocol_version >= 1
