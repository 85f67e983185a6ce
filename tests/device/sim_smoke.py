#!/usr/bin/env python3
"""Smoke test of the real aacmm-sim binary (standard library only).

    python3 tests/device/sim_smoke.py build/sim/aacmm-sim [--stream-seconds S] [--jacobian]
        [--fixed]

Checks the command-line contract (exit codes 2 and 3 with one clear line,
the stdout lines, exit 0 on SIGTERM and SIGINT), then talks to the simulator
over its pseudo-terminal with a minimal codec of its own: garbage followed by
a PING (resynchronisation), INFO, a 1 kHz stream checked for lost or
duplicated sequence numbers, and a SAVE that survives a restart. Prints one
JSON line with the measured stream figures. The thorough loopback tests with
the host client live in tests/host.
"""

from __future__ import annotations

import itertools
import json
import os
import re
import select
import signal
import struct
import subprocess
import sys
import tempfile
import termios
import time
import tty
import zlib
from collections.abc import Iterator
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "host"))
from streamclock import (
    schedule_drift_us,
    schedule_rate_hz,
)  # stdlib only, like this file

# The version byte comes from the one place it is defined, the firmware's header.
_PROTO_H = Path(__file__).resolve().parents[2] / "firmware" / "include" / "aacmm" / "proto.h"
_m = re.search(r"#define AACMM_PROTO_VERSION (\d+)u", _PROTO_H.read_text())
assert _m is not None, f"{_PROTO_H}: AACMM_PROTO_VERSION not found"
PROTO = int(_m.group(1))
PING, INFO, GET_PARAMS, SET_PARAMS, SAVE, RESTORE, MEASURE, COMPUTE, START, STOP = range(1, 11)
SAMPLE_EVT, TRIGGER_EVT, ERROR_RSP = 0x40, 0x41, 0xFF

failures: list[str] = []
EXPECT_FIXED = 1 if "--fixed" in sys.argv else 0  # build_flags bit 0 of a DEVICE_KIN=q build


def check(cond: bool, what: str) -> None:
    print(("ok   " if cond else "FAIL ") + what, flush=True)
    if not cond:
        failures.append(what)


def cobs_encode(data: bytes) -> bytes:
    out = bytearray([0])
    code_pos, code = 0, 1
    for b in data:
        if b == 0:
            out[code_pos] = code
            code_pos, code = len(out), 1
            out.append(0)
        else:
            out.append(b)
            code += 1
            if code == 0xFF:
                out[code_pos] = code
                code_pos, code = len(out), 1
                out.append(0)
    out[code_pos] = code
    return bytes(out)


def cobs_decode(data: bytes) -> bytes | None:
    out = bytearray()
    i = 0
    while i < len(data):
        code = data[i]
        if code == 0 or i + code > len(data):
            return None
        out += data[i + 1 : i + code]
        i += code
        if code < 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


def frame(body: bytes) -> bytes:
    return b"\x00" + cobs_encode(body + struct.pack("<I", zlib.crc32(body))) + b"\x00"


class Link:
    def __init__(self, path: str) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(self.fd)
        attrs = termios.tcgetattr(self.fd)
        attrs[3] &= ~termios.ECHO
        termios.tcsetattr(self.fd, termios.TCSANOW, attrs)
        self.buf = bytearray()
        self.seq = 0
        self.bad = 0

    def send(self, mtype: int, payload: bytes = b"") -> int:
        self.seq = (self.seq + 1) & 0xFF
        os.write(self.fd, frame(bytes([PROTO, mtype, self.seq]) + payload))
        return self.seq

    def frames(self, timeout: float) -> Iterator[bytes]:
        """Yield decoded bodies until timeout (seconds) passes without data."""
        while True:
            while b"\x00" in self.buf:
                raw, _, rest = self.buf.partition(b"\x00")
                self.buf = bytearray(rest)
                if not raw:
                    continue
                dec = cobs_decode(bytes(raw))
                if dec is None or len(dec) < 7:
                    self.bad += 1
                    continue
                body, crc = dec[:-4], struct.unpack("<I", dec[-4:])[0]
                if zlib.crc32(body) != crc:
                    self.bad += 1
                    continue
                yield body
            r, _, _ = select.select([self.fd], [], [], timeout)
            if not r:
                return
            try:
                self.buf += os.read(self.fd, 65536)
            except BlockingIOError:
                pass

    def request(self, mtype: int, payload: bytes = b"", timeout: float = 2.0) -> bytes | None:
        seq = self.send(mtype, payload)
        deadline = time.monotonic() + timeout
        for body in self.frames(0.2):
            if body[2] == seq and body[1] in (mtype | 0x80, ERROR_RSP):
                return body
            if time.monotonic() > deadline:
                break
        return None

    def close(self) -> None:
        os.close(self.fd)


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process (Linux /proc)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def run(args: list[str], timeout: float = 5.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(args, capture_output=True, text=True, timeout=timeout)


def start(sim: str, *extra: str) -> tuple[subprocess.Popen[str], str]:
    p = subprocess.Popen(
        [sim, "--serial", "pty", "--quiet", *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert p.stdout is not None
    first = p.stdout.readline().strip()
    second = p.stdout.readline().strip()
    check(
        first.startswith("aacmm-sim: serial /dev/"),
        f"first stdout line names the pty: {first!r}",
    )
    check(second == "aacmm-sim: ready", f"then 'aacmm-sim: ready': {second!r}")
    return p, first.split(" ", 2)[2]


def stop(p: subprocess.Popen[str], sig: int = signal.SIGTERM) -> int:
    p.send_signal(sig)
    try:
        return p.wait(timeout=5)
    except subprocess.TimeoutExpired:
        p.kill()
        return -999


def test_arguments(sim: str, tmp: str) -> None:
    bad = [
        [],
        ["--serial"],
        ["--serial", "pty", "--node", "200"],
        ["--serial", "pty", "--motion", "dance"],
        ["--serial", "pty", "--encoder-bits", "33"],
        ["--serial", "pty", "--cpr", "1"],
        ["--serial", "pty", "--cpr", "4096", "--encoder-bits", "12"],
        ["--serial", "pty", "--bogus"],
        ["--serial", "pty", "--button-every", "x"],
        ["--serial", "pty", "--encoder", "endat"],
        ["--serial", "pty", "--encoder", "counts", "--encoder-faults", "3"],
        ["--serial", "pty", "--encoder-faults", "-1"],
        ["--serial", "pty", "--motion", "replay:" + os.path.join(tmp, "missing.txt")],
    ]
    for args in bad:
        r = run([sim, *args])
        check(
            r.returncode == 2 and "aacmm-sim:" in r.stderr and r.stdout == "",
            f"bad arguments {args}: exit 2 with a message (got {r.returncode})",
        )
    replay = os.path.join(tmp, "bad.txt")
    with open(replay, "w") as f:
        f.write("# header\n1 2 3 4 5 6\n1, 2, 3, 4, 5\n")
    r = run([sim, "--serial", "pty", "--motion", "replay:" + replay])
    check(
        r.returncode == 2 and f"{replay}:3:" in r.stderr,
        f"malformed replay file: exit 2 naming line 3 ({r.stderr.strip()!r})",
    )
    r = run([sim, "--serial", "/dev/aacmm-no-such-tty"])
    check(
        r.returncode == 3
        and "/dev/aacmm-no-such-tty" in r.stderr
        and len(r.stderr.splitlines()) == 1,
        f"missing tty: exit 3, one line naming it ({r.stderr.strip()!r})",
    )
    r = run([sim, "--serial", "/dev/null"])
    check(
        r.returncode == 3 and "not a tty" in r.stderr,
        f"not a tty: exit 3 ({r.stderr.strip()!r})",
    )
    r = run([sim, "--can", "aacmmnosuch0"])
    check(
        r.returncode == 3 and "aacmmnosuch0" in r.stderr and len(r.stderr.splitlines()) == 1,
        f"bad CAN interface: exit 3, one line ({r.stderr.strip()!r})",
    )


def test_session(sim: str, tmp: str, stream_seconds: float, content: int) -> dict[str, float]:
    store = os.path.join(tmp, "params.bin")
    p, path = start(sim, "--storage", store, "--motion", "static", "--serial-number", "4242")
    link = Link(path)
    # Garbage first: the deframer must resynchronise.
    os.write(link.fd, b"\x13\x37garbage\x00\x05\x01\x02\x03\x04\x05\x06\x00")
    rsp = link.request(PING, struct.pack("<I", 0xDEADBEEF))
    check(
        rsp is not None and rsp[1] == PING | 0x80 and rsp[3:] == struct.pack("<I", 0xDEADBEEF),
        "PING after garbage answered with the token",
    )
    rsp = link.request(INFO)
    ok = rsp is not None and rsp[1] == INFO | 0x80 and len(rsp) == 3 + 25
    check(ok, "INFO answered (25-byte payload)")
    if ok:
        assert rsp is not None
        (
            pv,
            _maj,
            _min,
            _pat,
            flags,
            _crc,
            source,
            state,
            maxb,
            serial,
            _node,
            nj,
            np_,
        ) = struct.unpack("<HBBHIIBBHIBBB", rsp[3:])
        check(
            pv == PROTO and source == 0 and state == 1 and maxb == 512 and serial == 4242,
            f"INFO: defaults, empty storage, serial number (src {source}, state {state})",
        )
        check(
            flags & 0x0001 == EXPECT_FIXED and flags & 0x0008 != 0,
            "INFO: kinematics backend as expected, serial link built in",
        )
        check(
            (nj, np_) == (6, 25),
            f"INFO: the paper's arm, 6 joints and 25 parameters ({nj}, {np_})",
        )
    rsp = link.request(0x7E)
    check(
        rsp is not None and rsp[1] == ERROR_RSP,
        "unknown request type answered with ERROR_RSP",
    )
    # 1 kHz stream.
    rsp = link.request(START, struct.pack("<HB", 1000, content))
    check(
        rsp is not None and rsp[1] == START | 0x80 and rsp[3:] == struct.pack("<HB", 1000, content),
        f"STREAM_START 1000 Hz (content {content}) accepted",
    )
    seqs: list[int] = []
    stamps: list[int] = []
    cpu0, wall0 = cpu_seconds(p.pid), time.monotonic()
    t_end = time.monotonic() + stream_seconds
    for body in link.frames(0.5):
        if body[1] == SAMPLE_EVT:
            seq, ts = struct.unpack_from("<IQ", body, 3)
            if len(body) != 3 + 55 + (300 if content else 0):
                link.bad += 1
            seqs.append(seq)
            stamps.append(ts)
        if time.monotonic() > t_end:
            break
    cpu_pct = 100.0 * (cpu_seconds(p.pid) - cpu0) / (time.monotonic() - wall0)
    link.send(STOP)
    for _ in link.frames(0.3):
        pass
    n = len(seqs)
    gaps = sum(1 for a, b in itertools.pairwise(seqs) if b != a + 1)
    check(n > 0 and seqs[0] == 0, "stream starts at seq 0")
    check(gaps == 0, f"{n} samples, no lost or duplicated sequence numbers ({gaps} gaps)")
    # late samples (the process descheduled) cannot move the drift (streamclock.py)
    span_s = (seqs[-1] - seqs[0]) / 1000.0 if n > 1 else 0.0
    drift_us = schedule_drift_us(seqs, stamps, 1000) if n > 1 else 0.0
    rate = schedule_rate_hz(seqs, stamps, 1000) if n > 1 else 0.0
    check(
        n > 1 and abs(drift_us) < 1000,
        f"device timestamps keep 1000 Hz: {rate:.2f} Hz (schedule drift {drift_us:.0f} us "
        f"over {span_s:.2f} s)",
    )
    check(link.bad == 0, f"no bad frames ({link.bad})")
    deltas = sorted(b - a for a, b in itertools.pairwise(stamps))
    p50 = deltas[len(deltas) // 2] if deltas else 0
    p99 = deltas[int(0.99 * (len(deltas) - 1))] if deltas else 0
    worst = deltas[-1] if deltas else 0
    # Save, restart, and the stored set is back.
    rsp = link.request(SAVE)
    check(rsp is not None and rsp[1] == SAVE | 0x80, "SAVE_PARAMS answered")
    link.close()
    check(stop(p, signal.SIGTERM) == 0, "SIGTERM: exit 0")
    check(
        os.path.exists(store) and not os.path.exists(store + ".tmp"),
        "storage file written, no temp left",
    )
    p, path = start(sim, "--storage", store)
    link = Link(path)
    rsp = link.request(INFO)
    if rsp is not None and len(rsp) == 3 + 25:
        source, state = struct.unpack_from("<BB", rsp, 3 + 14)
        check(
            source == 1 and state == 0,
            f"after restart: parameters from storage (src {source}, state {state})",
        )
    else:
        check(False, "INFO after restart")
    link.close()
    check(stop(p, signal.SIGINT) == 0, "SIGINT: exit 0")
    return {
        "samples": n,
        "seconds": round(span_s, 3),
        "rate_hz": round(rate, 3),
        "gaps": gaps,
        "interval_p50_us": p50,
        "interval_p99_us": p99,
        "sim_cpu_percent": round(cpu_pct, 1),
        "interval_max_us": worst,
        "bad_frames": link.bad,
    }


DIAG = 0x0B
JOINT_FAULTS = 0x3F00


def test_encoder_faults(sim: str) -> dict[str, int]:
    """Corrupted encoder frames (one in 9) are counted per joint and never give a point."""
    p, path = start(
        sim, "--motion", "static", "--encoder", "ssi-gray", "--encoder-bits", "20",
        "--encoder-faults", "9",
    )  # fmt: skip
    link = Link(path)
    faulty_readings = 0
    point_from_bad_frame = 0
    good_counts: set[tuple[int, ...]] = set()
    n = 60
    for _ in range(n):
        rsp = link.request(MEASURE, b"\x00")
        if rsp is None or rsp[1] != MEASURE | 0x80:
            check(False, "MEASURE answered")
            break
        counts = struct.unpack_from("<6I", rsp, 3 + 31)
        status = struct.unpack_from("<I", rsp, 3 + 24)[0]
        bad = status & JOINT_FAULTS
        if bad:
            faulty_readings += bin(bad).count("1")
            point_from_bad_frame += status & 0x1 != 0 or status & 0x2 == 0
        else:
            good_counts.add(counts)
    check(point_from_bad_frame == 0, "no sample with a faulty joint has a point")
    check(
        len(good_counts) == 1,
        f"the clean samples of a static arm agree ({len(good_counts)})",
    )
    rsp = link.request(DIAG)
    ok = rsp is not None and rsp[1] == DIAG | 0x80 and len(rsp) == 3 + 130
    check(ok, "DIAG answered (130-byte payload: 60 + 6 joints x 11 + temp_faults)")
    joint_faults = 0
    if ok:
        assert rsp is not None
        joints = [struct.unpack_from("<BBBII", rsp, 3 + 60 + 11 * j) for j in range(6)]
        joint_faults = sum(j[3] for j in joints)
        check(
            all(j[0] == 3 and j[1] == 20 for j in joints),
            "DIAG: six SSI Gray 20-bit joints",
        )
        check(
            joint_faults == faulty_readings == n * 6 // 9,
            f"DIAG: {joint_faults} joint faults = {faulty_readings} flagged = one frame in 9",
        )
        (temp_faults,) = struct.unpack_from("<I", rsp, 3 + 60 + 11 * 6)
        check(temp_faults == 0, f"DIAG: no temperature faults ({temp_faults})")
    link.close()
    check(stop(p) == 0, "SIGTERM: exit 0")
    return {"encoder_faults": joint_faults}


def main() -> int:
    sim = sys.argv[1] if len(sys.argv) > 1 else "build/sim/aacmm-sim"
    seconds = 3.0
    if "--stream-seconds" in sys.argv:
        seconds = float(sys.argv[sys.argv.index("--stream-seconds") + 1])
    content = 1 if "--jacobian" in sys.argv else 0
    with tempfile.TemporaryDirectory() as tmp:
        test_arguments(sim, tmp)
        stats = test_session(sim, tmp, seconds, content)
        stats["jacobian"] = content
        stats.update(test_encoder_faults(sim))
    print(json.dumps({"sim_stream": stats}))
    if failures:
        print(f"sim smoke: {len(failures)} failed", file=sys.stderr)
        return 1
    print("sim smoke: all passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
