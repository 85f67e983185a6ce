"""Responses do not wait behind stale samples (#15.8), on the real simulator.

A 1 kHz stream with the Jacobian (about 370 bytes a sample) runs while the
host stops reading for 1 s: the device's 256 KiB output queue fills. Then the
host sends a PING and reads everything until the answer. Before the fix the
answer came behind the whole queue (measured: 278 KB, 765 frames); now it
waits only for what the pseudo-terminal already holds plus the frame in
progress (measured: 17 KB). The test bounds the bytes ahead of the answer,
not the time (the machine may be loaded), and prints the latency.
"""

from __future__ import annotations

import json
import os
import select
import time
import tty

import pytest
from aacmm.protocol import (
    Deframer,
    Message,
    MsgType,
    Ping,
    Stream,
    decode_message,
    frame_message,
)
from simproc import Sim

pytestmark = pytest.mark.timeout(60)

QUEUE_BYTES = 256 * 1024  # the simulator's serial output queue


def read_until(fd: int, deframer: Deframer, want: MsgType, seq: int, limit_s: float) -> int:
    """Read frames until the message (want, seq); return the bytes read before it."""
    ahead = 0
    end = time.monotonic() + limit_s
    while time.monotonic() < end:
        r, _, _ = select.select([fd], [], [], 0.5)
        if not r:
            continue
        data = os.read(fd, 4096)
        for i in range(len(data)):  # byte by byte: count exactly what came first
            for body in deframer.feed(data[i : i + 1]):
                msg = decode_message(body)
                if msg.type == want and msg.seq == seq:
                    return ahead + i + 1
        ahead += len(data)
    raise AssertionError(f"no {want.name} within {limit_s} s")


def test_request_answered_after_a_host_stall() -> None:
    with Sim("--serial", "pty", "--quiet") as sim:
        assert sim.serial_path is not None
        fd = os.open(sim.serial_path, os.O_RDWR | os.O_NOCTTY)
        try:
            tty.setraw(fd)
            d = Deframer()
            os.write(fd, frame_message(Message(MsgType.STREAM_START_REQ, 1, Stream(1000, True))))
            read_until(fd, d, MsgType.STREAM_START_RSP, 1, 5.0)
            end = time.monotonic() + 0.3
            while time.monotonic() < end:  # streaming normally
                if select.select([fd], [], [], 0.1)[0]:
                    d.feed(os.read(fd, 65536))
            time.sleep(1.0)  # the host stalls; the device keeps streaming
            t0 = time.monotonic()
            os.write(fd, frame_message(Message(MsgType.PING_REQ, 2, Ping(0x5EED))))
            ahead = read_until(fd, Deframer(), MsgType.PING_RSP, 2, 20.0)
            latency_ms = (time.monotonic() - t0) * 1e3
            os.write(fd, frame_message(Message(MsgType.STREAM_STOP_REQ, 3)))
        finally:
            os.close(fd)
    print(json.dumps({"stall_s": 1.0, "bytes_before_answer": ahead, "latency_ms": latency_ms}))
    assert ahead < QUEUE_BYTES // 2, f"{ahead} bytes of stale samples came before the answer"
