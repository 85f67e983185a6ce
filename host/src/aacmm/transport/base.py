"""The transport interface the client talks through.

A transport moves protocol message bodies between the host and one device and
turns whatever arrives into decoded :class:`~aacmm.protocol.Message` objects,
delivered from its own reader thread to a :class:`Sink` (the client). It knows
nothing about requests, retries or sequence numbers; that is the client's job.
"""

from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Protocol

from aacmm.errors import FrameError, OperationError
from aacmm.protocol import Message


class Sink(Protocol):
    """Receiver of what a transport reads (called from the transport's threads)."""

    def on_message(self, msg: Message) -> None:
        """A decoded message arrived."""

    def on_frame_error(self, err: FrameError) -> None:
        """Bytes or frames arrived that are not a valid message (already dropped)."""

    def on_link_lost(self, err: BaseException) -> None:
        """The link failed for good (port closed, bus down); nothing more will arrive."""


@dataclass
class TransportStats:
    """Counters kept by every transport (never reset)."""

    messages_rx: int = 0
    """Decoded messages delivered to the sink."""
    messages_tx: int = 0
    """Message bodies sent."""
    frame_errors: int = 0
    """Frames or messages dropped as invalid (CRC, stuffing, length, codec)."""
    bytes_rx: int = 0
    """Raw bytes (serial) or CAN frames (CAN) received."""


class _NullSink:
    def on_message(self, msg: Message) -> None:
        pass

    def on_frame_error(self, err: FrameError) -> None:
        pass

    def on_link_lost(self, err: BaseException) -> None:
        pass


class Transport(ABC):
    """Base class of the transports.

    Life cycle: construct (opens the port or bus, raises
    :class:`~aacmm.errors.InitError`), :meth:`start` with a sink (starts the
    reader), :meth:`send` any number of times, :meth:`close` (idempotent).
    Usable as a context manager.
    """

    #: Human-readable description, e.g. ``"serial /dev/pts/3"``.
    description: str = "transport"

    def __init__(self) -> None:
        self.stats = TransportStats()
        self._sink: Sink = _NullSink()
        self._closed = threading.Event()
        self._started = False

    @property
    def closed(self) -> bool:
        """True once :meth:`close` was called or the link was lost."""
        return self._closed.is_set()

    def start(self, sink: Sink) -> None:
        """Start delivering received messages to ``sink`` (once).

        Raises:
            OperationError: already started or closed.
        """
        if self._started:
            raise OperationError(f"{self.description}: already started")
        if self.closed:
            raise OperationError(f"{self.description}: closed")
        self._sink = sink
        self._started = True
        self._start_reader()

    def _check_open(self) -> None:
        if self.closed:
            raise OperationError(f"{self.description}: closed")

    def _deliver(self, msg: Message) -> None:
        self.stats.messages_rx += 1
        self._sink.on_message(msg)

    def _frame_error(self, err: FrameError) -> None:
        self.stats.frame_errors += 1
        self._sink.on_frame_error(err)

    def _link_lost(self, err: BaseException) -> None:
        if not self._closed.is_set():
            self._closed.set()
            self._sink.on_link_lost(err)

    @abstractmethod
    def _start_reader(self) -> None:
        """Start the reader thread(s)."""

    @abstractmethod
    def send(self, body: bytes) -> None:
        """Send one message body (3..512 bytes).

        Raises:
            OperationError: closed or I/O failure.
            DeviceTimeoutError: the device did not take the data in time.
        """

    @abstractmethod
    def close(self) -> None:
        """Stop the reader and release the port or bus (idempotent)."""

    def __enter__(self) -> Transport:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
