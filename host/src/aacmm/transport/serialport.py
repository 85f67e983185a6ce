"""Serial transport: protocol frames over anything pyserial opens.

The port is opened with :func:`serial.serial_for_url`, so a device path
(``/dev/ttyACM0``, a pseudo-terminal ``/dev/pts/3``, ``COM3``) and pyserial's
URL handlers (``socket://host:port``, ``rfc2217://host:port``, ``loop://``,
``spy://...``) all work. A reader thread feeds the received bytes to the
resynchronising :class:`~aacmm.protocol.Deframer`; each good frame is decoded
and handed to the sink, bad ones are counted and reported and reception goes
on at the next delimiter.

The port is opened exclusively (pyserial's ``exclusive=True``: ``flock``
``LOCK_EX | LOCK_NB`` on a device path), so a second client -- another
process or another connection in this one, through the API or the CLI alike
-- gets :class:`~aacmm.errors.PortBusyError` at once instead of stealing the
first one's frames. The lock goes with the port when it is closed (or the
process ends, even by ``kill -9``).
"""

from __future__ import annotations

import errno
import os
import select
import socket
import threading
import time
from typing import Any

import serial
from serial.urlhandler import protocol_socket

from aacmm.errors import (
    DeviceTimeoutError,
    FrameError,
    InitError,
    OperationError,
    PortBusyError,
)
from aacmm.protocol import Deframer, decode_message, encode_frame
from aacmm.transport.base import Transport

DEFAULT_BAUDRATE = 921600
_READ_POLL_S = 0.05
_MAX_EMPTY_READS = 20
_COALESCE_BYTES = 1024
_COALESCE_S = 0.003


class SerialTransport(Transport):
    """Frames over a serial port or pyserial URL.

    Args:
        url: device path or pyserial URL (see the module docstring).
        baudrate: line rate for real UARTs (ignored by ptys and sockets).
        write_timeout: seconds a write may block before
            :class:`~aacmm.errors.DeviceTimeoutError`.

    Raises:
        PortBusyError: another process or connection has the port open.
        InitError: the port cannot be opened or configured.
        ValueError: empty URL or non-positive baud rate.
    """

    def __init__(
        self, url: str, baudrate: int = DEFAULT_BAUDRATE, write_timeout: float = 2.0
    ) -> None:
        super().__init__()
        if not url:
            raise ValueError("empty serial port")
        if baudrate <= 0:
            raise ValueError(f"baud rate must be positive, got {baudrate}")
        self.url = url
        self.description = f"serial {url}"
        self.deframer = Deframer()
        self.spurious_wakeups = 0
        """Reads that found no data after select() reported some (tolerated)."""
        self._write_lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        try:
            self._port: Any = serial.serial_for_url(
                url,
                baudrate=baudrate,
                timeout=_READ_POLL_S,
                write_timeout=write_timeout,
                exclusive=True,
            )
        except (serial.SerialException, OSError, ValueError) as exc:
            if getattr(exc, "errno", None) in (errno.EWOULDBLOCK, errno.EAGAIN):
                raise PortBusyError(
                    f"serial port {url} is busy: another process or connection has it open"
                ) from None
            raise InitError(f"cannot open serial port {url}: {exc}") from exc
        # A plain device path or pty (not a URL handler such as spy://, which
        # must see every read): read its descriptor directly, as for sockets
        # below; pyserial's read() costs a select(), an ioctl and its timeout
        # bookkeeping per call on top (bench-view: view.client_baseline).
        fd = getattr(self._port, "fd", None)
        plain = type(self._port) is serial.Serial and isinstance(fd, int)
        self._fd: int | None = fd if plain else None
        sock = getattr(self._port, "_socket", None)
        self._socket: socket.socket | None = (
            sock
            if isinstance(self._port, protocol_socket.Serial) and isinstance(sock, socket.socket)
            else None
        )

    # ------------------------------------------------------------ reading

    def _start_reader(self) -> None:
        self._thread = threading.Thread(
            target=self._reader, name=f"aacmm-serial-rx {self.url}", daemon=True
        )
        self._thread.start()

    def _errors(self) -> int:
        s = self.deframer.stats
        return s.crc_errors + s.cobs_errors + s.oversize + s.runts

    def _read_chunk(self) -> bytes:
        """Whatever has arrived (waits up to the poll interval), possibly nothing."""
        port = self._port
        sock = self._socket
        fd = self._fd
        if fd is not None:
            readable, _, _ = select.select([fd], [], [], _READ_POLL_S)
            if not readable:
                return b""
            try:
                data = os.read(fd, 65536)  # the descriptor is non-blocking (pyserial opens it so)
            except BlockingIOError:
                return b""
            except OSError as exc:
                raise serial.SerialException(f"read failed: {exc}") from exc
            if not data:  # pyserial's words, so the reader's pty rule below applies
                raise serial.SerialException(
                    "device reports readiness to read but returned no data "
                    "(device disconnected or multiple access on port?)"
                )
            return data
        if sock is None:
            return bytes(port.read(max(1, port.in_waiting)))
        # pyserial's socket:// reads one byte per select() (its in_waiting is
        # 0 or 1); take everything the socket holds instead.
        ready, _, _ = select.select([sock], [], [], _READ_POLL_S)
        if not ready:
            return b""
        data = sock.recv(65536)
        if not data:
            raise serial.SerialException("socket disconnected")
        return bytes(data)

    def _reader(self) -> None:
        empty_reads = 0
        while not self._stop.is_set():
            try:
                data = self._read_chunk()
            except serial.SerialException as exc:
                # pyserial reads a tty with VMIN=0 after select(); on a Linux
                # pty, select() now and then reports input the read then does
                # not get ("readiness to read but returned no data"). Only a
                # run of these means the other side hung up.
                if "returned no data" in str(exc) and empty_reads < _MAX_EMPTY_READS:
                    empty_reads += 1
                    self.spurious_wakeups += 1
                    time.sleep(0.0005 * empty_reads)
                    continue
                if not self._stop.is_set():
                    self._link_lost(OperationError(f"{self.description}: {exc}"))
                return
            except (OSError, TypeError, AttributeError, ValueError) as exc:
                # TypeError/AttributeError/ValueError: pyserial internals or a
                # socket after a close from another thread.
                if not self._stop.is_set():
                    self._link_lost(OperationError(f"{self.description}: {exc}"))
                return
            if not data:
                continue
            empty_reads = 0
            self.feed(bytes(data))
            if len(data) < _COALESCE_BYTES:
                # A 1 kHz stream arrives a frame (often half a frame) at a
                # time: reading each piece as it lands costs a wake-up, a
                # read and a deframer call per piece, most of the client's
                # CPU. Waiting a few ms lets the pieces pile up into one read
                # (bench-view: view.client_baseline); what arrived is already
                # delivered, so a reply is never held back by the wait.
                time.sleep(_COALESCE_S)

    def feed(self, data: bytes) -> None:
        """Process received bytes as the reader thread does (also for tests)."""
        self.stats.bytes_rx += len(data)
        before = self._errors()
        bodies = self.deframer.feed(data)
        new_errors = self._errors() - before
        for _ in range(new_errors):
            err = self.deframer.last_error or FrameError("bad frame", -6)
            self._frame_error(err)
        for body in bodies:
            try:
                msg = decode_message(body)
            except FrameError as exc:
                self._frame_error(exc)
                continue
            self._deliver(msg)

    # ------------------------------------------------------------ writing

    def send(self, body: bytes) -> None:
        self.write_raw(encode_frame(body))
        self.stats.messages_tx += 1

    def write_raw(self, data: bytes) -> None:
        """Write raw bytes to the line (diagnostics, fault injection in tests).

        Raises:
            OperationError: closed or I/O failure.
            DeviceTimeoutError: the write blocked longer than ``write_timeout``.
        """
        self._check_open()
        with self._write_lock:
            try:
                self._port.write(data)
            except serial.SerialTimeoutException as exc:
                raise DeviceTimeoutError(f"{self.description}: write timed out") from exc
            except (serial.SerialException, OSError, TypeError, AttributeError) as exc:
                raise OperationError(f"{self.description}: write failed: {exc}") from exc

    def close(self) -> None:
        self._stop.set()
        self._closed.set()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=2.0)
        with self._write_lock:
            try:
                self._port.close()
            except Exception:  # closing must not raise
                pass
