"""The trigger-sample rule over CAN (issue 14 item 5), in the shared vcan session.

``aacmm-sim --can`` driven through its control channel: the device's trigger
samples travel as sample frames flagged TRIGGER_EVENT (docs/protocol.md 2.6)
and must not enter the stream: a 100 Hz stream stays 100 Hz with contiguous
numbers however often the buttons are pressed, each trigger's seq names the
first stream sample after its edge, and the undo button reports index 1.
``aacmm log`` over CAN: the rate it reports is the stream's, and every trigger
row joins a sample row on ``seq``. Outside the runner (no vcan0) the tests
skip; inside it a missing interface fails.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from aacmm.client import connect
from aacmm.protocol import Button, Sample, SampleStatus
from aacmm.simulation.control import ControlChannel
from aacmm.simulation.process import SimProcess
from simctl import check_stream

NODE = 6
RATE_HZ = 100
AACMM = Path(sys.executable).with_name("aacmm")
pytestmark = pytest.mark.timeout(240)


@pytest.fixture
def controlled(vcan_iface: str) -> Iterator[tuple[SimProcess, ControlChannel]]:
    chan, fd = ControlChannel.pair()
    try:
        sim = SimProcess(
            ["--can", vcan_iface, "--node", str(NODE), "--quiet", "--control", str(fd)],
            pass_fds=[fd],
        )
    finally:
        chan.child_started()
    try:
        chan.hello()
        chan.set_counts((1 << 30, 3 << 29, 5, 1 << 31, 123456789, 4000000000))
        chan.sync()
        yield sim, chan
    finally:
        chan.close()
        sim.stop()


def test_can_stream_keeps_its_rate_and_numbers(
    controlled: tuple[SimProcess, ControlChannel],
) -> None:
    sim, chan = controlled
    got: list[Sample] = []
    with connect(sim.url, timeout=3.0) as c:
        with c.stream(RATE_HZ, timeout=10.0) as samples:
            assert chan.wait_stream(True, timeout=10.0)
            got += [next(samples) for _ in range(20)]
            for button in (Button.CAPTURE, Button.UNDO, Button.CAPTURE, Button.CAPTURE):
                chan.press(button)
                got += [next(samples) for _ in range(3)]
                chan.release(button)
                got += [next(samples) for _ in range(20)]
        deadline = time.monotonic() + 5.0
        triggers = c.drain_triggers()
        while len(triggers) < 8 and time.monotonic() < deadline:
            time.sleep(0.1)
            triggers += c.drain_triggers()
    seqs = [s.seq for s in got]
    check_stream(seqs, [s.status for s in got], [s.timestamp_us for s in got], RATE_HZ)
    assert len(triggers) == 8
    assert [t.button for t in triggers if t.pressed] == [0, 1, 0, 0]
    by_seq = {s.seq: s for s in got}
    for t in triggers:
        assert t.sample.status & SampleStatus.TRIGGER_EVENT
        after = by_seq.get(t.sample.seq)  # the first stream sample after the edge
        assert after is None or after.timestamp_us >= t.sample.timestamp_us
        before = by_seq.get(t.sample.seq - 1)
        assert before is None or before.timestamp_us <= t.sample.timestamp_us


def test_log_over_can_joins_triggers_to_samples(vcan_iface: str, tmp_path: Path) -> None:
    out = tmp_path / "run.csv"
    args = ["--can", vcan_iface, "--node", str(NODE), "--quiet", "--button-every", "0.25"]
    with SimProcess(args) as sim:
        env = {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}
        r = subprocess.run(
            [str(AACMM), "log", str(out), "--port", sim.url, "--timeout", "3",
             "-r", str(RATE_HZ), "-n", "300", "-q"],
            capture_output=True, text=True, timeout=180, env=env,
        )  # fmt: skip
        assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(out.open()))
    trig = list(csv.DictReader((tmp_path / "run.triggers.csv").open()))
    assert len(rows) == 300 and len(trig) >= 4
    seqs = [int(r["seq"]) for r in rows]
    t_us = [int(r["device_time_us"]) for r in rows]
    check_stream(seqs, [int(r["flags"]) for r in rows], t_us, RATE_HZ)
    meta = json.loads((tmp_path / "run.csv.json").read_text())
    assert meta["samples"] == 300
    by_seq = {int(r["seq"]): int(r["device_time_us"]) for r in rows}
    inside = [t for t in trig if int(t["seq"]) <= seqs[-1]]  # edges after the last row: none
    assert len(inside) >= 4
    for t in trig:
        assert int(t["flags"]) & SampleStatus.TRIGGER_EVENT
    for t in inside:
        seq = int(t["seq"])
        if seq in by_seq:  # (not if the device dropped that sample, flagged OVERRUN)
            assert by_seq[seq] >= int(t["device_time_us"])
    assert sum(int(t["seq"]) in by_seq for t in inside) >= len(inside) - 1
