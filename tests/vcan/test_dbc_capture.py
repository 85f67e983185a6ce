"""A real CAN capture decodes with the node's DBC (issue 14 item 4).

The simulator on vcan0 with its default node, ``aacmm log --raw`` records
every frame of the session (candump -l format), and with the default node's
shipped DBC (what ``aacmm dbc`` writes: tests/host/test_dbc.py) both
``cantools decode`` (the command line tool) and ``cantools`` + python-can's
reader decode every frame of the capture: sample frames to the logged rows,
trigger frames, ISO-TP frames. Before, every frame
of a default session was an "Unknown frame id".
"""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import can
import cantools
import pytest
from aacmm.protocol.can import node_dbc_path
from aacmm.simulation.process import SimProcess
from aacmm.transport import DEFAULT_CAN_NODE

AACMM = Path(sys.executable).with_name("aacmm")
pytestmark = pytest.mark.timeout(240)


def aacmm(*args: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}
    return subprocess.run([str(AACMM), *args], capture_output=True, text=True, timeout=180, env=env)


def test_default_session_capture_decodes_with_the_node_dbc(vcan_iface: str, tmp_path: Path) -> None:
    out, raw = tmp_path / "s.csv", tmp_path / "s.log"
    dbc = node_dbc_path(DEFAULT_CAN_NODE)
    with SimProcess(["--can", vcan_iface, "--quiet", "--button-every", "0.3"]) as sim:
        assert sim.url.endswith(f"node={DEFAULT_CAN_NODE}"), sim.url  # the default node
        p = aacmm(
            "log", str(out), "--port", f"socketcan://{vcan_iface}", "--timeout", "3",
            "-r", "50", "-n", "60", "--raw", str(raw),
        )  # fmt: skip
    assert p.returncode == 0, p.stderr

    # 1. cantools' own command line tool on the capture file
    with open(raw, encoding="ascii") as f:
        dec = subprocess.run(
            [sys.executable, "-m", "cantools", "decode", "--single-line", dbc],
            stdin=f,
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert dec.returncode == 0, dec.stderr
    lines = dec.stdout.splitlines()
    frames = [ln for ln in raw.read_text().splitlines() if ln.strip()]
    assert len(lines) == len(frames) > 6 * 60
    assert not [ln for ln in lines if "Unknown frame id" in ln]
    assert sum("AACMM_SampleHeader(" in ln for ln in lines) >= 60
    assert any("AACMM_IsoTpRequest(" in ln for ln in lines)

    # 2. cantools' database + python-can's reader: the sample frames are the logged rows
    db = cantools.database.load_file(dbc)
    assert isinstance(db, cantools.database.can.Database)
    samples: dict[int, dict[str, Any]] = {}
    current: dict[str, Any] = {}
    for msg in can.LogReader(str(raw)):
        m = db.get_message_by_frame_id(msg.arbitration_id)  # KeyError: unknown id
        sig: Any = m.decode(bytes(msg.data))
        if m.name == "AACMM_SampleHeader":
            current = dict(sig)
        elif m.name.startswith(("AACMM_Counts", "AACMM_Point")) and current:
            current.update(sig)
            if m.name == "AACMM_PointZ":
                samples[int(current["Seq"])] = current
                current = {}
    rows = list(csv.DictReader(out.read_text().splitlines()))
    assert len(rows) == 60
    for r in rows:
        s = samples[int(r["seq"])]
        assert s["TimestampUs"] == int(r["device_time_us"]) & 0xFFFFFFFF
        assert [s[f"Count{i}"] for i in range(1, 7)] == [int(r[f"count{i}"]) for i in range(1, 7)]
        for axis in "xyz":
            assert abs(s[axis.upper()] - float(r[f"{axis}_mm"])) < 5e-5
        assert s["Status"] == int(r["flags"]) & 0xFFFF
