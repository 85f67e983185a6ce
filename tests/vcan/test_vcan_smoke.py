"""Smoke tests for the vcan test infrastructure, with the real libraries.

Run through tests/vcan/run-in-vcan.sh (make test-vcan): python-can's
socketcan interface, kernel and user-space ISO-TP (can-isotp) and cantools
decoding, all on the runner's vcan0.
"""

from __future__ import annotations

import os
import subprocess
import threading
import time
from pathlib import Path

import can
import cantools
import isotp
import isotp.tpsock
import pytest

RUNNER = Path(__file__).resolve().parent / "run-in-vcan.sh"


def _bus(iface: str, **kw: object) -> can.BusABC:
    return can.Bus(interface="socketcan", channel=iface, **kw)


class Collector(threading.Thread):
    """Reads a bus concurrently until `count` frames arrived or `timeout`."""

    def __init__(self, bus: can.BusABC, count: int, timeout: float = 60.0) -> None:
        super().__init__(daemon=True)
        self.bus, self.count, self.timeout = bus, count, timeout
        self.frames: list[can.Message] = []
        self.ready = threading.Event()

    def run(self) -> None:
        deadline = time.monotonic() + self.timeout
        self.ready.set()
        while len(self.frames) < self.count and time.monotonic() < deadline:
            msg = self.bus.recv(timeout=0.5)
            if msg is not None:
                self.frames.append(msg)


def test_socketcan_send_receive(vcan_iface: str) -> None:
    n = 400
    sent = []
    for i in range(n):
        ext = i % 3 == 0
        arb = (0x1ABC0000 + i) if ext else (0x100 + i % 0x600)
        data = bytes((i + k) & 0xFF for k in range(i % 9))
        sent.append(can.Message(arbitration_id=arb, is_extended_id=ext, data=data))
    with _bus(vcan_iface) as tx, _bus(vcan_iface) as rx:
        reader = Collector(rx, n)
        reader.start()
        reader.ready.wait()
        for i, msg in enumerate(sent):
            tx.send(msg, timeout=5)
            # Keep at most ~100 frames in flight: the receive queue holds only
            # a few hundred, and an emulated, loaded machine can stall the reader.
            deadline = time.monotonic() + 30
            while i - len(reader.frames) > 100 and time.monotonic() < deadline:
                time.sleep(0.002)
        reader.join()
    got = reader.frames
    assert len(got) == n, f"received {len(got)} of {n} frames"
    for s, r in zip(sent, got, strict=True):
        assert (r.arbitration_id, r.is_extended_id, bytes(r.data)) == (
            s.arbitration_id,
            s.is_extended_id,
            bytes(s.data),
        )
        assert r.channel == vcan_iface


def test_socketcan_filters(vcan_iface: str) -> None:
    filters = [{"can_id": 0x321, "can_mask": 0x7FF, "extended": False}]
    with _bus(vcan_iface) as tx, _bus(vcan_iface, can_filters=filters) as rx:
        for arb in (0x320, 0x321, 0x322, 0x321):
            tx.send(can.Message(arbitration_id=arb, is_extended_id=False, data=[arb & 0xFF]))
        got = []
        while (msg := rx.recv(timeout=0.5)) is not None:
            got.append(msg.arbitration_id)
    assert got == [0x321, 0x321]


def _payload(n: int) -> bytes:
    return bytes((i * 7 + 3) & 0xFF for i in range(n))


def test_isotp_kernel_sockets_multiframe(vcan_iface: str) -> None:
    """300 bytes between two kernel ISO-TP sockets (flow control by the kernel)."""
    isotp.tpsock.check_support()
    a = isotp.socket(timeout=20)
    b = isotp.socket(timeout=20)
    try:
        for s in (a, b):
            s.set_fc_opts(bs=8, stmin=0)
        a.bind(
            vcan_iface, isotp.Address(isotp.AddressingMode.Normal_11bits, rxid=0x7E8, txid=0x7E0)
        )
        b.bind(
            vcan_iface, isotp.Address(isotp.AddressingMode.Normal_11bits, rxid=0x7E0, txid=0x7E8)
        )
        req, resp = _payload(300), _payload(1000)[::-1]
        a.send(req)
        assert b.recv() == req
        b.send(resp)
        assert a.recv() == resp
    finally:
        a.close()
        b.close()


def test_isotp_python_stack_to_kernel_socket(vcan_iface: str) -> None:
    """User-space isotp stack on a python-can bus <-> kernel ISO-TP socket,
    29-bit ids, 300 bytes each way."""
    isotp.tpsock.check_support()
    addr_stack = isotp.Address(isotp.AddressingMode.Normal_29bits, rxid=0x18DAF110, txid=0x18DA10F1)
    addr_sock = isotp.Address(isotp.AddressingMode.Normal_29bits, rxid=0x18DA10F1, txid=0x18DAF110)
    sock = isotp.socket(timeout=20)
    sock.set_fc_opts(bs=0, stmin=0)
    sock.bind(vcan_iface, addr_sock)
    with _bus(vcan_iface) as bus:
        notifier = can.Notifier(bus, [], timeout=0.1)
        stack = isotp.NotifierBasedCanStack(
            bus,
            notifier,
            address=addr_stack,
            params={"blocking_send": True, "tx_data_min_length": 8, "stmin": 0, "blocksize": 0},
        )
        stack.start()
        try:
            req = _payload(300)
            stack.send(req, send_timeout=20)
            assert sock.recv() == req
            resp = bytes(reversed(req))
            sock.send(resp)
            got = stack.recv(block=True, timeout=20)
            assert got is not None and bytes(got) == resp
        finally:
            stack.stop()
            notifier.stop()
            sock.close()


DBC = """\
VERSION ""

NS_ :

BS_:

BU_: ARM HOST

BO_ 291 JointAngles: 8 ARM
 SG_ Joint1 : 0|16@1- (0.01,0) [-327.68|327.67] "deg" HOST
 SG_ Joint2 : 16|16@1- (0.01,0) [-327.68|327.67] "deg" HOST
 SG_ Temperature : 32|8@1+ (0.5,-40) [-40|87.5] "degC" HOST
 SG_ Counter : 40|4@1+ (1,0) [0|15] "" HOST
 SG_ Probe : 44|1@1+ (1,0) [0|1] "" HOST

VAL_ 291 Probe 0 "released" 1 "touched" ;
"""


def test_cantools_dbc_roundtrip_over_vcan(vcan_iface: str, tmp_path: Path) -> None:
    path = tmp_path / "arm.dbc"
    path.write_text(DBC)
    db = cantools.database.load_file(str(path))
    msg = db.get_message_by_name("JointAngles")
    values = {
        "Joint1": -12.34,
        "Joint2": 179.99,
        "Temperature": 25.5,
        "Counter": 9,
        "Probe": "touched",
    }
    data = msg.encode(values)
    assert len(data) == 8
    with _bus(vcan_iface) as tx, _bus(vcan_iface) as rx:
        tx.send(can.Message(arbitration_id=msg.frame_id, is_extended_id=False, data=data))
        frame = rx.recv(timeout=5)
    assert frame is not None and frame.arbitration_id == 291
    decoded = db.decode_message(frame.arbitration_id, frame.data)
    assert decoded["Joint1"] == pytest.approx(-12.34)
    assert decoded["Joint2"] == pytest.approx(179.99)
    assert decoded["Temperature"] == pytest.approx(25.5)
    assert decoded["Counter"] == 9
    assert str(decoded["Probe"]) == "touched"


@pytest.mark.skipif(
    os.environ.get("AACMM_VCAN") is None or os.geteuid() != 0,
    reason="needs root with vcan available (runs inside the runner)",
)
def test_runner_native_mode_passes_exit_status(vcan_iface: str) -> None:
    """Inside the runner vcan works, so a nested runner takes the native path."""
    env = dict(os.environ, AACMM_VCAN_MODE="native")
    r = subprocess.run(
        [str(RUNNER), "sh", "-c", "ip -br link show vcan0; exit 3"],
        env=env,
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert r.returncode == 3, r.stderr
    assert "vcan0" in r.stdout and "UP" in r.stdout
    assert "running natively" in r.stderr
