#!/usr/bin/env python3
"""Link temperatures of the real aacmm-sim binary (standard library only).

    python3 tests/device/sim_temps.py build/sim/aacmm-sim [--fixed]

The simulator's side of device temperatures (TEMPS_SPEC.md, docs/simulator.md
"Link temperatures"): the --temperature and --no-temperature-sensors
arguments, INFO's TEMPERATURES build flag, a parameter set with the thermal
block taken (--param-set, SET_PARAMS) where the simulator has sensors and
refused where it has none, and the thermal point: with every link of the
same CTE at the same temperature every length of the arm scales by one factor
f = 1 + cte (T - tref), and so does the point (the chain is linear in its
lengths at fixed angles), so the MEASURE point at T must be f times the
COMPUTE point at the reference temperatures. The control channel's `temps`
line sets the sensors and a sensor that does not answer (`-`) or a reading
outside -40 .. 85 degC flags the sample TEMP_FAULT and, with the thermal
block, leaves it without a point. Talks over the pty with the minimal codec
of tests/device/sim_smoke.py.
"""

from __future__ import annotations

import math
import os
import select
import socket
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sim_smoke import (  # stdlib only, like this file
    COMPUTE,
    DIAG,
    ERROR_RSP,
    GET_PARAMS,
    INFO,
    MEASURE,
    SAVE,
    SET_PARAMS,
    Link,
    check,
    failures,
    run,
    stop,
)

BUILD_TEMPERATURES = 0x0020
POINT_VALID = 0x0001
TEMP_FAULT = 0x8000
ERR_UNSUPPORTED = -12
CTE = 2300  # 23e-6 / K in 1e-8 / K, every link
REF_TEMP = 2000  # 20.00 degC


def start(
    sim: str, *extra: str, pass_fds: tuple[int, ...] = ()
) -> tuple[subprocess.Popen[str], str]:
    p = subprocess.Popen(
        [sim, "--serial", "pty", "--quiet", *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        pass_fds=pass_fds,
    )
    assert p.stdout is not None
    first = p.stdout.readline().strip()
    second = p.stdout.readline().strip()
    if not first.startswith("aacmm-sim: serial /dev/") or second != "aacmm-sim: ready":
        assert p.stderr is not None
        raise RuntimeError(f"aacmm-sim did not start: {first!r} {second!r} {p.stderr.read()!r}")
    return p, first.split(" ", 2)[2]


def thermal_payload(plain: bytes) -> bytes:
    """The paper's arm's set (no harmonics) with the thermal block: H = 1,
    every link's cte CTE, ref_temp REF_TEMP (docs/protocol.md 2.3)."""
    hdr = struct.unpack_from("<I", plain, 4)[0]
    assert hdr == 0, "the default set has no error model"
    n = plain[0]
    return (
        plain[:4]
        + struct.pack("<I", 1 << 28)
        + plain[8:]
        + struct.pack(f"<{n}h", *([CTE] * n))
        + struct.pack("<h", REF_TEMP)
    )


def info_flags(link: Link) -> int | None:
    rsp = link.request(INFO)
    if rsp is None or rsp[1] != INFO | 0x80:
        return None
    return int(struct.unpack_from("<I", rsp, 3 + 6)[0])


def measure(link: Link) -> tuple[int, tuple[int, int, int], tuple[int, ...]] | None:
    """status, point (1e-4 mm), counts of a MEASURE without content."""
    rsp = link.request(MEASURE, b"\x00")
    if rsp is None or rsp[1] != MEASURE | 0x80:
        return None
    point = struct.unpack_from("<3i", rsp, 3 + 12)
    status = struct.unpack_from("<I", rsp, 3 + 24)[0]
    n = rsp[3 + 29]
    counts = struct.unpack_from(f"<{n}I", rsp, 3 + 31)
    return status, point, counts


def compute_ref(link: Link, counts: tuple[int, ...]) -> tuple[float, float, float] | None:
    """COMPUTE without temperatures: the point at the reference temperatures (mm)."""
    rsp = link.request(COMPUTE, struct.pack(f"<BB{len(counts)}I", 0, len(counts), *counts))
    if rsp is None or rsp[1] != COMPUTE | 0x80:
        return None
    x, y, z = struct.unpack_from("<3d", rsp, 3 + 4)
    return x, y, z


def scaled_ok(point: tuple[int, int, int], ref: tuple[float, float, float], t_c: float) -> bool:
    """The wire point is f times the reference point, f = 1 + cte (T - tref),
    within the f32 / fixed-point class (2 um on a ~1 m point)."""
    f = 1.0 + CTE * 1e-8 * (t_c - REF_TEMP * 0.01)
    return all(abs(p * 1e-4 - f * r) < 2e-3 for p, r in zip(point, ref, strict=True))


def test_arguments(sim: str, tmp: str, thermal_file: str) -> None:
    bad = [
        ["--temperature", "90"],
        ["--temperature", "-40.01"],
        ["--temperature", "20,21"],
        ["--temperature", "20.123"],
        ["--temperature", "warm"],
        ["--temperature", "20", "--no-temperature-sensors"],
        ["--no-temperature-sensors=1"],
        ["--temperature", "20,20,20,20,20,20,20"],  # 7 values, the paper's arm has 6 links
    ]
    for args in bad:
        r = run([sim, "--serial", "pty", *args])
        check(
            r.returncode == 2 and r.stderr.startswith("aacmm-sim:") and r.stdout == "",
            f"bad arguments {args}: exit 2 with a message (got {r.returncode})",
        )
    r = run([sim, "--serial", "pty", "--no-temperature-sensors", "--param-set", thermal_file])
    check(
        r.returncode == 2
        and "thermal block" in r.stderr
        and "--no-temperature-sensors" in r.stderr
        and len(r.stderr.splitlines()) == 1,
        f"--param-set with the thermal block, no sensors: exit 2, one line ({r.stderr.strip()!r})",
    )
    r = run([sim, "--help"])
    check(
        r.returncode == 0
        and "--temperature" in r.stdout
        and "--no-temperature-sensors" in r.stdout,
        "--help names --temperature and --no-temperature-sensors",
    )


def test_sensors_and_sets(sim: str, tmp: str) -> str:
    """INFO's flag, SET_PARAMS of a thermal set with and without sensors;
    returns the path of the thermal set's file."""
    p, path = start(sim, "--motion", "static")
    link = Link(path)
    flags = info_flags(link)
    check(flags is not None and flags & BUILD_TEMPERATURES != 0, "INFO: TEMPERATURES by default")
    rsp = link.request(GET_PARAMS)
    assert rsp is not None and rsp[1] == GET_PARAMS | 0x80, "GET_PARAMS answered"
    thermal = thermal_payload(rsp[3:])
    rsp = link.request(SET_PARAMS, thermal)
    check(
        rsp is not None and rsp[1] == SET_PARAMS | 0x80,
        "SET_PARAMS with the thermal block accepted (sensors at 20.00 degC)",
    )
    m = measure(link)
    check(
        m is not None and m[0] & (POINT_VALID | TEMP_FAULT) == POINT_VALID,
        "a thermal set's sample at 20.00 degC has a point, no TEMP_FAULT",
    )
    link.close()
    check(stop(p) == 0, "SIGTERM: exit 0")
    thermal_file = os.path.join(tmp, "thermal.bin")
    with open(thermal_file, "wb") as f:
        f.write(thermal)

    p, path = start(sim, "--motion", "static", "--no-temperature-sensors")
    link = Link(path)
    flags = info_flags(link)
    check(
        flags is not None and flags & BUILD_TEMPERATURES == 0,
        "INFO: no TEMPERATURES with --no-temperature-sensors",
    )
    rsp = link.request(SET_PARAMS, thermal)
    status = struct.unpack_from("<h", rsp, 3)[0] if rsp is not None and rsp[1] == ERROR_RSP else 0
    check(
        status == ERR_UNSUPPORTED, f"SET_PARAMS with the thermal block: ERR_UNSUPPORTED ({status})"
    )
    m = measure(link)
    check(
        m is not None and m[0] & (POINT_VALID | TEMP_FAULT) == POINT_VALID,
        "no sensors: samples have points and no TEMP_FAULT",
    )
    link.close()
    check(stop(p) == 0, "SIGTERM: exit 0")
    return thermal_file


def test_stored_thermal_set(sim: str, tmp: str) -> None:
    """A thermal set saved on a simulator with sensors is not used by one without
    (defaults, the start-up line says why), and is again with sensors."""
    store = os.path.join(tmp, "store.bin")
    p, path = start(sim, "--storage", store)
    link = Link(path)
    rsp = link.request(GET_PARAMS)
    assert rsp is not None and rsp[1] == GET_PARAMS | 0x80, "GET_PARAMS answered"
    ok = link.request(SET_PARAMS, thermal_payload(rsp[3:]))
    saved = link.request(SAVE)
    check(
        ok is not None
        and ok[1] == SET_PARAMS | 0x80
        and saved is not None
        and saved[1] == SAVE | 0x80,
        "a thermal set set and saved",
    )
    link.close()
    check(stop(p) == 0, "SIGTERM: exit 0")
    for args, source, what in (
        (("--no-temperature-sensors",), 0, "without sensors: the defaults"),
        ((), 1, "with sensors: the stored set"),
    ):
        q = subprocess.Popen(
            [sim, "--serial", "pty", "--storage", store, *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert q.stdout is not None and q.stderr is not None
        report = q.stderr.readline().strip()
        first = q.stdout.readline().strip()
        q.stdout.readline()
        link = Link(first.split(" ", 2)[2])
        rsp = link.request(INFO)
        got = rsp[3 + 14] if rsp is not None and rsp[1] == INFO | 0x80 else -1
        check(got == source, f"stored thermal set, {what} (param_source {got})")
        if source == 0:
            check(
                "thermal block without temperature sensors" in report,
                f"the start-up line says why: {report!r}",
            )
        link.close()
        check(stop(q) == 0, "SIGTERM: exit 0")


def test_thermal_point(sim: str, thermal_file: str) -> None:
    """--param-set with the thermal block at --temperature T: point = f x reference."""
    for t_c, arg in ((45.0, "45"), (-12.5, "-12.5"), (20.0, "20,20,20,20,20,20")):
        p, path = start(
            sim, "--motion", "static", "--param-set", thermal_file, "--temperature", arg
        )
        link = Link(path)
        m = measure(link)
        ref = compute_ref(link, m[2]) if m is not None else None
        ok = m is not None and ref is not None and m[0] & POINT_VALID != 0
        check(ok, f"--temperature {arg}: MEASURE and COMPUTE answered, a point")
        if ok:
            assert m is not None and ref is not None
            moved = math.dist([v * 1e-4 for v in m[1]], ref)
            check(
                scaled_ok(m[1], ref, t_c),
                f"--temperature {arg}: the point is (1 + cte dT) x the reference point "
                f"(moved {moved:.4f} mm)",
            )
            if t_c == 45.0:
                check(moved > 0.1, f"25 K move the tip by {moved:.3f} mm (> 0.1)")
        link.close()
        check(stop(p) == 0, "SIGTERM: exit 0")


class Control:
    """The control channel over a socket pair (docs/simulator.md)."""

    def __init__(self) -> None:
        self.ours, self.theirs = socket.socketpair()
        self.buf = b""
        self.token = 0

    def line(self, timeout: float = 3.0) -> str | None:
        deadline = time.monotonic() + timeout
        while b"\n" not in self.buf:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self.ours], [], [], left)[0]:
                return None
            data = self.ours.recv(4096)
            if not data:
                return None
            self.buf += data
        raw, _, self.buf = self.buf.partition(b"\n")
        return raw.decode()

    def send(self, *lines: str) -> list[str]:
        """Send lines, then a sync; the lines heard before the sync's answer."""
        self.token += 1
        self.ours.sendall(("".join(f"{x}\n" for x in lines) + f"sync t{self.token}\n").encode())
        heard: list[str] = []
        while True:
            got = self.line()
            if got is None or got == f"sync t{self.token}":
                return heard
            heard.append(got)


def test_wire_temperatures(sim: str, thermal_file: str) -> None:
    """Protocol version 4 through the binary: the sample's temperatures
    (content bit 1, i16[N] after the counts), DIAG's temp_faults (after the N
    joint entries), COMPUTE at the request's temperatures."""
    ctl = Control()
    fd = ctl.theirs.fileno()
    p, path = start(sim, "--control", str(fd), "--param-set", thermal_file, pass_fds=(fd,))
    ctl.theirs.close()
    ctl.line()
    link = Link(path)
    ctl.send("counts 1 2 3 4 5 6", "temps 21.5 -3.25 - 85.5 40 20")
    rsp = link.request(MEASURE, b"\x02")
    ok = rsp is not None and rsp[1] == MEASURE | 0x80 and len(rsp) == 3 + 31 + 24 + 12
    check(ok, "MEASURE with TEMPERATURES: 67-byte sample (6 counts, 6 temperatures)")
    if ok:
        assert rsp is not None
        temps = struct.unpack_from("<6h", rsp, 3 + 31 + 24)
        status = struct.unpack_from("<I", rsp, 3 + 24)[0]
        check(
            temps == (2150, -325, -32768, 8550, 4000, 2000),
            f"the sample's temperatures as the sensors read them, -32768 for link 3 ({temps})",
        )
        check(status & (TEMP_FAULT | POINT_VALID) == TEMP_FAULT, "TEMP_FAULT, no point")
    rsp = link.request(DIAG)
    ok = rsp is not None and rsp[1] == DIAG | 0x80 and len(rsp) == 3 + 130
    faults = struct.unpack_from("<I", rsp, 3 + 126)[0] if ok and rsp is not None else -1
    check(ok and faults == 1, f"DIAG: temp_faults 1 ({faults})")
    counts = (0x20000000, 0xC0000000, 0x30000000, 0xF0000000, 0x2AAAAAAB, 0x9ABCDEF0)
    ref = compute_ref(link, counts)
    temps_req = (4500,) * 6
    rsp = link.request(COMPUTE, struct.pack("<BB6I6h", 2, 6, *counts, *temps_req))
    ok = rsp is not None and rsp[1] == COMPUTE | 0x80 and ref is not None
    if ok:
        assert rsp is not None and ref is not None
        pt = struct.unpack_from("<3d", rsp, 3 + 4)
        f = 1.0 + CTE * 1e-8 * 25.0
        ok = rsp[3 + 28] == 2 and all(abs(a - f * b) < 2e-3 for a, b in zip(pt, ref, strict=True))
    check(ok, "COMPUTE at 45 degC (request): (1 + cte dT) x the reference point, content echoed")
    link.close()
    ctl.ours.close()
    check(stop(p) == 0, "SIGTERM: exit 0")

    p, path = start(sim, "--no-temperature-sensors")
    link = Link(path)
    rsp = link.request(MEASURE, b"\x02")
    status = struct.unpack_from("<h", rsp, 3)[0] if rsp is not None and rsp[1] == ERROR_RSP else 0
    check(status == ERR_UNSUPPORTED, f"no sensors: MEASURE with TEMPERATURES refused ({status})")
    link.close()
    check(stop(p) == 0, "SIGTERM: exit 0")


def test_control_temps(sim: str, thermal_file: str) -> None:
    ctl = Control()
    fd = ctl.theirs.fileno()
    counts = "536870912 3221225472 805306368 4026531840 715827883 2596069104"
    p, path = start(sim, "--control", str(fd), "--param-set", thermal_file, pass_fds=(fd,))
    ctl.theirs.close()
    check(ctl.line() == "control 1", "control channel: 'control 1'")
    link = Link(path)
    heard = ctl.send(f"counts {counts}", "temps 45")
    check(heard == [], f"counts, temps 45: no reply ({heard})")
    m = measure(link)
    ref = compute_ref(link, m[2]) if m is not None else None
    check(
        m is not None
        and ref is not None
        and m[0] & POINT_VALID != 0
        and scaled_ok(m[1], ref, 45.0),
        "temps 45: the point at 45 degC on every link",
    )
    cases = [
        ("temps 20 20 - 20 20 20", False, "link 3 does not answer"),
        ("temps 85.01", False, "85.01 degC (above 85)"),
        ("temps -40.01", False, "-40.01 degC (below -40)"),
        ("temps -", False, "no sensor answers"),
        ("temps 85", True, "85.00 degC"),
        ("temps -40 -40 -40 -40 -40 -40.00", True, "-40.00 degC per link"),
        ("temps 21.5 22 22.25 23 24 25.75 -", True, "seven values, link 7 not the arm's"),
    ]
    for line, good, what in cases:
        heard = ctl.send(line)
        m = measure(link)
        if good:
            ok = m is not None and m[0] & (POINT_VALID | TEMP_FAULT) == POINT_VALID
        else:
            ok = m is not None and m[0] & (POINT_VALID | TEMP_FAULT) == TEMP_FAULT
            ok = ok and m is not None and m[1] == (0, 0, 0)
        check(
            ok and heard == [],
            f"`{line}` ({what}): " + ("a point" if good else "TEMP_FAULT, no point"),
        )
    for bad in ("temps 20 21", "temps warm", "temps 20.001", "temps 400"):
        heard = ctl.send(bad)
        check(
            len(heard) == 1 and heard[0].startswith("error temps"),
            f"`{bad}`: one error line ({heard})",
        )
    # temps set before a barrier are applied in order with counts
    heard = ctl.send("temps 30", f"counts {counts}", "temps 45")
    m = measure(link)
    check(
        m is not None and ref is not None and scaled_ok(m[1], ref, 45.0),
        "the last temps before a sync wins",
    )
    link.close()
    ctl.ours.close()
    check(stop(p) == 0, "SIGTERM: exit 0")

    # no sensors: `temps` refused with an error line; without the thermal
    # block a missing sensor only flags the sample
    ctl = Control()
    fd = ctl.theirs.fileno()
    p, path = start(sim, "--control", str(fd), "--no-temperature-sensors", pass_fds=(fd,))
    ctl.theirs.close()
    ctl.line()
    heard = ctl.send("temps 20")
    check(
        len(heard) == 1 and "no temperature sensors" in heard[0],
        f"--no-temperature-sensors: `temps` refused ({heard})",
    )
    ctl.ours.close()
    stop(p)
    ctl = Control()
    fd = ctl.theirs.fileno()
    p, path = start(sim, "--control", str(fd), pass_fds=(fd,))
    ctl.theirs.close()
    ctl.line()
    link = Link(path)
    ctl.send(f"counts {counts}")
    before = measure(link)
    ctl.send("temps 20 20 20 20 - 20")
    after = measure(link)
    check(
        before is not None
        and after is not None
        and after[0] == before[0] | TEMP_FAULT
        and after[1] == before[1],
        "no thermal block: a missing sensor flags TEMP_FAULT, the point unchanged",
    )
    link.close()
    ctl.ours.close()
    check(stop(p) == 0, "SIGTERM: exit 0")


def main() -> int:
    sim = sys.argv[1] if len(sys.argv) > 1 else "build/sim/aacmm-sim"
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        thermal_file = test_sensors_and_sets(sim, tmp)
        test_arguments(sim, tmp, thermal_file)
        test_thermal_point(sim, thermal_file)
        test_stored_thermal_set(sim, tmp)
        test_control_temps(sim, thermal_file)
        test_wire_temperatures(sim, thermal_file)
    if failures:
        print(f"sim temperatures: {len(failures)} failed", file=sys.stderr)
        return 1
    print(f"sim temperatures: all passed ({time.monotonic() - t0:.2f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
