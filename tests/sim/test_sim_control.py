"""The simulator's control channel, the second button and the trigger-sample
rule over the serial link, and replay of aacmm's own logs (issue 14 items 5
and 6), against the real ``aacmm-sim`` binary and the host client.

- counts and buttons set on the channel are what the device reads and reports;
  a button edge carries the counts set before it (barrier semantics);
- the channel reports stream start, restart and stop; refuses bad lines with
  an ``error`` line and goes on; its end of file ends the simulator (exit 0);
- a trigger's sample is read at the edge, flagged TRIGGER_EVENT, numbered with
  the stream's next seq, and takes no stream number (docs/protocol.md 2.6);
  button 1 (undo) reports index 1;
- ``--motion replay:`` takes a CSV written by ``aacmm log`` (header row) and
  replays its counts in order, skipping rows flagged ENCODER_FAULT; the log
  of a 5- and a 7-axis model (``aacmm sim --model``), replayed on the same
  model, streams the same counts on every joint (issue 26); a log of another
  joint count than the arm's is refused (one line, exit status 2);
- ``temps`` on the channel is what the device's link temperature sensors read
  (issue 27): the sample carries them, a set with the thermal block computes
  at them, a sensor that does not answer (``-``) flags TEMP_FAULT and leaves
  no point, DIAG counts it, a malformed line is refused.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from aacmm.client import connect
from aacmm.protocol import (
    Button,
    ComputeResult,
    MeasureRequest,
    MsgType,
    Sample,
    SampleStatus,
)
from aacmm.protocol.constants import TEMP_NONE
from aacmm.simulation.control import ControlChannel, ControlError
from aacmm.simulation.process import SimProcess, SimulatorUsageError
from simctl import ControlledSim, check_stream

pytestmark = pytest.mark.timeout(120)
AACMM = Path(sys.executable).with_name("aacmm")
COUNTS = (1 << 30, 3 << 29, 5, 1 << 31, 123456789, 4000000000)


def test_temps_reach_the_device(controlled: ControlledSim) -> None:
    chan = controlled.chan
    with connect(controlled.url, timeout=2.0) as c:

        def measure_temps() -> Sample:
            s = c.request(MsgType.MEASURE_REQ, MeasureRequest(temperatures=True)).payload
            assert isinstance(s, Sample)
            return s

        plain = c.get_params()
        cte = 2300  # 23e-6 / K on every link, tref 20 degC
        c.set_params(dataclasses.replace(plain, cte=(cte,) * plain.joints, ref_temp=2000))
        chan.set_counts(COUNTS)
        chan.send_raw("temps 45")
        chan.sync()
        s = measure_temps()
        assert s.temp == (4500,) * 6
        assert s.status & SampleStatus.POINT_VALID and not s.status & SampleStatus.TEMP_FAULT
        # one CTE and one temperature on every link scale every length, and so
        # the point, by 1 + cte dT (COMPUTE without temperatures: the reference)
        ref = c.compute(COUNTS)
        assert isinstance(ref, ComputeResult) and not ref.temperatures
        f = 1.0 + cte * 1e-8 * 25.0
        assert all(abs(a - f * b) < 2e-3 for a, b in zip(s.point_mm, ref.point_mm, strict=True))
        assert math.dist(s.point_mm, ref.point_mm) > 0.1
        chan.send_raw("temps 20 20 - 20.25 20 -3.5")
        chan.sync()
        s = measure_temps()
        assert s.temp == (2000, 2000, TEMP_NONE, 2025, 2000, -350)
        assert s.status & SampleStatus.TEMP_FAULT and not s.status & SampleStatus.POINT_VALID
        diag = c.diagnostics()
        assert diag is not None and diag.temp_faults == 1
        chan.send_raw("temps warm")
        with pytest.raises(ControlError, match="temps"):
            chan.sync()
        # without the thermal block a missing sensor only flags the sample
        c.set_params(plain)
        s = measure_temps()
        assert s.status & SampleStatus.TEMP_FAULT and s.status & SampleStatus.POINT_VALID


def test_counts_and_buttons_reach_the_device(controlled: ControlledSim) -> None:
    chan = controlled.chan
    with connect(controlled.url, timeout=2.0) as c:
        chan.set_counts(COUNTS)
        chan.sync()
        assert c.measure().counts == COUNTS
        # a press carries the counts set before it, even when new counts follow at once
        chan.set_counts((1, 2, 3, 4, 5, 6))
        chan.send_raw("buttons 1")  # a barrier, without waiting
        chan.set_counts((7, 8, 9, 10, 11, 12))
        chan.send_raw("buttons 2")
        chan.sync()
        down = c.wait_trigger(timeout=2.0)
        assert (down.button, down.pressed) == (Button.CAPTURE, True)
        assert down.sample.counts == (1, 2, 3, 4, 5, 6)
        assert down.sample.status & SampleStatus.TRIGGER_EVENT
        assert down.sample.status & SampleStatus.TRIGGER_DOWN
        # mask 1 -> 2: button 0 released and button 1 pressed, in button order
        up = c.wait_trigger(timeout=2.0)
        undo = c.wait_trigger(timeout=2.0)
        assert (up.button, up.pressed) == (Button.CAPTURE, False)
        assert (undo.button, undo.pressed) == (Button.UNDO, True)
        assert up.sample.counts == undo.sample.counts == (7, 8, 9, 10, 11, 12)
        assert not undo.sample.status & SampleStatus.TRIGGER_DOWN  # only the capture button
        chan.release(Button.UNDO)
        assert c.wait_trigger(timeout=2.0).pressed is False
        assert c.drain_triggers() == []


def test_stream_events_and_trigger_rule(controlled: ControlledSim) -> None:
    chan = controlled.chan
    chan.set_counts(COUNTS)
    assert chan.streams()["serial"].active is False
    with connect(controlled.url, timeout=2.0) as c:
        with c.stream(200) as samples:
            assert chan.wait_stream(True, timeout=5.0)
            assert chan.streams()["serial"].rate_hz == 200
            got = [next(samples) for _ in range(20)]
            for _ in range(3):
                chan.press(Button.CAPTURE)
                chan.release(Button.CAPTURE)
                got += [next(samples) for _ in range(10)]
            triggers = c.drain_triggers()
            diag = f"stream {samples.stats}, client {c.stats}"
        assert chan.wait_stream(False, timeout=5.0)
        starts = chan.starts()
        with c.stream(50) as samples:  # a restart is reported again
            next(samples)
            assert chan.wait_stream(after_starts=starts, timeout=5.0)
    seqs = [s.seq for s in got]
    assert seqs[0] == 0, diag
    check_stream(seqs, [s.status for s in got], [s.timestamp_us for s in got], 200.0)
    assert len(triggers) == 6
    by_seq = {s.seq: s for s in got}
    for t in triggers:
        s = t.sample
        assert s.status & SampleStatus.TRIGGER_EVENT
        # between stream samples seq - 1 and seq (docs/protocol.md 2.7)
        if s.seq in by_seq:
            assert by_seq[s.seq].timestamp_us >= s.timestamp_us
        if s.seq - 1 in by_seq:
            assert by_seq[s.seq - 1].timestamp_us <= s.timestamp_us
    assert sum(t.sample.seq in by_seq for t in triggers) >= 5
    assert {t.pressed for t in triggers} == {True, False}


def test_bad_lines_are_refused_and_the_channel_goes_on(controlled: ControlledSim) -> None:
    chan = controlled.chan
    for line in (
        "counts 1 2 3",
        f"counts 1 2 3 4 5 {1 << 32}",
        "counts 1 2 3 4 5 x",
        "buttons 4",
        "fly away",
        "sync",
        "x" * 300,
    ):
        chan.send_raw(line)
        with pytest.raises(ControlError, match="refused"):
            chan.sync()
    chan.set_counts(COUNTS)
    chan.sync()
    with connect(controlled.url, timeout=2.0) as c:
        assert c.measure().counts == COUNTS


def test_control_option_errors() -> None:
    a, b = socket.socketpair()
    try:
        with pytest.raises(SimulatorUsageError):
            SimProcess(["--serial", "pty", "--control", str(b.fileno()), "--motion", "static"],
                       pass_fds=[b.fileno()])  # fmt: skip
        with pytest.raises(SimulatorUsageError):
            SimProcess(["--serial", "pty", "--control", "77"])  # not open
        with pytest.raises(SimulatorUsageError):
            SimProcess(["--serial", "pty", "--control", "x"])
    finally:
        a.close()
        b.close()


def _aacmm(*args: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}
    return subprocess.run([str(AACMM), *args], capture_output=True, text=True, timeout=60, env=env)


def test_replay_reads_an_aacmm_log(tmp_path: Path) -> None:
    log = tmp_path / "run.csv"
    with SimProcess(["--serial", "pty", "--quiet", "--motion", "walk", "--seed", "3"]) as sim:
        r = _aacmm("log", str(log), "--port", sim.url, "-n", "30", "-r", "200", "-q")
        assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(log.open()))
    assert len(rows) == 30
    # a row of a faulty reading is skipped on replay
    text = log.read_text().splitlines()
    flags = text[0].split(",").index("flags")
    fault = text[1].split(",")
    fault[flags] = str(int(fault[flags]) | int(SampleStatus.ENCODER_FAULT))
    text.insert(2, ",".join(fault))
    log.write_text("\n".join(text) + "\n")
    want = [tuple(int(r[f"count{i}"]) for i in range(1, 7)) for r in rows]
    with SimProcess(["--serial", "pty", "--quiet", "--motion", f"replay:{log}"]) as sim:
        with connect(sim.url, timeout=2.0) as c:
            got = [c.measure().counts for _ in range(len(want) + 2)]
    assert got == want + want[:2]  # in order, looping at the end


def _sim_url(proc: subprocess.Popen[str]) -> str:
    assert proc.stdout is not None and proc.stderr is not None
    url = proc.stdout.readline().strip()
    if not url.startswith("serial://"):
        proc.kill()
        pytest.fail(f"aacmm sim did not start: {proc.stderr.read()}")
    return url


def _log_of(args: list[str], log: Path, n: int) -> list[tuple[int, ...]]:
    """``aacmm log`` of n samples at 200 Hz from ``aacmm sim ARGS``: the rows' counts."""
    env = {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}
    proc = subprocess.Popen(
        [str(AACMM), "sim", "--quiet", *args],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    try:
        r = _aacmm("log", str(log), "--port", _sim_url(proc), "-n", str(n), "-r", "200", "-q")
        assert r.returncode == 0, r.stderr
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    rows = list(csv.DictReader(log.open()))
    seqs = [int(r["seq"]) for r in rows]
    assert seqs == list(range(seqs[0], seqs[0] + n)), "a gap in the stream"
    k = sum(1 for c in rows[0] if c.startswith("count"))
    return [tuple(int(r[f"count{i}"]) for i in range(1, k + 1)) for r in rows]


@pytest.mark.parametrize(("name", "joints"), [("microscribe5", 5), ("commercial7", 7)])
def test_replay_of_a_model_log_streams_its_counts(name: str, joints: int, tmp_path: Path) -> None:
    """The log of an N-joint arm replayed on the same model: every joint's counts again."""
    log = tmp_path / "run.csv"
    want = _log_of(["--model", name, "--motion", "walk", "--seed", "5"], log, 40)
    assert {len(c) for c in want} == {joints}
    # the arm moves on every joint, the last too (7: not the old 0.7 rad hold)
    assert all(len({c[j] for c in want}) > 1 for j in range(joints))
    got = _log_of(["--model", name, "--motion", f"replay:{log}"], tmp_path / "again.csv", 100)
    # a stream starts somewhere in the loop: the counts are the log's, in its order, looping
    start = want.index(got[0])
    assert got == [want[(start + i) % len(want)] for i in range(len(got))]
    # during the replay a set of another joint count is refused (issue 26 left-out): one
    # line, exit 1, the replay's arm still in force; one of its own count is taken
    other = tmp_path / "other.toml"
    r = _aacmm("model", "example", "desk4" if joints == 5 else "microscribe5", "-o", str(other))
    assert r.returncode == 0, r.stderr
    own = tmp_path / "own.toml"
    assert _aacmm("model", "example", name, "-o", str(own)).returncode == 0
    env = {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}
    proc = subprocess.Popen(
        [str(AACMM), "sim", "--quiet", "--model", name, "--motion", f"replay:{log}"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    try:
        url = _sim_url(proc)
        r = _aacmm("params", "set", str(other), "--port", url)
        assert r.returncode == 1, r.stderr
        assert r.stderr.count("\n") == 1 and r.stderr.endswith(
            f"the device cannot serve an arm of {4 if joints == 5 else 5} joints (its encoders, "
            f"or a simulator's replay file, give another joint count); the set in force, "
            f"{joints} joints, is unchanged\n"
        ), r.stderr
        with connect(url) as c:
            assert c.info().joints == joints
        r = _aacmm("params", "set", str(own), "--port", url)
        assert r.returncode == 0, r.stderr
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=30)
    # the same log on an arm of another joint count: refused, one line (the
    # 7-axis log's counts are past microscribe5's 16384 per revolution: that
    # is said first)
    if joints == 5:
        r = _aacmm("sim", "--quiet", "--model", "commercial7", "--motion", f"replay:{log}")
        assert r.returncode == 2, r.stderr
        assert f"aacmm-sim: replay file {log} has 5 joints, the arm 7\n" in r.stderr
    r = _aacmm("sim", "--quiet", "--motion", f"replay:{log}")  # the paper's arm: 6 joints
    assert r.returncode == 2, r.stderr
    assert f"aacmm-sim: replay file {log} has {joints} joints, the arm 6\n" in r.stderr


def test_replay_csv_errors(tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    for text, msg in (
        ("seq,count1,count2\n1,2,3\n", "no column count3"),
        ("count1,count2,count3,count4,count6\n1,2,3,4,6\n", "no column count5"),
        ("count1,count2,count3,count4,count5,count6,count7,count8\n1,2,3,4,5,6,7,8\n", "count8"),
        ("1 2 3 4 5\n1 2 3 4\n", ":2: 4 counts, expected 5 as on line 1"),
        ("1 2 3 4 5\n", f"replay file {bad} has 5 joints, the arm 6"),
        ("count1,count2,count3,count4,count5,count6,count7\n1,2,3,4,5,6,7\n", "has 7 joints"),
        ("count1,count2,count3,count4,count5,count6\n1,2,3,4,5\n", ":2:"),
        ("count1,count2,count3,count4,count5,count6\n1,2,3,4,5,-6\n", "count6"),
    ):
        bad.write_text(text)
        r = subprocess.run(
            [os.environ["AACMM_SIM"], "--serial", "pty", "--motion", f"replay:{bad}"],
            capture_output=True, text=True, timeout=20,
        )  # fmt: skip
        assert r.returncode == 2 and msg in r.stderr, r.stderr
        assert r.stderr.count("\n") == 1


def test_simulator_ends_when_control_peer_dies_quickly() -> None:
    """The operator killed: its end of the channel closes, the simulator follows."""
    chan, fd = ControlChannel.pair()
    sim = SimProcess(["--serial", "pty", "--quiet", "--control", str(fd)], pass_fds=[fd])
    chan.child_started()
    t0 = time.monotonic()
    chan.close()
    assert sim.proc.wait(timeout=10) == 0
    assert time.monotonic() - t0 < 5
    sim.stop()


def test_log_over_serial_joins_triggers_to_samples(tmp_path: Path) -> None:
    """docs/protocol.md 2.7 on the serial link, through `aacmm log`: the stream keeps
    its rate and numbers, and every trigger row joins the first sample row after it."""
    out = tmp_path / "run.csv"
    args = ["--serial", "pty", "--quiet", "--button-every", "0.2"]
    with SimProcess(args) as sim:
        r = _aacmm("log", str(out), "--port", sim.url, "-r", "100", "-n", "200", "-q")
        assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(out.open()))
    trig = list(csv.DictReader((tmp_path / "run.triggers.csv").open()))
    seqs = [int(r["seq"]) for r in rows]
    t_us = [int(r["device_time_us"]) for r in rows]
    check_stream(seqs, [int(r["flags"]) for r in rows], t_us, 100.0)
    assert len(trig) >= 10
    by_seq = {int(r["seq"]): int(r["device_time_us"]) for r in rows}
    inside = [t for t in trig if int(t["seq"]) <= seqs[-1]]  # edges after the last row: none
    assert len(inside) >= 8
    for t in trig:
        assert int(t["flags"]) & SampleStatus.TRIGGER_EVENT
    for t in inside:
        seq, t_trig = int(t["seq"]), int(t["device_time_us"])
        if seq in by_seq:
            assert by_seq[seq] >= t_trig  # the first stream sample after the edge
        if seq - 1 in by_seq:
            assert by_seq[seq - 1] <= t_trig
    assert sum(int(t["seq"]) in by_seq for t in inside) >= len(inside) - 1
