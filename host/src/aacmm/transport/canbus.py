"""CAN transports: SocketCAN (python-can ``socketcan``) and python-can's in-process ``virtual`` bus.

Layout (``firmware/include/aacmm/proto_can.h``, ``aacmm/data/aacmm.dbc``):
plain samples arrive as six periodic 8-byte frames at 0x100+n .. 0x150+n,
probe button edges as a trigger frame at 0x160+n, and every other message
is a protocol message body carried by ISO-TP (``can-isotp``) on 0x600+n
(host to device) and 0x680+n (device to host).

One reader thread takes every frame off the bus as it arrives (so a flood of
sample frames never overruns the socket's receive queue while the host is
busy elsewhere) and routes it: sample frames to a small assembler, ISO-TP
frames to the user-space ISO-TP stack, which runs in its own threads. Samples
rebuilt from CAN frames carry the device's 32-bit timestamp extended to 64
bits across wrap-arounds, the low 16 status bits, and no Jacobian (a sample
with a Jacobian travels as an ISO-TP message instead).
"""

from __future__ import annotations

import errno
import queue
import select
import socket
import struct
import threading
from collections import OrderedDict
from typing import Any, Final

import can
import isotp
import isotp.tpsock

from aacmm.errors import DeviceTimeoutError, FrameError, InitError, OperationError
from aacmm.protocol import Message, MsgType, Sample, SampleStatus, Trigger, decode_message
from aacmm.protocol.can import (
    ID_ISOTP_RESPONSE,
    ID_POINT_Z,
    ID_SAMPLE_HEADER,
    ID_TRIGGER,
    ISOTP_PADDING,
    NODE_ID_MAX,
    SAMPLE_FRAME_IDS,
    isotp_address,
    isotp_params,
    sample_frame_ids,
)
from aacmm.protocol.status import Status
from aacmm.transport.base import Transport

_POLL_S: Final = 0.05
_RCVBUF_BYTES: Final = 8 << 20
_SO_RCVBUFFORCE: Final = 33  # Linux; lets root exceed net.core.rmem_max
_RECENT_SAMPLES: Final = 256
_TRIGGER_WAIT_SAMPLES: Final = 64

_HDR = struct.Struct("<II")
_PAIR_U = struct.Struct("<II")
_PAIR_I = struct.Struct("<ii")
_POINT_Z = struct.Struct("<iHBB")
_TRIG = struct.Struct("<IBBH")
_SEQUENCES: Final = {n: sample_frame_ids(n) for n in range(4, 8)}


def check_node(node_id: int) -> int:
    """Return ``node_id`` if it is a valid CAN node id (0..15), else raise ValueError."""
    if isinstance(node_id, bool) or not isinstance(node_id, int):
        raise ValueError(f"CAN node id must be an int, got {node_id!r}")
    if not 0 <= node_id <= NODE_ID_MAX:
        raise ValueError(f"CAN node id {node_id} outside 0..{NODE_ID_MAX}")
    return node_id


class SampleFrameDecoder:
    """Rebuilds samples and trigger events from one node's periodic frames.

    Decodes with :mod:`struct` (the layout of ``proto_can.h``), independently
    of the DBC, and is fast enough for 1 kHz streams. A sample whose frames
    are missing, out of order or whose SeqTag does not match its header is
    dropped and counted in :attr:`incomplete`. A sample flagged
    ``TRIGGER_EVENT`` is the sample of the trigger frame that follows it
    (docs/protocol.md 2.7): it becomes that TRIGGER_EVT, never a SAMPLE_EVT.
    A trigger frame naming no such sample takes the stream sample with its
    seq, as devices before that rule sent it.
    """

    def __init__(self, node_id: int) -> None:
        self.node_id = check_node(node_id)
        self.incomplete = 0
        self.bad_frames = 0
        self.triggers_unmatched = 0
        self._parts: list[bytes] = []
        self._ids: tuple[int, ...] = ()
        self._orphan = False
        self._ts_high = 0
        self._ts_last = -1
        self._recent: OrderedDict[int, Sample] = OrderedDict()
        self._edge: OrderedDict[int, Sample] = OrderedDict()  # trigger samples by seq
        self._pending: list[tuple[int, int, bool, int]] = []  # seq, button, pressed, age

    def _timestamp(self, low: int) -> int:
        if self._ts_last >= 0 and low < self._ts_last and self._ts_last - low > 1 << 31:
            self._ts_high += 1 << 32
        self._ts_last = low
        return self._ts_high | low

    def feed(self, arbitration_id: int, data: bytes) -> list[Message]:
        """Process one frame; return the messages it completes (SAMPLE_EVT, TRIGGER_EVT)."""
        base = arbitration_id - self.node_id
        if len(data) != 8:
            self.bad_frames += 1
            return []
        if base == ID_TRIGGER:
            return self._trigger(data)
        if base == ID_SAMPLE_HEADER:
            if self._parts:
                self.incomplete += 1
            self._parts = [data]
            self._ids = (base,)
            self._orphan = False
            return []
        if base not in SAMPLE_FRAME_IDS:
            return []
        ids = (*self._ids, base)
        if not self._parts or not any(q[: len(ids)] == ids for q in _SEQUENCES.values()):
            # A frame is missing: drop the sample, count it once.
            if self._parts or not self._orphan:
                self.incomplete += 1
            self._parts = []
            self._ids = ()
            self._orphan = True
            return []
        self._parts.append(data)
        self._ids = ids
        if base != ID_POINT_Z:
            return []
        parts, self._parts, self._ids = self._parts, [], ()
        return self._complete(parts, ids)

    def _complete(self, parts: list[bytes], ids: tuple[int, ...]) -> list[Message]:
        """A sample of N joints: header, (N + 1) // 2 count frames, PointXY, PointZ."""
        seq, ts_low = _HDR.unpack(parts[0])
        counts: tuple[int, ...] = ()
        for data in parts[1:-2]:
            counts += _PAIR_U.unpack(data)
        x, y = _PAIR_I.unpack(parts[-2])
        z, status, seq_tag, joints = _POINT_Z.unpack(parts[-1])
        if seq_tag != seq & 0xFF or _SEQUENCES.get(joints) != ids:
            self.incomplete += 1
            return []
        sample = Sample(
            seq=seq,
            timestamp_us=self._timestamp(ts_low),
            counts=counts[:joints],
            point_100nm=(x, y, z),
            status=status,
            params=4 * joints + 1,  # the frames carry no P: the smallest N-joint shape
        )
        if status & SampleStatus.TRIGGER_EVENT:
            self._edge[seq] = sample
            if len(self._edge) > _RECENT_SAMPLES:
                self._edge.popitem(last=False)
            return self._match_pending(seq, None)
        self._recent[seq] = sample
        if len(self._recent) > _RECENT_SAMPLES:
            self._recent.popitem(last=False)
        return self._match_pending(seq, Message(MsgType.SAMPLE_EVT, seq & 0xFF, sample))

    def _match_pending(self, seq: int, first: Message | None) -> list[Message]:
        """Trigger frames that waited for sample ``seq`` (after ``first``, if any)."""
        out = [] if first is None else [first]
        still: list[tuple[int, int, bool, int]] = []
        for t_seq, button, pressed, age in self._pending:
            sample = self._take(t_seq) if t_seq == seq else None
            if sample is not None:
                trig = Trigger(button, pressed, sample)
                out.append(Message(MsgType.TRIGGER_EVT, seq & 0xFF, trig))
            elif age + 1 < _TRIGGER_WAIT_SAMPLES:
                still.append((t_seq, button, pressed, age + 1))
            else:
                self.triggers_unmatched += 1
        self._pending = still
        return out

    def _take(self, seq: int) -> Sample | None:
        """The trigger sample numbered ``seq`` (used once), else the stream sample."""
        sample = self._edge.pop(seq, None)
        return sample if sample is not None else self._recent.get(seq)

    def _trigger(self, data: bytes) -> list[Message]:
        seq, button, pressed, _reserved = _TRIG.unpack(data)
        if pressed > 1:
            self.bad_frames += 1
            return []
        sample = self._take(seq)
        if sample is None:
            self._pending.append((seq, button, bool(pressed), 0))
            return []
        return [Message(MsgType.TRIGGER_EVT, seq & 0xFF, Trigger(button, bool(pressed), sample))]


class _IsoTp:
    """One ISO-TP back end: sends request bodies, yields response bodies."""

    #: True if the bus reader must hand it the device's ISO-TP frames.
    wants_frames = False

    def start(self) -> None:
        """Start (after the transport's sink is set)."""

    def on_frame(self, data: bytes) -> None:
        """A frame on the response id (user-space back end only)."""

    def send(self, body: bytes, timeout: float) -> None:
        raise NotImplementedError

    def recv(self, timeout: float) -> bytes | None:
        """One complete response body, or None after ``timeout`` s."""
        raise NotImplementedError

    def stop(self) -> None:
        """Stop (idempotent)."""


class _UserIsoTp(_IsoTp):
    """The ``can-isotp`` user-space stack, fed by the transport's bus reader."""

    wants_frames = True

    def __init__(self, owner: CanTransport, node_id: int, timeout_ms: int) -> None:
        self._owner = owner
        self._rx_id = ID_ISOTP_RESPONSE + node_id
        self._frames: queue.SimpleQueue[isotp.CanMessage] = queue.SimpleQueue()
        params = isotp_params(timeout_ms)
        params["blocking_send"] = True
        self._tp = isotp.TransportLayer(
            rxfn=self._rxfn,
            txfn=self._txfn,
            address=isotp_address(node_id),
            error_handler=self._error,
            params=params,
            read_timeout=_POLL_S,
        )
        self._started = False

    def _rxfn(self, timeout: float) -> isotp.CanMessage | None:
        try:
            return self._frames.get(timeout=timeout)
        except queue.Empty:
            return None

    def _txfn(self, msg: isotp.CanMessage) -> None:
        try:
            self._owner.send_frame(msg.arbitration_id, bytes(msg.data))
        except OperationError as exc:
            # Raising here would kill can-isotp's thread; report it and let
            # the transfer time out instead.
            self._owner._frame_error(FrameError(str(exc), int(Status.ERR_IO)))

    def _error(self, err: Exception) -> None:
        self._owner._frame_error(FrameError(f"ISO-TP: {err}", int(Status.ERR_FRAME)))

    def start(self) -> None:
        self._tp.start()
        self._started = True

    def on_frame(self, data: bytes) -> None:
        self._frames.put(isotp.CanMessage(arbitration_id=self._rx_id, data=data))

    def send(self, body: bytes, timeout: float) -> None:
        try:
            self._tp.send(body, send_timeout=timeout)
        except isotp.BlockingSendTimeout as exc:
            raise DeviceTimeoutError("ISO-TP send timed out (no flow control?)") from exc
        except isotp.BlockingSendFailure as exc:
            raise OperationError(f"ISO-TP send failed: {exc}") from exc
        except RuntimeError as exc:
            raise OperationError(f"ISO-TP: {exc}") from exc

    def recv(self, timeout: float) -> bytes | None:
        data = self._tp.recv(block=True, timeout=timeout)
        return None if data is None else bytes(data)

    def stop(self) -> None:
        if self._started:
            self._started = False
            self._tp.stop()


class _KernelIsoTp(_IsoTp):
    """A Linux kernel ISO-TP socket (``CAN_ISOTP``, module ``can-isotp``) via ``isotp.socket``.

    The kernel answers flow control and reassembles the device's multi-frame
    messages by itself, so long responses and Jacobian streams do not depend
    on how fast this process runs.
    """

    def __init__(self, channel: str, node_id: int, timeout_ms: int) -> None:
        try:
            isotp.tpsock.check_support()
            sock = isotp.socket()
            sock.set_opts(txpad=ISOTP_PADDING, frame_txtime=0)
            sock.set_fc_opts(bs=0, stmin=0, wftmax=10)
            sock.set_ll_opts(mtu=isotp.tpsock.LinkLayerProtocol.CAN, tx_dl=8)
            sock.bind(channel, isotp_address(node_id))
        except (OSError, NotImplementedError, RuntimeError) as exc:
            raise InitError(f"no kernel ISO-TP on {channel}: {exc}") from exc
        self._sock = sock
        self._raw: socket.socket = sock.real_socket()
        self._timeout_ms = timeout_ms

    def send(self, body: bytes, timeout: float) -> None:
        try:
            self._raw.send(body)
        except OSError as exc:
            if exc.errno in (errno.ECOMM, errno.ETIMEDOUT):
                raise DeviceTimeoutError(f"ISO-TP send failed: {exc}") from exc
            raise OperationError(f"ISO-TP send failed: {exc}") from exc

    def recv(self, timeout: float) -> bytes | None:
        ready, _, _ = select.select([self._raw], [], [], timeout)
        if not ready:
            return None
        try:
            return self._raw.recv(4095, socket.MSG_DONTWAIT)
        except BlockingIOError:
            return None
        except OSError as exc:
            if exc.errno in (errno.ENODEV, errno.ENETDOWN, errno.EBADF):
                raise
            # a reception error (sequence, timeout, ...) of one message
            raise FrameError(f"ISO-TP receive: {exc}", int(Status.ERR_FRAME)) from exc

    def stop(self) -> None:
        try:
            self._sock.close()
        except OSError:
            pass


_CAN_FRAME = struct.Struct("=IB3x8s")
_CAN_EFF_RTR_ERR = 0xE0000000


class CanTransport(Transport):
    """Protocol over a python-can bus: ISO-TP requests/responses plus periodic sample frames.

    Prefer the subclasses :class:`SocketCanTransport` and
    :class:`VirtualCanTransport`; this one takes an already open bus.

    Args:
        bus: an open python-can bus (shut down by :meth:`close` if ``own_bus``).
        node_id: the device's CAN node id, 0..15.
        isotp_timeout_ms: ISO-TP flow-control and consecutive-frame timeout.
        send_timeout: seconds a request may take to leave (flow control included).
        own_bus: shut the bus down on close.
        kernel_isotp: SocketCAN interface name to use a kernel ISO-TP socket
            on, instead of the user-space ``can-isotp`` stack.
    """

    def __init__(
        self,
        bus: can.BusABC,
        node_id: int = 0,
        isotp_timeout_ms: int = 1000,
        send_timeout: float = 2.0,
        own_bus: bool = True,
        kernel_isotp: str | None = None,
    ) -> None:
        super().__init__()
        self.node_id = check_node(node_id)
        self.bus = bus
        self.description = f"can {bus.channel_info} node {node_id}"
        self.samples = SampleFrameDecoder(node_id)
        self.frames_foreign = 0
        self._own_bus = own_bus
        self._send_timeout = send_timeout
        self._stop = threading.Event()
        self._send_lock = threading.Lock()
        self._threads: list[threading.Thread] = []
        self._rx_id = ID_ISOTP_RESPONSE + node_id
        self._isotp: _IsoTp = (
            _KernelIsoTp(kernel_isotp, node_id, isotp_timeout_ms)
            if kernel_isotp is not None
            else _UserIsoTp(self, node_id, isotp_timeout_ms)
        )
        #: "kernel" or "user": which ISO-TP implementation carries the requests.
        self.isotp_kind = "kernel" if kernel_isotp is not None else "user"

    @staticmethod
    def filters(node_id: int, isotp_frames: bool = True) -> list[can.typechecking.CanFilter]:
        """python-can receive filters for one node: its sample and trigger ids, and
        the ISO-TP response id if ``isotp_frames``."""
        ids = [*SAMPLE_FRAME_IDS, ID_TRIGGER] + ([ID_ISOTP_RESPONSE] if isotp_frames else [])
        return [{"can_id": i + node_id, "can_mask": 0x7FF, "extended": False} for i in ids]

    # ------------------------------------------------------------ reading

    def _start_reader(self) -> None:
        self._isotp.start()
        raw = _raw_socketcan(self.bus)
        bus_reader = self._socket_reader if raw is not None else self._bus_reader
        for target, name in ((bus_reader, "bus"), (self._isotp_reader, "isotp")):
            t = threading.Thread(target=target, name=f"aacmm-can-{name}", daemon=True)
            self._threads.append(t)
            t.start()

    def _lost(self, exc: BaseException) -> None:
        if not self._stop.is_set():
            self._link_lost(OperationError(f"{self.description}: {exc}"))

    def _bus_reader(self) -> None:
        while not self._stop.is_set():
            try:
                frame = self.bus.recv(timeout=_POLL_S)
            except (can.CanError, OSError, ValueError) as exc:
                self._lost(exc)
                return
            if frame is not None:
                self.feed_frame(frame)

    def _socket_reader(self) -> None:
        # SocketCAN fast path: the frames straight off the bus's raw socket
        # (its kernel filters already applied), a burst per wake-up, without
        # building a can.Message per frame. At 1 kHz a device sends 6000
        # frames/s; this keeps the reader ahead of the socket's queue.
        sock = _raw_socketcan(self.bus)
        assert sock is not None
        unpack = _CAN_FRAME.unpack
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([sock], [], [], _POLL_S)
                if not ready:
                    continue
                for _ in range(1024):
                    try:
                        raw = sock.recv(16, socket.MSG_DONTWAIT)
                    except BlockingIOError:
                        break
                    can_id, dlc, data = unpack(raw)
                    self._route(can_id, data[:dlc])
            except (OSError, ValueError, struct.error) as exc:
                self._lost(exc)
                return

    def feed_frame(self, frame: can.Message) -> None:
        """Route one received python-can frame as the reader thread does."""
        flags = 0
        if frame.is_error_frame or frame.is_remote_frame or frame.is_extended_id:
            flags = _CAN_EFF_RTR_ERR
        self._route(frame.arbitration_id | flags, bytes(frame.data))

    def _route(self, can_id: int, data: bytes) -> None:
        self.stats.bytes_rx += 1
        if can_id & _CAN_EFF_RTR_ERR:
            self.frames_foreign += 1
            return
        if can_id == self._rx_id:
            if self._isotp.wants_frames:
                self._isotp.on_frame(data)
            return
        base = can_id - self.node_id
        if base in SAMPLE_FRAME_IDS or base == ID_TRIGGER:
            for msg in self.samples.feed(can_id, data):
                self._deliver(msg)
        else:
            self.frames_foreign += 1

    def _isotp_reader(self) -> None:
        while not self._stop.is_set():
            try:
                data = self._isotp.recv(_POLL_S)
            except FrameError as exc:
                self._frame_error(exc)
                continue
            except OSError as exc:
                self._lost(exc)
                return
            if data is None:
                continue
            try:
                msg = decode_message(data)
            except FrameError as exc:
                self._frame_error(exc)
                continue
            self._deliver(msg)

    # ------------------------------------------------------------ writing

    def send(self, body: bytes) -> None:
        self._check_open()
        if not 3 <= len(body) <= 4095:
            raise ValueError(f"body of {len(body)} bytes does not fit ISO-TP")
        with self._send_lock:
            try:
                self._isotp.send(bytes(body), self._send_timeout)
            except DeviceTimeoutError as exc:
                raise DeviceTimeoutError(f"{self.description}: {exc}") from exc
            except OperationError as exc:
                raise OperationError(f"{self.description}: {exc}") from exc
        self.stats.messages_tx += 1

    def send_frame(self, arbitration_id: int, data: bytes) -> None:
        """Send one raw classic CAN frame (also used by the user-space ISO-TP stack).

        Raises:
            OperationError: closed or the bus refused the frame.
        """
        self._check_open()
        try:
            self.bus.send(
                can.Message(arbitration_id=arbitration_id, data=data, is_extended_id=False),
                timeout=self._send_timeout,
            )
        except can.CanError as exc:
            raise OperationError(f"{self.description}: send failed: {exc}") from exc

    def close(self) -> None:
        if self._stop.is_set():
            return
        self._stop.set()
        self._closed.set()
        self._isotp.stop()
        me = threading.current_thread()
        for t in self._threads:
            if t is not me:
                t.join(timeout=2.0)
        if self._own_bus:
            try:
                self.bus.shutdown()
            except Exception:  # closing must not raise
                pass


def _raw_socketcan(bus: Any) -> socket.socket | None:
    """The raw CAN socket of a python-can ``socketcan`` bus, else None."""
    sock = getattr(bus, "socket", None)
    if isinstance(sock, socket.socket) and sock.family == getattr(socket, "AF_CAN", -1):
        return sock
    return None


def enlarge_rcvbuf(bus: Any) -> None:
    """Give a python-can SocketCAN bus's socket a big receive buffer (8 MiB; best
    effort: SO_RCVBUFFORCE, which lets root exceed net.core.rmem_max, else
    SO_RCVBUF), so a slow reader loses no frames. Other buses are left alone."""
    sock = _raw_socketcan(bus)
    if sock is None:
        return
    for opt in (_SO_RCVBUFFORCE, socket.SO_RCVBUF):
        try:
            sock.setsockopt(socket.SOL_SOCKET, opt, _RCVBUF_BYTES)
            return
        except OSError:
            continue


class SocketCanTransport(CanTransport):
    """SocketCAN interface (e.g. ``vcan0``, ``can0``) via python-can's ``socketcan`` bus.

    Kernel filters pass only the node's frames, the socket's receive buffer is
    enlarged (best effort) so a stalled host survives a burst, and frames are
    read straight off the bus's socket. ISO-TP: ``isotp="kernel"`` uses a
    kernel ISO-TP socket, ``"user"`` the user-space ``can-isotp`` stack,
    ``"auto"`` (default) the kernel one when the kernel has it.

    Raises:
        InitError: the interface does not exist, is down, SocketCAN is
            missing, or ``isotp="kernel"`` without kernel ISO-TP.
        ValueError: bad node id or ``isotp`` value.
    """

    def __init__(self, channel: str, node_id: int = 0, isotp: str = "auto", **kwargs: Any) -> None:
        check_node(node_id)
        if isotp not in ("auto", "kernel", "user"):
            raise ValueError(f"isotp must be auto, kernel or user, got {isotp!r}")
        kernel = isotp != "user"
        if isotp == "auto":
            try:
                _KernelIsoTp(channel, node_id, 1000).stop()
            except InitError:
                kernel = False
        try:
            bus = can.Bus(
                interface="socketcan",
                channel=channel,
                can_filters=self.filters(node_id, isotp_frames=not kernel),
                receive_own_messages=False,
            )
        except (can.CanError, OSError, ValueError, ImportError) as exc:
            raise InitError(f"cannot open SocketCAN interface {channel}: {exc}") from exc
        enlarge_rcvbuf(bus)
        try:
            super().__init__(bus, node_id, kernel_isotp=channel if kernel else None, **kwargs)
        except BaseException:
            bus.shutdown()
            raise
        self.description = f"socketcan {channel} node {node_id}"


class VirtualCanTransport(CanTransport):
    """python-can's in-process ``virtual`` bus (unit tests; the peer lives in the same process).

    Raises:
        InitError: the bus cannot be created.
        ValueError: bad node id.
    """

    def __init__(self, channel: str, node_id: int = 0, **kwargs: Any) -> None:
        check_node(node_id)
        try:
            bus = can.Bus(
                interface="virtual",
                channel=channel,
                can_filters=self.filters(node_id),
                receive_own_messages=False,
            )
        except (can.CanError, OSError, ValueError) as exc:
            raise InitError(f"cannot open virtual CAN channel {channel}: {exc}") from exc
        super().__init__(bus, node_id, **kwargs)
        self.description = f"virtual {channel} node {node_id}"
