"""Start and stop the POSIX simulator ``aacmm-sim`` for the loopback tests.

The binary is ``build/sim/aacmm-sim`` (``make sim``) or ``$AACMM_SIM``. Its
stdout contract: ``aacmm-sim: serial /dev/pts/N`` (with ``--serial``),
``aacmm-sim: can IFACE node N`` (with ``--can``), then ``aacmm-sim: ready``;
exit status 0 on SIGTERM/SIGINT.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import threading
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SIM_BIN = Path(os.environ.get("AACMM_SIM", REPO / "build" / "sim" / "aacmm-sim"))

_SERIAL = re.compile(r"^aacmm-sim: serial (\S+)$")
_CAN = re.compile(r"^aacmm-sim: can (\S+) node (\d+)$")


class SimError(RuntimeError):
    pass


class Sim:
    """One simulator process; stop it with :meth:`stop` (or use it as a context manager)."""

    def __init__(self, *args: str, ready_timeout: float = 15.0) -> None:
        if not SIM_BIN.is_file():
            raise SimError(f"simulator {SIM_BIN} not built (run `make sim`)")
        self.args = [str(SIM_BIN), *args]
        self.serial_path: str | None = None
        self.can_iface: str | None = None
        self.can_node: int | None = None
        self.stdout_lines: list[str] = []
        self.stderr_lines: list[str] = []
        self._ready = threading.Event()
        self.proc = subprocess.Popen(
            self.args,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            bufsize=1,
        )
        self._threads = [
            threading.Thread(target=self._read_stdout, daemon=True),
            threading.Thread(target=self._read_stderr, daemon=True),
        ]
        for t in self._threads:
            t.start()
        if not self._ready.wait(ready_timeout) or self.proc.poll() is not None:
            self.kill()
            raise SimError(
                f"{' '.join(self.args)} did not get ready (exit {self.proc.returncode}):\n"
                + "\n".join(self.stdout_lines + self.stderr_lines)
            )

    def _read_stdout(self) -> None:
        assert self.proc.stdout is not None
        for raw in self.proc.stdout:  # keeps draining so the simulator never blocks
            line = raw.rstrip("\n")
            self.stdout_lines.append(line)
            if m := _SERIAL.match(line):
                self.serial_path = m.group(1)
            elif m := _CAN.match(line):
                self.can_iface, self.can_node = m.group(1), int(m.group(2))
            elif line == "aacmm-sim: ready":
                self._ready.set()
        self._ready.set()

    def _read_stderr(self) -> None:
        assert self.proc.stderr is not None
        for raw in self.proc.stderr:
            self.stderr_lines.append(raw.rstrip("\n"))

    @property
    def serial_url(self) -> str:
        if self.serial_path is None:
            raise SimError("simulator has no serial link")
        return f"serial://{self.serial_path}"

    def can_url(self, scheme: str = "socketcan") -> str:
        if self.can_iface is None:
            raise SimError("simulator has no CAN link")
        return f"{scheme}://{self.can_iface}?node={self.can_node}"

    def stop(self, timeout: float = 10.0) -> int:
        """SIGTERM, wait, return the exit status (kills it if it hangs)."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.kill()
                raise SimError("simulator ignored SIGTERM") from None
        for t in self._threads:
            t.join(2.0)
        return self.proc.returncode

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)

    def __enter__(self) -> Sim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.kill() if exc[0] is not None else self.stop()
