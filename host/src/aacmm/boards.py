"""Emulated ARM boards: run the firmware images of ``firmware/boards/`` under QEMU.

The board ports build two images each (``make firmware-boards``, see
``docs/boards.md``) and this module starts them under ``qemu-system-arm``
with the settings measured to work:

* ``-icount shift=0``: every guest instruction is 1 ns of virtual time, so
  the board's timer counts instructions deterministically;
* the board's UART on a TCP socket (``server=on,wait=on,nodelay=on``, port
  picked by QEMU): the guest does not start before the host connects, so no
  byte is lost, and ``nodelay`` avoids a ~40 ms stall per reply. The host
  then talks to the board with pyserial's ``socket://127.0.0.1:PORT`` URL,
  exactly as to a USB-serial device;
* semihosting (``-semihosting-config enable=on,target=native``) for the
  self-test images, whose exit status is QEMU's.

Main names:

* :data:`BOARDS` -- the supported boards.
* :func:`start_board` -- start a board, return ``(process, url)``.
* :func:`run_semihosted` -- run an image to completion, return its status
  and output.
* :func:`reset_board` -- a system reset through QEMU's QMP socket.
* :func:`qemu_argv` -- the command line, for docs and debugging.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import socket
import subprocess
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

QEMU = "qemu-system-arm"


@dataclass(frozen=True)
class Board:
    """One supported board: its QEMU machine and what it runs."""

    name: str
    machine: str
    cpu: str
    kinematics: str  # "f32" or "q": the device image's kinematics path
    flash_bytes: int
    ram_bytes: int
    tick_hz: int  # the benchmark/time-base clock


BOARDS: dict[str, Board] = {
    "mps2-an386": Board(
        "mps2-an386", "mps2-an386", "Cortex-M4F", "f32", 4 << 20, 4 << 20, 25_000_000
    ),
    "microbit": Board("microbit", "microbit", "Cortex-M0", "q", 256 << 10, 16 << 10, 16_000_000),
}

_WAITING = re.compile(r"waiting for connection on: disconnected:tcp:([0-9.]+):(\d+)")


def _board(name: str) -> Board:
    try:
        return BOARDS[name]
    except KeyError:
        raise ValueError(f"unknown board {name!r}; boards: {', '.join(BOARDS)}") from None


def repo_root() -> Path | None:
    """The checkout this module belongs to (``$AACMM_ROOT`` overrides); None
    for a pip-installed package (never the current directory)."""
    env = os.environ.get("AACMM_ROOT")
    if env:
        return Path(env)
    here = Path(__file__).resolve()
    for parent in here.parents:
        if (parent / "firmware" / "boards").is_dir():
            return parent
    return None


def default_image(board: str, image: str = "fw") -> Path:
    """``build/boards/<board>/<image>.elf`` of the checkout.

    Raises FileNotFoundError for a pip-installed package without $AACMM_ROOT.
    """
    _board(board)
    root = repo_root()
    if root is None:
        raise FileNotFoundError(
            "the board images are built in the aacmm source tree ('make firmware-boards'): "
            "set $AACMM_ROOT to that tree"
        )
    return root / "build" / "boards" / board / f"{image}.elf"


def qemu_argv(
    board: str,
    elf: str | os.PathLike[str],
    serial: str = "null",
    semihosting: bool = False,
    qemu: str = QEMU,
) -> list[str]:
    """The QEMU command line for ``elf`` on ``board`` with the UART on ``serial``."""
    b = _board(board)
    argv = [
        qemu,
        "-M",
        b.machine,
        "-nographic",
        "-monitor",
        "none",
        "-icount",
        "shift=0",
        "-kernel",
        str(elf),
        "-serial",
        serial,
    ]
    if semihosting:
        argv += ["-semihosting-config", "enable=on,target=native"]
    return argv


def _check_tools(qemu: str, elf: Path) -> None:
    if shutil.which(qemu) is None:
        raise FileNotFoundError(f"{qemu} not found (Debian: apt-get install qemu-system-arm)")
    if not elf.is_file():
        raise FileNotFoundError(f"{elf} not found (make firmware-boards)")


def start_board(
    board: str,
    elf: str | os.PathLike[str] | None = None,
    *,
    qemu: str = QEMU,
    timeout: float = 10.0,
    log: list[str] | None = None,
    qmp: str | os.PathLike[str] | None = None,
    extra: Sequence[str] = (),
) -> tuple[subprocess.Popen[bytes], str]:
    """Start ``elf`` (default: the board's device image) under QEMU.

    Returns the process and the pyserial URL of the board's UART
    (``socket://127.0.0.1:PORT``). The guest starts when the first client
    connects; connect exactly once (QEMU accepts one client). QEMU's own
    messages are appended to ``log`` if given. ``qmp`` opens QEMU's machine
    protocol on that Unix socket path (see :func:`reset_board`); ``extra``
    goes on QEMU's command line as given (tests use ``-device loader,...``).
    Stop the board with ``process.kill()`` (or :func:`stop_board`).

    Raises FileNotFoundError (no QEMU, no image), ValueError (unknown board),
    TimeoutError / RuntimeError (QEMU did not come up).
    """
    path = Path(elf) if elf is not None else default_image(board)
    _check_tools(qemu, path)
    argv = qemu_argv(board, path, "tcp:127.0.0.1:0,server=on,wait=on,nodelay=on", qemu=qemu)
    if qmp is not None:
        argv += ["-qmp", f"unix:{qmp},server=on,wait=off"]
    argv += list(extra)
    proc = subprocess.Popen(
        argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    assert proc.stderr is not None
    found: list[str] = []
    lines: list[str] = log if log is not None else []
    ready = threading.Event()

    def pump() -> None:
        assert proc.stderr is not None
        for raw in proc.stderr:
            line = raw.decode(errors="replace").rstrip()
            lines.append(line)
            m = _WAITING.search(line)
            if m and not found:
                found.append(f"socket://{m.group(1)}:{m.group(2)}")
                ready.set()
        ready.set()

    threading.Thread(target=pump, name=f"qemu-{board}-stderr", daemon=True).start()
    deadline = time.monotonic() + timeout
    while not ready.wait(0.05):
        if time.monotonic() > deadline:
            proc.kill()
            proc.wait()
            raise TimeoutError(f"QEMU for {board} did not open its UART socket in {timeout} s")
    if not found:
        proc.wait()
        raise RuntimeError(f"QEMU for {board} exited ({proc.returncode}): " + " | ".join(lines))
    return proc, found[0]


def reset_board(qmp: str | os.PathLike[str], timeout: float = 5.0) -> None:
    """Reset a board started with ``qmp=``: QEMU's ``system_reset``, the same
    system reset request the guest makes with SYSRESETREQ (RAM and flash kept,
    every device and the CPU reset, the image's ROM contents reloaded).

    Raises OSError (no QEMU there), RuntimeError (QEMU refused).
    """
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.settimeout(timeout)
        s.connect(str(qmp))
        f = s.makefile("rwb")

        def reply() -> dict[str, object]:
            while True:
                line = f.readline()
                if not line:
                    raise RuntimeError("QMP connection closed")
                msg = json.loads(line)
                if "return" in msg or "error" in msg:
                    return dict(msg)

        json.loads(f.readline())  # greeting
        for cmd in ("qmp_capabilities", "system_reset"):
            f.write(json.dumps({"execute": cmd}).encode() + b"\n")
            f.flush()
            r = reply()
            if "error" in r:
                raise RuntimeError(f"QMP {cmd}: {r['error']}")


def stop_board(proc: subprocess.Popen[bytes], timeout: float = 5.0) -> None:
    """Terminate a board started by :func:`start_board` and reap it."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def run_semihosted(
    board: str, elf: str | os.PathLike[str], *, qemu: str = QEMU, timeout: float = 60.0
) -> tuple[int, str]:
    """Run a semihosting image to its exit: ``(exit status, its output)``.

    The exit status is the image's (``exit(n)`` through semihosting); a run
    that outlasts ``timeout`` seconds is killed and reported as status -1.
    """
    path = Path(elf)
    _check_tools(qemu, path)
    argv = qemu_argv(board, path, "null", semihosting=True, qemu=qemu)
    try:
        r = subprocess.run(
            argv, stdin=subprocess.DEVNULL, capture_output=True, timeout=timeout, check=False
        )
    except subprocess.TimeoutExpired as exc:
        out = (exc.stdout or b"").decode(errors="replace")
        return -1, out + f"\n(killed after {timeout} s)\n"
    return r.returncode, r.stdout.decode(errors="replace") + r.stderr.decode(errors="replace")


def main(argv: list[str] | None = None) -> int:
    """``python -m aacmm.boards BOARD [ELF]``: start a board, print its URL, run until Ctrl-C."""
    import argparse
    import signal
    import sys

    ap = argparse.ArgumentParser(
        prog="python -m aacmm.boards", description="Run a board's device image under QEMU."
    )
    ap.add_argument("board", choices=sorted(BOARDS))
    ap.add_argument("elf", nargs="?", help="image (default build/boards/BOARD/fw.elf)")
    args = ap.parse_args(argv)
    try:
        proc, url = start_board(args.board, args.elf)
    except (OSError, RuntimeError, ValueError) as exc:
        print(f"aacmm.boards: {exc}", file=sys.stderr)
        return 1
    print(
        f"{args.board}: {url}  (the board starts when a client connects, e.g. "
        f"aacmm info --port {url}; Ctrl-C stops it)",
        flush=True,
    )
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))  # stop QEMU on kill too
    try:
        return proc.wait()
    except KeyboardInterrupt:
        return 0
    finally:
        stop_board(proc)


if __name__ == "__main__":
    raise SystemExit(main())
