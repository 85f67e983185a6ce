"""The protocol on a real SocketCAN interface (vcan0), with the production helpers.

Runs in the vcan session (``make test-vcan``, via ``VCAN_TESTS`` in
mk/protocol.mk): python-can's socketcan bus, ``make_isotp_stack`` (the
threaded can-isotp stack the host client uses) talking to the firmware's C
ISO-TP endpoint (through the test shim) in a device thread, and DBC sample
frames produced by the C encoder decoded with cantools.
"""

from __future__ import annotations

import ctypes
import os
import threading
import time
from pathlib import Path

import can
import pytest
from aacmm import protocol
from aacmm.protocol import Message, MsgType, Ping, Sample
from aacmm.protocol import can as pcan
from test_protocol_interop import LIB

NODE = 6


def _iface() -> str:
    name = os.environ.get("AACMM_VCAN_IFACES", "vcan0").split()[0]
    try:
        up = bool(int(Path(f"/sys/class/net/{name}/flags").read_text(), 16) & 1)
    except (OSError, ValueError):
        up = False
    if not up:
        if os.environ.get("AACMM_VCAN"):
            pytest.fail(f"SocketCAN interface {name} is not up")
        pytest.skip(f"{name} is not up; run through tests/vcan/run-in-vcan.sh (make test-vcan)")
    return name


class Device(threading.Thread):
    """A minimal device: C ISO-TP endpoint on the bus, answers PING_REQ with PING_RSP."""

    def __init__(self, iface: str) -> None:
        super().__init__(daemon=True)
        self.bus = can.Bus(interface="socketcan", channel=iface)
        self.stop = threading.Event()
        self.answered = 0
        assert (
            LIB.shim_isotp_init(
                pcan.ID_ISOTP_RESPONSE + NODE, pcan.ID_ISOTP_REQUEST + NODE, 8, 0, 4095
            )
            == 0
        )

    def run(self) -> None:
        fid, dlc, buf = ctypes.c_uint32(), ctypes.c_uint8(), (ctypes.c_uint8 * 8)()
        out = (ctypes.c_uint8 * 4095)()
        n = ctypes.c_size_t()
        while not self.stop.is_set():
            now = int(time.monotonic() * 1000) & 0xFFFFFFFF
            msg = self.bus.recv(timeout=0.001)
            if msg is not None and not msg.is_extended_id:
                data = bytes(msg.data)
                LIB.shim_isotp_on_frame(msg.arbitration_id, len(data), data.ljust(8, b"\0"), now)
            if LIB.shim_isotp_receive(out, len(out), ctypes.byref(n)):
                req = protocol.decode_message(bytes(out[: n.value]))
                if isinstance(req.payload, Ping):
                    rsp = protocol.encode_message(Message(MsgType.PING_RSP, req.seq, req.payload))
                    assert LIB.shim_isotp_send(rsp, len(rsp), now) == 0
                    self.answered += 1
            while LIB.shim_isotp_poll(now, ctypes.byref(fid), ctypes.byref(dlc), buf):
                self.bus.send(
                    can.Message(
                        arbitration_id=fid.value, is_extended_id=False, data=bytes(buf[: dlc.value])
                    ),
                    timeout=1,
                )
        self.bus.shutdown()


def test_ping_over_isotp_on_socketcan() -> None:
    iface = _iface()
    dev = Device(iface)
    dev.start()
    bus = can.Bus(interface="socketcan", channel=iface)
    stack = pcan.make_isotp_stack(bus, NODE)
    stack.start()
    try:
        for seq, token in enumerate((1, 0xDEADBEEF, 0x12345678)):
            stack.send(protocol.encode_message(Message(MsgType.PING_REQ, seq, Ping(token))))
            reply = stack.recv(block=True, timeout=10)
            assert reply is not None
            assert protocol.decode_message(reply) == Message(MsgType.PING_RSP, seq, Ping(token))
        # a long body too: the parameter-set response size, both ways through FC/CF
        long_body = protocol.encode_message(
            Message(MsgType.SAMPLE_EVT, 9, Sample(1, 2, (3,) * 6, (4, 5, 6), 7, ((0.5,) * 25,) * 3))
        )
        stack.send(long_body)  # the device ignores it (not a ping) but must reassemble it
        stack.send(protocol.encode_message(Message(MsgType.PING_REQ, 77, Ping(77))))
        reply = stack.recv(block=True, timeout=10)
        assert reply is not None and protocol.decode_message(reply).seq == 77
    finally:
        stack.stop()
        bus.shutdown()
        dev.stop.set()
        dev.join(timeout=5)
    assert dev.answered == 4


def test_c_sample_frames_decode_with_the_dbc_on_socketcan() -> None:
    iface = _iface()
    sample = Sample(
        0x01020304, 0x1122334455, (1, 2, 3, 0xFFFFFFFF, 5, 6), (-22000000, 7, 12345678), 0x25
    )
    body = protocol.encode_message(Message(MsgType.SAMPLE_EVT, 0, sample))
    ids = (ctypes.c_uint32 * 7)()
    data = (ctypes.c_uint8 * 56)()
    assert LIB.shim_can_sample(body, len(body), NODE, ids, data) == 6
    with (
        can.Bus(interface="socketcan", channel=iface) as tx,
        can.Bus(interface="socketcan", channel=iface) as rx,
    ):
        for i in range(6):
            tx.send(
                can.Message(
                    arbitration_id=ids[i], is_extended_id=False, data=bytes(data[8 * i : 8 * i + 8])
                ),
                timeout=1,
            )
        asm = pcan.SampleAssembler(NODE)
        got = None
        deadline = time.monotonic() + 10
        while got is None and time.monotonic() < deadline:
            msg = rx.recv(timeout=0.5)
            if msg is not None:
                got = asm.feed(msg.arbitration_id, bytes(msg.data))
    assert got == Sample(
        sample.seq,
        sample.timestamp_us & 0xFFFFFFFF,
        sample.counts,
        sample.point_100nm,
        sample.status,
    )
