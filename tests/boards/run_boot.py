#!/usr/bin/env python3
"""Boot check of the board ports over their emulated UARTs.

Usage: run_boot.py build/boards/<board>/echo.elf...

Starts each boot image (firmware/boards/common/echo_main.c) under QEMU with
its UART on a TCP socket, as aacmm.boards.start_board does for every image,
and checks over pyserial's socket:// URL that

* the banner names the board and its clock;
* the clock advances ("?" returns the board's microseconds);
* 16 KiB sent in one go come back unchanged: the interrupt-driven UART
  driver loses nothing when its receive ring fills (it holds the emulated
  UART back instead);
* the driver's counters ("#", firmware/boards/common/uart.h) agree with what
  the host sent and received: every byte read, every byte written, no line
  error.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import serial
from aacmm.boards import start_board, stop_board


def read_until(port: serial.SerialBase, end: bytes, timeout: float = 10.0) -> bytes:
    buf = b""
    deadline = time.monotonic() + timeout
    while not buf.endswith(end):
        if time.monotonic() > deadline:
            raise TimeoutError(f"waiting for {end!r}, got {buf[-200:]!r}")
        buf += port.read(1)
    return buf


def check(elf: Path) -> None:
    board = elf.parent.name
    proc, url = start_board(board, elf)
    try:
        port = serial.serial_for_url(url, timeout=0.2)
        try:
            # the guest starts when we connect; under a loaded machine QEMU's TCG may
            # take seconds before the first byte (a CI run once saw none in 10 s)
            banner_bytes = read_until(port, b"\r\n", timeout=30.0)
            banner = banner_bytes.decode()
            print(f"{board}: {banner.strip()}  ({url})")
            assert f"aacmm boot {board} tick_hz=" in banner, banner
            t1_line = port.write(b"?") and read_until(port, b"\n")
            t1 = int(t1_line)
            time.sleep(0.2)
            port.write(b"?")
            t2_line = read_until(port, b"\n")
            t2 = int(t2_line)
            assert t2 > t1, (t1, t2)
            print(f"{board}: clock {t1} us -> {t2} us")
            data = bytes(range(256)).replace(b"?", b"!").replace(b"#", b"!") * 64
            t0 = time.monotonic()
            port.write(data)
            got = b""
            while len(got) < len(data) and time.monotonic() - t0 < 30:
                got += port.read(len(data) - len(got))
            dt = time.monotonic() - t0
            first_bad = next(
                (i for i, (a, b) in enumerate(zip(got, data, strict=False)) if a != b), len(got)
            )
            assert got == data, (
                f"echo: {len(got)} of {len(data)} bytes, first difference at {first_bad}"
            )
            print(f"{board}: echoed {len(data)} bytes intact ({len(data) / dt / 1000:.1f} kB/s)")
            sent = 1 + 1 + len(data) + 1  # "?", "?", the data, "#"
            received = len(banner_bytes) + len(t1_line) + len(t2_line) + len(got)
            port.write(b"#")
            fields = read_until(port, b"\n").decode().split()
            counts = {k: int(v) for k, v in (f.split("=") for f in fields)}
            print(f"{board}: UART counters {counts}")
            assert counts["rx_bytes"] == sent, (counts, sent)
            assert counts["tx_bytes"] == received, (counts, received)
            assert counts["rx_errors"] == 0, counts
            assert 0 < counts["tx_peak_bytes"] <= received, counts
        finally:
            port.close()
    finally:
        stop_board(proc)


def main(argv: list[str]) -> int:
    failed = 0
    for arg in argv:
        try:
            check(Path(arg))
        except (AssertionError, TimeoutError, OSError) as exc:
            print(f"FAIL {arg}: {exc}")
            failed += 1
    print(f"board boot checks: {len(argv)} image(s), {'FAILED' if failed else 'passed'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
