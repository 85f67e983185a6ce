"""The ``aacmm`` command over SocketCAN against ``aacmm-sim --can vcan0``.

Runs in the shared vcan session (``make test-vcan``: tests/vcan/run-in-vcan.sh,
one VM boot when the host kernel has no CAN); ``mk/host-cli.mk`` adds this
directory to ``VCAN_TESTS``. Outside the runner (no vcan0) the tests skip;
inside it a missing interface fails. Few tests: every ``aacmm`` start costs
seconds in the emulated VM.

- ``aacmm log --raw FILE`` in the three raw formats
  (.blf, .asc, .log): the CSV is a complete log, and python-can's readers
  open the raw file, whose sample frames decode with the packaged DBC to the
  rows of the CSV;
- ``aacmm log --reconnect`` across a simulator restart on the same bus;
- with a thermal block in force on a device with sensors, ``aacmm log``
  asks for the link temperatures over CAN (the samples then come as
  SAMPLE_EVT over ISO-TP, not sample frames: docs/protocol.md 4.1), so
  every row carries the device's readings and a valid point; without it
  (the tests above) the compact sample frames, no temperatures.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import can
import pytest
from aacmm.protocol.can import ID_ISOTP_REQUEST, ID_ISOTP_RESPONSE, ID_SAMPLE_HEADER, load_dbc
from aacmm.records.schema import LOG_COLUMNS as COLUMNS
from aacmm.simulation.process import SimProcess

AACMM = Path(sys.executable).with_name("aacmm")
NODE = 3
TIMEOUT = "3"  # seconds per request: the VM is slow (TCG)
pytestmark = pytest.mark.timeout(240)


@pytest.fixture(scope="module")
def iface() -> str:
    """vcan0 (or the runner's first interface); a failure under the runner, else a skip."""
    name = os.environ.get("AACMM_VCAN_IFACES", "vcan0").split()[0]
    try:
        up = int(Path(f"/sys/class/net/{name}/flags").read_text(), 16) & 0x1
    except (OSError, ValueError):
        up = 0
    if not up:
        msg = f"SocketCAN interface {name} is not up"
        if os.environ.get("AACMM_VCAN"):
            pytest.fail(msg)
        pytest.skip(f"{msg}; run through tests/vcan/run-in-vcan.sh (make test-vcan)")
    return name


def sim_args(iface: str) -> list[str]:
    return ["--can", iface, "--node", str(NODE), "--quiet", "--button-every", "0.5"]


@pytest.fixture(scope="module")
def sim(iface: str) -> Iterator[SimProcess]:
    with SimProcess(sim_args(iface)) as s:
        yield s


def aacmm(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}
    return subprocess.run(
        [str(AACMM), *args], capture_output=True, text=True, timeout=timeout, env=env
    )


def wait_until(pred: Callable[[], bool], timeout: float) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if pred():
            return
        time.sleep(0.1)
    raise AssertionError("condition not met in time")


def csv_rows(path: Path) -> list[list[str]]:
    rows = list(csv.reader(path.read_text().splitlines()))
    assert tuple(rows[0]) == COLUMNS
    assert all(len(r) == len(COLUMNS) for r in rows[1:])
    return rows[1:]


@pytest.mark.parametrize("suffix", [".blf", ".asc", ".log"])
def test_log_with_raw_frames(sim: SimProcess, tmp_path: Path, suffix: str) -> None:
    out, raw = tmp_path / "can.csv", tmp_path / f"can{suffix}"
    p = aacmm(
        "log", str(out), "--port", sim.url, "--timeout", TIMEOUT,
        "-r", "100", "-n", "150", "--raw", str(raw),
    )  # fmt: skip
    assert p.returncode == 0, p.stderr
    rows = csv_rows(out)
    assert len(rows) == 150
    meta = json.loads((tmp_path / "can.csv.json").read_text())
    assert meta["status"] == "complete" and meta["raw_can"] == raw.name
    assert meta["transport"].startswith("socketcan")
    assert meta["device"]["can_node_id"] == NODE and "CAN" in meta["device"]["build_flags_names"]

    frames = list(can.LogReader(str(raw)))  # the standard reader of the suffix
    ids = {f.arbitration_id for f in frames}
    assert ID_ISOTP_REQUEST + NODE in ids and ID_ISOTP_RESPONSE + NODE in ids
    assert ID_SAMPLE_HEADER + NODE in ids
    # the raw sample headers decode (DBC, node 0 ids + node) to the logged samples
    header = load_dbc().get_message_by_frame_id(ID_SAMPLE_HEADER)
    stamps: dict[int, int] = {}
    for f in frames:
        if f.arbitration_id == ID_SAMPLE_HEADER + NODE:
            d: Any = header.decode(bytes(f.data))
            stamps[int(d["Seq"])] = int(d["TimestampUs"])
    for r in rows:
        seq, t_us = int(r[0]), int(r[1])
        assert stamps[seq] == t_us & 0xFFFFFFFF, (seq, t_us)


def test_log_reconnects_on_the_bus(iface: str, sim: SimProcess, tmp_path: Path) -> None:
    sim.stop()  # the module's simulator makes way (the bus is shared)
    out = tmp_path / "again.csv"
    side = tmp_path / "again.csv.json"
    first = SimProcess(sim_args(iface))
    second: SimProcess | None = None
    env = {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}
    proc = subprocess.Popen(
        [str(AACMM), "log", str(out), "--port", first.url, "--timeout", TIMEOUT,
         "-r", "50", "--reconnect", "--stall", "3"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    try:
        wait_until(lambda: out.exists() and out.read_text().count("\n") > 30, 90)
        first.kill()
        wait_until(lambda: json.loads(side.read_text())["gaps"] != [], 90)  # stall seen
        n_before = out.read_text().count("\n")
        second = SimProcess(sim_args(iface))
        wait_until(lambda: json.loads(side.read_text())["reconnects"] == 1, 90)
        wait_until(lambda: out.read_text().count("\n") > n_before + 30, 90)
        proc.send_signal(signal.SIGINT)
        _, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
        first.stop()
        if second is not None:
            second.stop()
    assert proc.returncode == 0, stderr
    assert "reconnected" in stderr
    meta = json.loads(side.read_text())
    assert meta["reconnects"] == 1 and len(meta["gaps"]) == 1
    assert len(csv_rows(out)) == meta["samples"]


def test_log_thermal_set_carries_temperatures(iface: str, sim: SimProcess, tmp_path: Path) -> None:
    from aacmm.core import EncoderConfig, Params
    from aacmm.errmodel import ErrorModel
    from aacmm.protocol import ParamSet, encode_param_set
    from aacmm.protocol.errwire import with_error_model

    sim.stop()  # the module's simulator makes way (the bus is shared)
    em = ErrorModel(((),) * 6, (23e-6,) * 6, (20.0,) * 6)
    ps = with_error_model(ParamSet.from_core(Params(), EncoderConfig()), em)
    set_file = tmp_path / "thermal.set"
    set_file.write_bytes(encode_param_set(ps))
    out = tmp_path / "warm.csv"
    args = [*sim_args(iface), "--param-set", str(set_file), "--temperature", "27.5"]
    with SimProcess(args) as warm:
        p = aacmm(
            "log", str(out), "--port", warm.url, "--timeout", TIMEOUT, "-r", "20", "-n", "30",
        )  # fmt: skip
    assert p.returncode == 0, p.stderr
    rows = list(csv.DictReader(out.read_text().splitlines()))
    assert len(rows) == 30
    for r in rows:
        assert [r[f"temp{i}_c"] for i in range(1, 7)] == ["27.50"] * 6, r
        assert r["x_mm"] != "", r
