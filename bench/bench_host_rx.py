"""Host receive cost per serial frame; one JSON object per line on stdout.

What a client's reader thread does for each sample the device streams: find
the frame delimiters, undo the COBS stuffing, check the CRC-32
(:func:`zlib.crc32`), decode the message and hand it to the sink
(:meth:`aacmm.transport.SerialTransport.feed`). Two frame sizes: a sample
event (56-byte body) and a sample event with the Jacobian (356-byte body).

* ``host_rx.crc32``: the CRC of one body alone.
* ``host_rx.frame``: the whole receive path, frames fed in 4 KiB chunks as a
  1 kHz stream arrives (``us_per_frame``), and one frame per read
  (``us_per_frame_single``); ``core_share_1khz`` is the fraction of one core
  a 1 kHz stream of such frames costs (``us_per_frame`` x 1000 / 1e6).

Each figure is the best of several repeats of process CPU time (the cost on
one core, independent of other load); ``wall_us_per_frame`` is the same in
wall-clock time.
"""

from __future__ import annotations

import json
import time
import zlib
from collections.abc import Callable

from aacmm.protocol import Message, MsgType, Sample, encode_frame, encode_message
from aacmm.transport import SerialTransport

REPEATS = 7
N_CRC = 20_000


def best(fn: Callable[[], object], repeats: int = REPEATS) -> tuple[float, float]:
    """Best process CPU time and best wall time of ``fn`` (s)."""
    cpu = wall = float("inf")
    for _ in range(repeats):
        c0, t0 = time.process_time(), time.perf_counter()
        fn()
        cpu = min(cpu, time.process_time() - c0)
        wall = min(wall, time.perf_counter() - t0)
    return cpu, wall


class CountingSink:
    def __init__(self) -> None:
        self.messages = 0
        self.errors = 0

    def on_message(self, msg: Message) -> None:
        self.messages += 1

    def on_frame_error(self, err: object) -> None:
        self.errors += 1

    def on_link_lost(self, err: BaseException) -> None:
        pass


def sample_body(seq: int, jacobian: bool) -> bytes:
    jac = (
        tuple(tuple(((25 * r + c) % 17) * 0.25 - 2.0 for c in range(25)) for r in range(3))
        if jacobian
        else None
    )
    s = Sample(
        seq=seq,
        timestamp_us=1_000_000 + 1000 * seq,
        counts=(seq * 7919, 1 << 30, 3 << 30, 12345, 0xFFFFFFFF, seq),
        point_100nm=(5_300_295, -5_806_323, -8_508_455),
        status=1,
        jacobian=jac,
    )
    return encode_message(Message(MsgType.SAMPLE_EVT, seq & 0xFF, s))


def main() -> None:
    for jacobian in (False, True):
        body = sample_body(1, jacobian)

        def crcs(b: bytes = body) -> None:
            for _ in range(N_CRC):
                zlib.crc32(b)

        cpu, wall = best(crcs)
        print(
            json.dumps(
                {
                    "bench": "host_rx.crc32",
                    "body_bytes": len(body),
                    "us_per_body": round(cpu / N_CRC * 1e6, 4),
                    "wall_us_per_body": round(wall / N_CRC * 1e6, 4),
                }
            ),
            flush=True,
        )

        n = 2000
        frames = [encode_frame(sample_body(i, jacobian)) for i in range(n)]
        stream = b"".join(frames)
        chunks = [stream[i : i + 4096] for i in range(0, len(stream), 4096)]
        transport = SerialTransport("loop://")
        sink = CountingSink()
        transport.start(sink)  # no reader thread is needed: feed() is called here

        def chunked(t: SerialTransport = transport, cs: list[bytes] = chunks) -> None:
            for c in cs:
                t.feed(c)

        def single(t: SerialTransport = transport, fs: list[bytes] = frames) -> None:
            for f in fs:
                t.feed(f)

        cpu, wall = best(chunked)
        cpu1, _ = best(single)
        transport.close()
        assert sink.errors == 0 and sink.messages == 2 * REPEATS * n, vars(sink)
        us = cpu / n * 1e6
        print(
            json.dumps(
                {
                    "bench": "host_rx.frame",
                    "body_bytes": len(body),
                    "wire_bytes": len(frames[1]),
                    "frames": n,
                    "us_per_frame": round(us, 2),
                    "us_per_frame_single": round(cpu1 / n * 1e6, 2),
                    "wall_us_per_frame": round(wall / n * 1e6, 2),
                    "core_share_1khz": round(us * 1000 / 1e6, 4),
                    "crc": "zlib.crc32",
                }
            ),
            flush=True,
        )


if __name__ == "__main__":
    main()
