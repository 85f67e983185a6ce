"""Hostile input against the sanitizer builds of the simulator (#15.10).

`make sim SAN=1` (and `SAN=1 DEVICE_KIN=q`) builds aacmm-sim with
AddressSanitizer and UndefinedBehaviorSanitizer, aborting on the first
report. Both kinematics backends get, over their serial link: random bytes,
torn and oversize frames, frames with a good CRC around random bodies (every
message type, every length), mutated valid requests, requests with extreme
but encodable values (parameter sets at and beyond the limits, counts at the
edges, every stream rate), a stalled host while streaming with the Jacobian,
and corrupted encoder frames on every joint; and hostile storage files at
start-up (random, truncated, oversized, a record with a good CRC around
garbage); and hostile `temps` lines on the control channel (issue 27: random
numbers, signs, decimals, dashes and blanks; overlong words and lines), each
followed by a sample with the temperatures. Every run must end with exit
status 0 on SIGTERM and nothing from a sanitizer on stderr, and the device
must still answer afterwards.

The binaries come from $AACMM_SIM_SAN and $AACMM_SIM_SAN_Q (mk/sim-robust.mk).
"""

from __future__ import annotations

import os
import random
import select
import struct
import time
import tty
import zlib
from collections.abc import Iterator
from pathlib import Path

import pytest
from aacmm.protocol import (
    PROTOCOL_VERSION,
    Deframer,
    Message,
    MsgType,
    Ping,
    decode_message,
    encode_frame,
    frame_message,
)
from aacmm.simulation.control import ControlChannel, ControlError
from aacmm.simulation.process import SimProcess
from simproc import Sim

pytestmark = pytest.mark.timeout(300)

ROOT = Path(__file__).resolve().parents[2]
BINARIES = {
    "f32": os.environ.get("AACMM_SIM_SAN", str(ROOT / "build" / "sim-san" / "aacmm-sim")),
    "q": os.environ.get("AACMM_SIM_SAN_Q", str(ROOT / "build" / "sim-q-san" / "aacmm-sim")),
}
SANITIZER_WORDS = (
    "AddressSanitizer",
    "LeakSanitizer",
    "runtime error",
    "UndefinedBehavior",
)


class Link:
    def __init__(self, path: str) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(self.fd)
        self.deframer = Deframer()

    def send(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            try:
                n = os.write(self.fd, view)
            except BlockingIOError:
                self.drain(0.01)
                continue
            view = view[n:]

    def drain(self, seconds: float) -> int:
        """Read and decode whatever arrives for `seconds`; return the bodies seen."""
        end = time.monotonic() + seconds
        bodies = 0
        while True:
            left = end - time.monotonic()
            if left <= 0:
                return bodies
            if select.select([self.fd], [], [], left)[0]:
                try:
                    data = os.read(self.fd, 65536)
                except BlockingIOError:
                    continue
                for body in self.deframer.feed(data):
                    check_body(body)  # everything the device sends decodes
                    bodies += 1

    def ping(self, token: int) -> bool:
        self.send(frame_message(Message(MsgType.PING_REQ, token & 0xFF, Ping(token))))
        end = time.monotonic() + 10.0
        while time.monotonic() < end:
            if select.select([self.fd], [], [], 0.5)[0]:
                try:
                    data = os.read(self.fd, 65536)
                except BlockingIOError:
                    continue
                for body in self.deframer.feed(data):
                    msg = check_body(body)
                    if (
                        msg is not None
                        and msg.type == MsgType.PING_RSP
                        and msg.payload == Ping(token)
                    ):
                        return True
        return False

    def close(self) -> None:
        os.close(self.fd)


V = PROTOCOL_VERSION


def check_body(body: bytes) -> Message | None:
    """A body the device sent: a message of this version, or (the answer to a
    request of an older version: version 1 in the mix, 2 .. V - 1 from a mutated
    version byte) an ERROR_RSP ERR_VERSION in that version, which is None here."""
    if 1 <= body[0] < V:
        assert len(body) == 6 and body[1] == 0xFF, body.hex()
        assert struct.unpack_from("<h", body, 3)[0] == -16, body.hex()  # ERR_VERSION
        return None
    return decode_message(body)


VALID_BODIES = [
    bytes([V, 0x01, 1]) + struct.pack("<I", 99),  # ping
    bytes([V, 0x07, 2, 1]),  # measure with the Jacobian
    bytes([V, 0x08, 3, 0, 6]) + struct.pack("<6I", 1, 2, 3, 4, 5, 6),  # compute
    bytes([V, 0x09, 4]) + struct.pack("<HB", 100, 0),  # stream start
    bytes([V, 0x0B, 5]),  # diagnostics
]


def framed(body: bytes) -> bytes:
    """Any body (up to 512 bytes) in a serial frame with a good CRC."""
    return encode_frame(body)


def hostile_frames(rng: random.Random) -> Iterator[bytes]:
    types = list(range(256))
    for _ in range(3000):
        kind = rng.randrange(8)
        if kind == 0:  # random bytes, zeros included: torn frames, garbage
            yield rng.randbytes(rng.randrange(1, 700))
        elif kind == 1:  # a good CRC around a random body of any type and length
            t = rng.choice(types)
            v = rng.choice([V, V, 1])  # and the six-joint version before arm models
            body = bytes([v, t, rng.randrange(256)]) + rng.randbytes(rng.randrange(0, 509))
            yield framed(body)
        elif kind == 2:  # the right length for a request type, random payload
            t = rng.randrange(1, 0x0C)
            n = {1: 4, 4: 262, 7: 1, 8: 26, 9: 3}.get(t, 0)
            yield framed(bytes([V, t, rng.randrange(256)]) + rng.randbytes(n))
        elif kind == 3:  # arm models of 3..8 joints, extreme values, some beyond the limits
            nj = rng.choice([3, 4, 5, 6, 6, 7, 7, 8])
            tip = rng.choice([1, 1, 3, 2])
            conv = rng.randrange(1 << nj) if rng.random() < 0.5 else 0
            beta = (rng.randrange(1 << nj) & ~1) if rng.random() < 0.5 else 0
            beta |= rng.random() < 0.05  # a beta on joint 1
            k = rng.choice([0, 0, 0, 1, 4, 5])
            h = rng.choice([0, 0, 1, 2])
            nf = 4 * nj + bin(beta).count("1") + tip
            vals = [rng.choice([0.0, -0.0, 6.283185307179586, 1e4, -1e4, 1e300, 5e-324, 7.0])
                    for _ in range(nf)]  # fmt: skip
            cpr = [rng.choice([1, 2, 1 << 32, (1 << 32) - 1, 0]) - 1 for _ in range(nj)]
            zero = [rng.choice([0, 1, (1 << 32) - 1]) for _ in range(nj)]
            dirs = [rng.choice([1, -1, 0, 2]) for _ in range(nj)]
            payload = bytes([nj, tip, conv, beta, k, h, 0, 0])
            payload += struct.pack(f"<{nf}d", *vals)
            payload += struct.pack(f"<{nj}I{nj}I{nj}b", *(c % (1 << 32) for c in cpr), *zero, *dirs)
            payload += rng.randbytes(4 * nj * k + 2 * (nj + 1) * min(h, 1))
            yield framed(bytes([V, 0x04, rng.randrange(256)]) + payload[:509])
        elif kind == 4:  # compute with edge counts, with and without the Jacobian
            nj = rng.choice([3, 4, 6, 6, 7, 8])  # the device's is 6: the others are refused
            counts = [rng.choice([0, 1, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF]) for _ in range(nj)]
            body = bytes([V, 0x08, 1, rng.randrange(2), nj]) + struct.pack(f"<{nj}I", *counts)
            yield framed(body)
        elif kind == 5:  # stream start at any rate (0 and > 1000 refused)
            rate = rng.choice([0, 1, 7, 999, 1000, 1001, 65535])
            yield framed(bytes([V, 0x09, 2]) + struct.pack("<HB", rate, rng.randrange(3)))
        elif kind == 6:  # a valid request with one byte mutated, CRC recomputed
            base = bytearray(rng.choice(VALID_BODIES))
            base[rng.randrange(len(base))] = rng.randrange(256)
            yield framed(bytes(base))
        else:  # oversize: a frame longer than any body, no zero inside
            yield b"\x00" + bytes(rng.randrange(1, 256) for _ in range(rng.randrange(520, 1500)))


def check_clean_exit(sim: Sim) -> None:
    code = sim.stop()
    text = "\n".join(sim.stderr_lines)
    assert code == 0, f"exit {code}:\n{text[-3000:]}"
    for word in SANITIZER_WORDS:
        assert word not in text, text[-3000:]


@pytest.fixture(params=sorted(BINARIES))
def sim_bin(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    path = BINARIES[request.param]
    assert Path(path).is_file(), f"{path} missing (make sim SAN=1)"
    monkeypatch.setenv("ASAN_OPTIONS", "detect_leaks=1:abort_on_error=1")
    monkeypatch.setenv("UBSAN_OPTIONS", "print_stacktrace=1:halt_on_error=1")
    import simproc

    monkeypatch.setattr(simproc, "SIM_BIN", Path(path))
    return path


def test_hostile_link_input(sim_bin: str, tmp_path: Path) -> None:
    rng = random.Random(15)
    store = tmp_path / "arm.bin"
    with Sim(
        "--serial", "pty", "--storage", str(store), "--encoder-faults", "3",
        "--button-every", "0.05", "--noise-counts", "1000",
    ) as sim:  # fmt: skip
        assert sim.serial_path is not None
        link = Link(sim.serial_path)
        sent = 0
        for chunk in hostile_frames(rng):
            link.send(chunk)
            sent += len(chunk)
            if rng.random() < 0.05:
                link.drain(0.01)
        link.drain(0.5)
        # a Jacobian stream with the host stalled, then hostile input again
        link.send(framed(bytes([V, 0x09, 9]) + struct.pack("<HB", 1000, 1)))
        time.sleep(1.2)
        for chunk in hostile_frames(random.Random(16)):
            link.send(chunk)
        link.send(framed(bytes([V, 0x0A, 10])))  # stop the stream
        link.send(framed(bytes([V, 0x05, 11])))  # save whatever set is active
        link.drain(1.0)
        assert link.ping(0x1234ABCD), "the device stopped answering"
        link.close()
        check_clean_exit(sim)
    assert sent > 600_000


@pytest.mark.parametrize(
    "content",
    [
        b"",
        b"AACM",
        b"\x00" * 1024,
        b"random",
        b"huge",
        b"good-crc",
    ],
    ids=["empty", "magic-only", "zeros", "random", "huge", "good-crc-garbage"],
)
def test_hostile_storage_files(sim_bin: str, tmp_path: Path, content: bytes) -> None:
    store = tmp_path / "arm.bin"
    rng = random.Random(len(content))
    if content == b"random":
        content = rng.randbytes(1024)
    elif content == b"huge":
        content = rng.randbytes(3 * 1024 * 1024)
    elif content == b"good-crc":
        rec = bytearray(rng.randbytes(512))
        rec[0:12] = b"AACM" + struct.pack("<HHI", 1, 278, 5)
        struct.pack_into("<I", rec, 290, zlib.crc32(bytes(rec[:290])))
        content = bytes(rec) * 2
    store.write_bytes(content)
    (tmp_path / "arm.bin.tmp").write_bytes(rng.randbytes(100))  # a stale temp file
    with Sim("--serial", "pty", "--storage", str(store)) as sim:
        assert sim.serial_path is not None
        link = Link(sim.serial_path)
        assert link.ping(7)
        link.send(framed(bytes([V, 0x05, 1])))  # save over it
        link.drain(0.3)
        link.close()
        check_clean_exit(sim)
    assert store.stat().st_size == 1024


def hostile_temps_lines(rng: random.Random) -> Iterator[str]:
    """`temps` lines: 0 .. 9 words of digits, signs, dots, dashes and junk."""
    alphabet = "0123456789-+.-"
    edge = ["-", "+", ".", "-.", "1.", ".5", "-0", "+0.00", "327.67", "-327.67", "327.68"]
    edge += ["-327.68", "85.001", "1e2", "0x10", "999999999999999999999", "--", "1..2", "\x7f"]
    for _ in range(1500):
        n = rng.choice([0, 1, 1, 2, 5, 6, 6, 7, 7, 8, 9])
        words = []
        for _ in range(n):
            if rng.random() < 0.3:
                words.append(rng.choice(edge))
            else:
                words.append("".join(rng.choice(alphabet) for _ in range(rng.randrange(1, 9))))
        yield " ".join(["temps", *words])[:250]
    yield "temps " + "1" * 300  # an overlong line
    yield "temps " + " ".join(["20"] * 40)


def test_hostile_temps_lines(sim_bin: str, tmp_path: Path) -> None:
    rng = random.Random(27)
    chan, fd = ControlChannel.pair()
    errlog = (tmp_path / "stderr.txt").open("w")
    try:
        sim = SimProcess(
            ["--serial", "pty", "--control", str(fd)],
            stderr=errlog,
            binary=Path(sim_bin),
            pass_fds=[fd],
        )
    finally:
        chan.child_started()
    chan.hello()
    assert sim.serial_path is not None
    link = Link(sim.serial_path)
    refused = 0
    for k, line in enumerate(hostile_temps_lines(rng)):
        chan.send_raw(line)
        if k % 50 == 49:
            try:
                chan.sync()
            except ControlError:
                refused += 1
            # a sample with the temperatures, whatever the sensors read now
            link.send(framed(bytes([V, 0x07, k & 0xFF, 0x03])))
            link.drain(0.02)
    chan.send_raw("temps 20")
    for _ in range(10):  # the refusals of the last lines, reported one per sync
        try:
            chan.sync()
            break
        except ControlError:
            refused += 1
    else:
        raise AssertionError("the channel keeps reporting refusals")
    assert refused > 2
    assert link.ping(0x7E3B), "the device stopped answering"
    link.close()
    chan.close()  # end of file on the channel ends the simulator
    code = sim.proc.wait(timeout=10)
    errlog.close()
    text = (tmp_path / "stderr.txt").read_text()
    assert code == 0, text[-3000:]
    for word in SANITIZER_WORDS:
        assert word not in text, text[-3000:]
