"""Run an `aacmm` command under an address-space limit, interrupt it like Ctrl-C.

The bounded-memory regression tests of issue 15.4 (`mc -n 10^12`,
`uncertainty --trials 10^8`) start the command with RLIMIT_AS, check it is
still running after a while (it did not die of MemoryError), send SIGINT and
return the exit status, stderr and the seconds it took to stop.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import time

AACMM = [sys.executable, "-m", "aacmm.cli"]


def run_then_interrupt(
    args: list[str], after_s: float, limit_bytes: int = 2 << 30
) -> tuple[int, str, float]:
    """(exit status, stderr, seconds from SIGINT to exit) of `aacmm ARGS`."""

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit_bytes, limit_bytes))
        # Ctrl-C reaches a command started from a terminal with SIGINT's default
        # action; a launcher that ignores it (a background job of a script,
        # `nohup ... &`) passes SIG_IGN on, and Python then installs no
        # KeyboardInterrupt handler: the command would never see the signal.
        signal.signal(signal.SIGINT, signal.SIG_DFL)

    proc = subprocess.Popen(
        [*AACMM, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=limit,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
    )
    time.sleep(after_s)
    if proc.poll() is not None:
        _, err = proc.communicate()
        raise AssertionError(f"ended before the interrupt, status {proc.returncode}: {err}")
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    return proc.returncode, err, time.monotonic() - t0
