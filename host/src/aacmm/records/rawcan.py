"""Raw CAN frames of a node recorded to .blf/.asc/.log (``aacmm log --raw``).

Errors: :class:`aacmm.errors.InitError` (the interface cannot be opened),
:class:`aacmm.fileio.OutputExistsError` / :class:`aacmm.fileio.OutputFileError`
(the file exists or cannot be written).
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path
from typing import Any

from aacmm.errors import InitError
from aacmm.fileio import OutputExistsError, OutputFileError

RAW_SUFFIXES = (".blf", ".asc", ".log")


class RawCanRecorder:
    """Records the node's CAN frames (both directions) with python-can's ``Logger``.

    A second socket on the same interface sees the frames the client sends
    (SocketCAN loopback) and those the device sends; timestamps are the
    kernel's. The format follows the suffix: ``.blf`` (Vector BLF), ``.asc``
    (Vector ASCII), ``.log`` (can-utils candump -l).
    """

    def __init__(self, path: Path, kind: str, channel: str, node: int, force: bool) -> None:
        import can

        from aacmm.protocol.can import ID_ISOTP_REQUEST
        from aacmm.transport.canbus import CanTransport, enlarge_rcvbuf

        if path.exists() and not force:
            raise OutputExistsError(f"{path} exists (use --force to overwrite)")
        filters = [
            *CanTransport.filters(node),
            {"can_id": ID_ISOTP_REQUEST + node, "can_mask": 0x7FF, "extended": False},
        ]
        try:
            self.bus = can.Bus(
                interface="socketcan" if kind == "socketcan" else "virtual",
                channel=channel,
                can_filters=filters,
                receive_own_messages=False,
            )
        except (can.CanError, OSError, ValueError, ImportError) as exc:
            raise InitError(f"cannot open CAN interface {channel} for --raw: {exc}") from None
        enlarge_rcvbuf(self.bus)
        try:
            self.logger: Any = can.Logger(str(path))
        except (OSError, ValueError) as exc:
            self.bus.shutdown()
            raise OutputFileError(f"cannot write {path}: {exc}") from None
        self._last_rx = time.monotonic()
        self.frames = 0
        self.notifier = can.Notifier(self.bus, [self.logger, self._seen], timeout=0.1)
        self.path = path

    def _seen(self, msg: Any) -> None:  # notifier thread
        self._last_rx = time.monotonic()
        self.frames += 1

    def stop(self, quiet_s: float = 0.3, max_wait_s: float = 3.0) -> None:
        """Let the recorder catch up (until the bus is quiet for ``quiet_s``), then close."""
        end = time.monotonic() + max_wait_s
        while time.monotonic() < end and time.monotonic() - self._last_rx < quiet_s:
            time.sleep(0.05)
        with contextlib.suppress(Exception):
            self.notifier.stop()
        with contextlib.suppress(Exception):
            self.logger.stop()
        with contextlib.suppress(Exception):
            self.bus.shutdown()
