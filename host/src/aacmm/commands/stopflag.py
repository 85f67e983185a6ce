"""StopFlag: SIGINT and SIGTERM turned into a flag that a command's loop polls."""

from __future__ import annotations

import signal
import threading
from types import FrameType
from typing import Any


class StopFlag:
    """Set by SIGINT/SIGTERM; a second Ctrl-C raises KeyboardInterrupt at once.

    While :attr:`immediate` (the command has not started its loop yet, e.g. it is
    still opening the device) a signal raises KeyboardInterrupt at once: there is
    nothing to finish, and a wait for a device that does not answer must not
    outlast Ctrl-C.
    """

    def __init__(self, immediate: bool = False) -> None:
        self.event = threading.Event()
        self.signal: int | None = None
        self.immediate = immediate
        self._old: dict[int, Any] = {}

    def _handler(self, signum: int, frame: FrameType | None) -> None:
        if self.immediate or (self.event.is_set() and signum == signal.SIGINT):
            raise KeyboardInterrupt
        self.signal = signum
        self.event.set()

    def install(self) -> None:
        for s in (signal.SIGINT, signal.SIGTERM):
            self._old[s] = signal.signal(s, self._handler)

    def restore(self) -> None:
        for s, h in self._old.items():
            signal.signal(s, h)
        self._old.clear()

    @property
    def set(self) -> bool:
        return self.event.is_set()
