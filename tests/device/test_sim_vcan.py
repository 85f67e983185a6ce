"""aacmm-sim on a virtual CAN bus: the device side of the CAN link, end to end.

Runs only under tests/vcan/run-in-vcan.sh (mk/device.mk adds this file to
VCAN_TESTS; it skips elsewhere). Standard library sockets only, with a tiny
ISO-TP client of its own, so it checks the simulator independently of the
host package: a PING and an INFO (multi-frame response, flow control from
us) over ISO-TP, a periodic-frame stream with gap-free sequence numbers, the
probe-button trigger frame after its sample's frames (TRIGGER_EVENT, not a
stream sample), exit codes.
The full client tests live with the host package.
"""

from __future__ import annotations

import os
import re
import select
import signal
import socket
import struct
import subprocess
import time
from collections.abc import Iterator

import pytest

SIM = os.path.join(os.path.dirname(__file__), "..", "..", "build", "sim", "aacmm-sim")
NODE = 5
REQ_ID = 0x600 + NODE
RSP_ID = 0x680 + NODE
CAN_FRAME = struct.Struct("=IB3x8s")
# The version byte from the one place it is defined, the firmware's header.
_PROTO_H = os.path.join(os.path.dirname(__file__), "..", "..", "firmware", "include", "aacmm")
with open(os.path.join(_PROTO_H, "proto.h"), encoding="utf-8") as _f:
    _m = re.search(r"#define AACMM_PROTO_VERSION (\d+)u", _f.read())
assert _m is not None, "proto.h: AACMM_PROTO_VERSION not found"
V = int(_m.group(1))

pytestmark = pytest.mark.skipif(not hasattr(socket, "AF_CAN"), reason="no AF_CAN in Python")


def iface() -> str:
    names = os.environ.get("AACMM_VCAN_IFACES", "").split()
    if not names:
        if os.environ.get("AACMM_VCAN"):
            pytest.fail("under the vcan runner but AACMM_VCAN_IFACES is empty")
        pytest.skip("not under tests/vcan/run-in-vcan.sh")
    return names[0]


class Bus:
    def __init__(self, name: str) -> None:
        self.s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
        self.s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.s.bind((name,))
        self.s.settimeout(0.0)

    def send(self, can_id: int, data: bytes) -> None:
        self.s.send(CAN_FRAME.pack(can_id, len(data), data.ljust(8, b"\xcc")))

    def recv(self, timeout: float) -> tuple[int, bytes] | None:
        r, _, _ = select.select([self.s], [], [], timeout)
        if not r:
            return None
        can_id, dlc, data = CAN_FRAME.unpack(self.s.recv(16))
        return can_id & 0x7FF, data[:dlc]

    def close(self) -> None:
        self.s.close()


def isotp_request(
    bus: Bus, body: bytes, frames: list[tuple[int, bytes]], timeout: float = 10.0
) -> bytes:
    """Send a single-frame request, return the response body (SF or FF+CFs)."""
    assert len(body) <= 7
    bus.send(REQ_ID, bytes([len(body)]) + body)
    deadline = time.monotonic() + timeout
    want = None
    got = b""
    while time.monotonic() < deadline:
        f = bus.recv(0.5)
        if f is None:
            continue
        can_id, data = f
        if can_id != RSP_ID:
            frames.append(f)
            continue
        pci = data[0] >> 4
        if pci == 0:
            return data[1 : 1 + (data[0] & 0x0F)]
        if pci == 1:
            want = ((data[0] & 0x0F) << 8) | data[1]
            got = data[2:8]
            bus.send(REQ_ID, b"\x30\x00\x00")  # clear to send, no block limit, no STmin
        elif pci == 2 and want is not None:
            got += data[1:8]
            if len(got) >= want:
                return got[:want]
    raise AssertionError("no ISO-TP response")


@pytest.fixture
def sim() -> Iterator[subprocess.Popen[str]]:
    name = iface()
    p = subprocess.Popen(
        [
            SIM,
            "--serial",
            "pty",
            "--can",
            name,
            "--node",
            str(NODE),
            "--motion",
            "static",
            "--button-every",
            "0.5",
            "--quiet",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert p.stdout is not None
    # Both links at once: the lines come in the documented order.
    assert p.stdout.readline().startswith("aacmm-sim: serial /dev/")
    assert p.stdout.readline().strip() == f"aacmm-sim: can {name} node {NODE}"
    assert p.stdout.readline().strip() == "aacmm-sim: ready"
    yield p
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)
        assert p.wait(timeout=20) == 0


def test_requests_stream_and_trigger(sim: subprocess.Popen[str]) -> None:
    bus = Bus(iface())
    other: list[tuple[int, bytes]] = []
    try:
        rsp = isotp_request(bus, bytes([V, 0x01, 7]) + struct.pack("<I", 0xA5A5F00D), other)
        assert rsp == bytes([V, 0x81, 7]) + struct.pack("<I", 0xA5A5F00D)
        info = isotp_request(bus, bytes([V, 0x02, 8]), other)
        assert info[:3] == bytes([V, 0x82, 8]) and len(info) == 3 + 25
        assert info[3 + 22] == NODE
        flags = struct.unpack_from("<I", info, 3 + 6)[0]
        assert flags & 0x18 == 0x18  # serial and CAN built in
        rsp = isotp_request(bus, bytes([V, 0x09, 9]) + struct.pack("<HB", 200, 0), other)
        assert rsp == bytes([V, 0x89, 9]) + struct.pack("<HB", 200, 0)
        frames = list(other)
        t_end = time.monotonic() + 3.0
        while time.monotonic() < t_end:
            f = bus.recv(0.2)
            if f is not None:
                frames.append(f)
        isotp_request(bus, bytes([V, 0x0A, 10]), frames)
    finally:
        bus.close()
    seqs = []
    triggers = []
    for i, (can_id, data) in enumerate(frames):
        if can_id == 0x100 + NODE:
            ids = [frames[i + k][0] for k in range(6) if i + k < len(frames)]
            assert ids == [
                0x100 + NODE,
                0x110 + NODE,
                0x120 + NODE,
                0x130 + NODE,
                0x140 + NODE,
                0x150 + NODE,
            ]
            status = struct.unpack_from("<H", frames[i + 5][1], 4)[0]
            if status & 0x80:  # TRIGGER_EVENT: a trigger's sample, not a stream sample
                assert i + 6 >= len(frames) or frames[i + 6][0] == 0x160 + NODE
            else:
                seqs.append(struct.unpack_from("<I", data)[0])
        elif can_id == 0x160 + NODE:
            seq, button, pressed = struct.unpack_from("<IBB", data)
            assert frames[i - 6][0] == 0x100 + NODE
            assert struct.unpack_from("<I", frames[i - 6][1])[0] == seq
            triggers.append((seq, button, pressed))
    assert len(seqs) > 300
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "lost or repeated sample"
    assert len(triggers) >= 4 and {t[2] for t in triggers} == {0, 1}
    # docs/protocol.md 2.6: a trigger names the stream sample that follows it
    assert all(t[0] in seqs for t in triggers[:-1])


def test_exit_codes() -> None:
    r = subprocess.run([SIM, "--can", "vcan99"], capture_output=True, text=True, timeout=20)
    assert r.returncode == 3 and "vcan99" in r.stderr
    r = subprocess.run([SIM, "--can", "lo"], capture_output=True, text=True, timeout=20)
    assert r.returncode == 3 and "not a CAN interface" in r.stderr
