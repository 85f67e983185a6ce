"""Client of the simulator's control channel (``aacmm-sim --control FD``).

The channel is a connected stream socket (one end inherited by the
simulator). The host sets the encoder counts (4 to 7), the link temperatures and the
button levels; the
simulator says when a link's stream starts or stops (a capture client is
listening) and answers ``sync`` barriers. Protocol: docs/simulator.md,
"Control channel" (and ``firmware/ports/posix/sim_control.h``).

Typical use::

    chan, child_fd = ControlChannel.pair()
    sim = SimProcess(["--serial", "pty", "--control", str(child_fd)], pass_fds=[child_fd])
    chan.child_started()                  # closes our copy of the child's end
    chan.hello()                          # "control 1"
    chan.set_counts(counts)
    chan.press(0)                         # button 0 down, seen by the device
    chan.release(0)

Errors: :class:`ControlError` (the simulator refused a command, went away,
or did not answer in time).
"""

from __future__ import annotations

import contextlib
import itertools
import math
import socket
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

from aacmm.errors import AacmmError

PROTOCOL_VERSION: Final = 1
LINKS: Final = ("serial", "can")
DEFAULT_TIMEOUT_S: Final = 10.0


class ControlError(AacmmError):
    """The control channel failed: refused command, simulator gone, or no answer."""


@dataclass(frozen=True)
class StreamState:
    """A link's stream as last reported by the simulator."""

    active: bool = False
    rate_hz: int = 0
    content: int = 0
    starts: int = 0  #: "stream LINK on" events seen (a restart counts again)


class ControlChannel:
    """The host end of ``aacmm-sim --control``.

    Thread-safe: one reader thread parses the simulator's lines; any thread
    may send commands (each line goes out in one ``sendall``).
    """

    def __init__(self, sock: socket.socket, child_fd: int | None = None) -> None:
        self._sock = sock
        self._child_fd = child_fd
        self._lock = threading.Lock()
        self._cond = threading.Condition(self._lock)
        self._streams: dict[str, StreamState] = {link: StreamState() for link in LINKS}
        self._syncs: set[str] = set()
        self._errors: list[str] = []
        self._version: int | None = None
        self._closed = False
        self._tokens = itertools.count(1)
        self._buttons = 0
        self._reader = threading.Thread(target=self._read, name="aacmm-sim-control", daemon=True)
        self._reader.start()

    @classmethod
    def pair(cls) -> tuple[ControlChannel, int]:
        """A new channel and the descriptor to hand to the simulator (inheritable)."""
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
        theirs.set_inheritable(True)
        fd = theirs.detach()
        return cls(ours, child_fd=fd), fd

    def child_started(self) -> None:
        """Close our copy of the child's end (after the simulator was started)."""
        if self._child_fd is not None:
            with contextlib.suppress(OSError):
                socket.close(self._child_fd)
            self._child_fd = None

    # ------------------------------------------------------------------ reading

    def _read(self) -> None:
        buf = b""
        try:
            while True:
                chunk = self._sock.recv(4096)
                if not chunk:
                    break
                buf += chunk
                while b"\n" in buf:
                    line, buf = buf.split(b"\n", 1)
                    self._line(line.decode("ascii", "replace").strip())
        except OSError:
            pass
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    def _line(self, line: str) -> None:
        words = line.split()
        with self._cond:
            if len(words) == 2 and words[0] == "control" and words[1].isdigit():
                self._version = int(words[1])
            elif len(words) >= 3 and words[0] == "stream" and words[1] in LINKS:
                old = self._streams[words[1]]
                if words[2] == "on" and len(words) == 5:
                    self._streams[words[1]] = StreamState(
                        True, int(words[3]), int(words[4]), old.starts + 1
                    )
                elif words[2] == "off":
                    self._streams[words[1]] = StreamState(
                        False, old.rate_hz, old.content, old.starts
                    )
            elif len(words) == 2 and words[0] == "sync":
                self._syncs.add(words[1])
            elif words and words[0] == "error":
                self._errors.append(line[len("error") :].strip())
            self._cond.notify_all()

    def _raise_errors(self) -> None:
        if self._errors:
            msg = self._errors[0]
            self._errors.clear()
            raise ControlError(f"the simulator refused a control command: {msg}")

    # ------------------------------------------------------------------ sending

    def send_raw(self, line: str) -> None:
        """Send one protocol line as it is (no wait; :meth:`sync` reports a refusal)."""
        self._send(line)

    def _send(self, line: str) -> None:
        try:
            self._sock.sendall(line.encode("ascii") + b"\n")
        except OSError as exc:
            raise ControlError(f"the simulator's control channel is gone: {exc}") from None

    def hello(self, timeout: float = DEFAULT_TIMEOUT_S) -> int:
        """Wait for the simulator's ``control N`` line; return N.

        Raises:
            ControlError: no such line in time, or a version this client does not speak.
        """
        end = time.monotonic() + timeout
        with self._cond:
            while self._version is None and not self._closed:
                left = end - time.monotonic()
                if left <= 0:
                    break
                self._cond.wait(left)
            version = self._version
        if version is None:
            raise ControlError("the simulator did not open its control channel")
        if version != PROTOCOL_VERSION:
            raise ControlError(f"control channel version {version}, expected {PROTOCOL_VERSION}")
        return version

    def set_counts(self, counts: Sequence[int]) -> None:
        """The encoders read ``counts`` (one per joint of the device's arm model, 4 to 7
        values below the resolution) from now on. The simulator takes six or seven:
        fewer are sent with the missing joints reading 0 (the device reads its N)."""
        if not 4 <= len(counts) <= 7:
            raise ValueError(f"4 to 7 counts expected, got {len(counts)}")
        values = [int(c) for c in counts] + [0] * max(0, 6 - len(counts))
        self._send("counts " + " ".join(str(c) for c in values))

    def set_temperatures(self, temps_c: Sequence[float | None]) -> None:
        """The link temperature sensors read ``temps_c`` (degC, one per link of the
        device's arm, or one for every link; None: that link's sensor does not
        answer) from now on: ``temps T1 .. Tn`` with 2 decimals (``-`` for None), six
        or seven values (an arm of fewer links: the others read the first link's
        value). No reply; :meth:`sync` orders it and reports a refusal."""
        values = list(temps_c)
        if not 1 <= len(values) <= 7:
            raise ValueError(f"1 to 7 link temperatures expected, got {len(values)}")
        for t in values:
            if t is not None and not (math.isfinite(t) and -40.0 <= t <= 85.0):
                raise ValueError(f"link temperature {t!r} outside -40 .. 85 degC")
        if 1 < len(values) < 6:
            values += [values[0]] * (6 - len(values))
        words = ["-" if t is None else f"{t:.2f}" for t in values]
        self._send("temps " + " ".join(words))

    def set_buttons(self, mask: int, timeout: float = DEFAULT_TIMEOUT_S) -> None:
        """Set the button levels (bit i = button i held) and wait until the device saw them."""
        if not 0 <= mask <= 3:
            raise ValueError(f"button mask must be 0..3, got {mask}")
        self._send(f"buttons {mask}")
        self._buttons = mask
        self.sync(timeout)

    def press(self, button: int = 0, timeout: float = DEFAULT_TIMEOUT_S) -> None:
        """Press ``button`` (0 capture, 1 undo); its trigger carries the counts now set."""
        self.set_buttons(self._buttons | (1 << button), timeout)

    def release(self, button: int = 0, timeout: float = DEFAULT_TIMEOUT_S) -> None:
        """Release ``button``."""
        self.set_buttons(self._buttons & ~(1 << button), timeout)

    def sync(self, timeout: float = DEFAULT_TIMEOUT_S) -> None:
        """Wait until the device has polled after every command sent before.

        Raises:
            ControlError: a command was refused, the simulator went away, or no answer.
        """
        token = f"t{next(self._tokens)}"
        self._send(f"sync {token}")
        end = time.monotonic() + timeout
        with self._cond:
            while token not in self._syncs:
                self._raise_errors()
                left = end - time.monotonic()
                if self._closed or left <= 0:
                    what = "went away" if self._closed else f"did not answer within {timeout:g} s"
                    raise ControlError(f"the simulator {what} (control sync)")
                self._cond.wait(left)
            self._syncs.discard(token)
            self._raise_errors()

    # ------------------------------------------------------------------ streams

    def streams(self) -> dict[str, StreamState]:
        """The stream of each link as last reported."""
        with self._cond:
            return dict(self._streams)

    def starts(self) -> int:
        """Stream starts seen on all links together."""
        with self._cond:
            return sum(s.starts for s in self._streams.values())

    def wait_stream(
        self, active: bool = True, after_starts: int | None = None, timeout: float | None = None
    ) -> bool:
        """Wait until some link streams (``active``) or none does (``not active``).

        With ``after_starts``, wait for a stream start beyond that many (a new
        start or a restart). Returns False on timeout or when the simulator is
        gone.
        """
        end = None if timeout is None else time.monotonic() + timeout

        def done() -> bool:
            streams = self._streams.values()
            if after_starts is not None:
                return sum(s.starts for s in streams) > after_starts
            return any(s.active for s in streams) == active

        with self._cond:
            while not done():
                if self._closed:
                    return False
                left = None if end is None else end - time.monotonic()
                if left is not None and left <= 0:
                    return False
                self._cond.wait(left if left is None else min(left, 1.0))
            return True

    @property
    def closed(self) -> bool:
        """The simulator closed its end (it ended)."""
        with self._cond:
            return self._closed

    def close(self) -> None:
        """Close the channel (the simulator then shuts down, as on SIGTERM)."""
        self.child_started()
        with contextlib.suppress(OSError):
            self._sock.shutdown(socket.SHUT_RDWR)
        with contextlib.suppress(OSError):
            self._sock.close()
        self._reader.join(2.0)
