"""An in-process fake aacmm device for the client unit tests.

:class:`FakeDevice` is the protocol logic (request body in, response bodies
out, sample events from a streaming thread) with knobs for injecting faults.
Two front ends put it on a link the real client transports can open:

- :class:`SerialFakeServer`: a TCP server speaking serial frames, opened by
  the client as ``socket://127.0.0.1:PORT`` (a pyserial URL);
- :class:`CanFakeDevice`: a peer on python-can's ``virtual`` bus with its own
  can-isotp stack and DBC-encoded sample frames (``virtual://CHANNEL``).

It is deliberately simple: the point is computed by a made-up function, not
the arm model; only the client logic is under test here.
"""

from __future__ import annotations

import math
import select
import socket
import struct
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import can
import isotp
from aacmm.errors import FrameError
from aacmm.protocol import (
    PROTOCOL_VERSION,
    ComputeRequest,
    ComputeResult,
    Deframer,
    DeviceInfo,
    ErrorReply,
    MeasureRequest,
    Message,
    MsgType,
    ParamCrc,
    ParamSet,
    Ping,
    Sample,
    Stream,
    Trigger,
    decode_message,
    encode_frame,
    encode_message,
    encode_sample_frames,
    param_set_crc32,
)
from aacmm.protocol.can import ID_TRIGGER, isotp_params
from aacmm.protocol.status import Status

DEFAULT_PARAMS = ParamSet(
    theta_offset_rad=(0.0,) * 6,
    alpha_rad=(math.pi / 2,) * 6,
    d_mm=(300.0, 65.5, 792.7, 65.5, 883.2, 0.0),
    a_mm=(0.0,) * 6,
    l_mm=183.5,
    counts_per_rev=(1 << 32,) * 6,
    zero_offset_counts=(0,) * 6,
    direction=(1,) * 6,
)


def param_crc(p: ParamSet) -> int:
    """``param_set_crc32`` of a parameter set."""
    return param_set_crc32(p)


def fake_point(counts: tuple[int, ...]) -> tuple[int, int, int]:
    return (counts[0] % 100000, -(counts[1] % 100000), counts[2] % 7 - 3)


def fake_jacobian(counts: tuple[int, ...]) -> tuple[tuple[float, ...], ...]:
    """3 rows of 25 values (the codec's Jacobian shape)."""
    return tuple(
        tuple(float(((25 * r + c) * 7 + counts[0]) % 13) - 6.0 for c in range(25)) for r in range(3)
    )


@dataclass
class Faults:
    """Fault injection: counters are consumed one per request."""

    drop: int = 0  # ignore this many requests
    busy: int = 0  # answer ERR_BUSY to this many requests
    wrong_type: int = 0  # answer with a PING_RSP to this many requests
    stale_first: int = 0  # send a response with another seq before the real one
    error_for: dict[int, int] = field(default_factory=dict)  # type -> status, always
    skip_seqs: set[int] = field(default_factory=set)  # stream: sample counters not sent
    dup_seqs: set[int] = field(default_factory=set)  # stream: sample counters sent twice
    delay_s: float = 0.0  # answer after this delay
    bad_token: int = 0  # answer this many pings with another token


class FakeDevice:
    """Protocol logic of the fake. ``emit(msg)`` delivers device-initiated messages."""

    def __init__(self, node_id: int = 1, counts: tuple[int, ...] | None = None) -> None:
        self.node_id = node_id
        self.params = DEFAULT_PARAMS
        self.stored: ParamSet | None = None
        self.counts = counts or (123456, 2_000_000, 3_000_000_000, 7, 8, 9)
        self.faults = Faults()
        self.requests: list[Message] = []
        self.emit: Callable[[Message], None] = lambda m: None
        self._sample_seq = 0
        self._lock = threading.Lock()
        self._stream_stop = threading.Event()
        self._stream_thread: threading.Thread | None = None
        self.stream_rate = 0
        self.stream_jacobian = False
        self.stream_temps = False
        #: the link temperatures its sensors read (wire units), None: no sensors
        self.temps: tuple[int, ...] | None = None
        self._evt_seq = 0

    # ------------------------------------------------------------ samples

    def make_sample(
        self, jacobian: bool = False, seq: int | None = None, temps: bool = False
    ) -> Sample:
        with self._lock:
            if seq is None:
                seq = self._sample_seq
                self._sample_seq = (self._sample_seq + 1) & 0xFFFFFFFF
        return Sample(
            seq=seq,
            timestamp_us=int(time.monotonic() * 1e6),
            counts=self.counts,
            point_100nm=fake_point(self.counts),
            status=0x1 | (0x8 if self.params == DEFAULT_PARAMS else 0),
            jacobian=fake_jacobian(self.counts) if jacobian else None,
            temp=self.temps if temps else None,
        )

    def _evt(self, t: MsgType, payload: Sample | Trigger) -> Message:
        self._evt_seq = (self._evt_seq + 1) & 0xFF
        return Message(t, self._evt_seq, payload)

    def press(self, button: int = 0, pressed: bool = True) -> Trigger:
        trig = Trigger(button, pressed, self.make_sample(temps=self.stream_temps))
        self.emit(self._evt(MsgType.TRIGGER_EVT, trig))
        return trig

    def _streamer(self, rate: int, jacobian: bool) -> None:
        period = 1.0 / rate
        t_next = time.monotonic()
        while not self._stream_stop.is_set():
            now = time.monotonic()
            if now < t_next:
                self._stream_stop.wait(t_next - now)
                continue
            t_next += period
            s = self.make_sample(jacobian, temps=self.stream_temps)
            if s.seq in self.faults.skip_seqs:
                continue
            self.emit(self._evt(MsgType.SAMPLE_EVT, s))
            if s.seq in self.faults.dup_seqs:
                self.emit(self._evt(MsgType.SAMPLE_EVT, s))

    def start_stream(self, rate: int, jacobian: bool) -> None:
        self.stop_stream()
        self.stream_rate, self.stream_jacobian = rate, jacobian
        self._stream_stop.clear()
        self._stream_thread = threading.Thread(
            target=self._streamer, args=(rate, jacobian), daemon=True
        )
        self._stream_thread.start()

    def stop_stream(self) -> None:
        self._stream_stop.set()
        t = self._stream_thread
        if t is not None and t is not threading.current_thread():
            t.join(2.0)
        self._stream_thread = None
        self.stream_rate = 0

    # ------------------------------------------------------------ requests

    def handle(self, body: bytes) -> list[Message]:
        """The messages to send in answer to one request body."""
        try:
            req = decode_message(body)
        except FrameError as exc:
            if len(body) >= 3:
                return [Message(MsgType.ERROR_RSP, body[2], ErrorReply(exc.status, body[1]))]
            return []
        self.requests.append(req)
        f = self.faults
        if f.drop > 0:
            f.drop -= 1
            return []
        if f.delay_s:
            time.sleep(f.delay_s)
        t = req.type
        if f.busy > 0:
            f.busy -= 1
            return [Message(MsgType.ERROR_RSP, req.seq, ErrorReply(int(Status.ERR_BUSY), t))]
        if t in f.error_for:
            return [Message(MsgType.ERROR_RSP, req.seq, ErrorReply(f.error_for[t], t))]
        if f.wrong_type > 0:
            f.wrong_type -= 1
            return [Message(MsgType.PING_RSP, req.seq, Ping(0))]
        out = [self._answer(req)]
        if f.stale_first > 0:
            f.stale_first -= 1
            out.insert(0, replace(out[0], seq=(req.seq - 1) & 0xFF))
        return out

    def _answer(self, req: Message) -> Message:
        t, seq, p = req.type, req.seq, req.payload
        rsp = MsgType(int(t) | 0x80)
        if t == MsgType.PING_REQ:
            if self.faults.bad_token > 0 and isinstance(p, Ping):
                self.faults.bad_token -= 1
                return Message(rsp, seq, Ping(p.token ^ 1))
            return Message(rsp, seq, p)
        if t == MsgType.INFO_REQ:
            info = DeviceInfo(
                protocol_version=PROTOCOL_VERSION,
                fw_major=0,
                fw_minor=1,
                fw_patch=2,
                build_flags=0x4 | 0x8 | 0x10 | (0x20 if self.temps is not None else 0),
                param_crc32=param_crc(self.params),
                param_source=0 if self.params == DEFAULT_PARAMS else 1,
                storage_state=0 if self.stored is not None else 1,
                max_body_bytes=512,
                serial_number=4242,
                can_node_id=self.node_id,
            )
            return Message(rsp, seq, info)
        if t == MsgType.GET_PARAMS_REQ:
            return Message(rsp, seq, self.params)
        if t == MsgType.SET_PARAMS_REQ:
            assert isinstance(p, ParamSet)
            self.params = p
            return Message(rsp, seq, ParamCrc(param_crc(p)))
        if t == MsgType.SAVE_PARAMS_REQ:
            self.stored = self.params
            return Message(rsp, seq, ParamCrc(param_crc(self.params)))
        if t == MsgType.RESTORE_DEFAULTS_REQ:
            self.params = DEFAULT_PARAMS
            return Message(rsp, seq, ParamCrc(param_crc(self.params)))
        if t == MsgType.MEASURE_REQ:
            assert isinstance(p, MeasureRequest)
            if p.temperatures and self.temps is None:
                return Message(MsgType.ERROR_RSP, seq, ErrorReply(int(Status.ERR_UNSUPPORTED), t))
            return Message(rsp, seq, self.make_sample(p.jacobian, temps=p.temperatures))
        if t == MsgType.COMPUTE_REQ:
            assert isinstance(p, ComputeRequest)
            x, y, z = fake_point(p.counts)
            res = ComputeResult(
                status=1,
                point_mm=(x * 1e-4, y * 1e-4, z * 1e-4),
                jacobian=fake_jacobian(p.counts) if p.jacobian else None,
                temperatures=p.temp is not None,
            )
            return Message(rsp, seq, res)
        if t == MsgType.STREAM_START_REQ:
            assert isinstance(p, Stream)
            if p.temperatures and self.temps is None:
                return Message(MsgType.ERROR_RSP, seq, ErrorReply(int(Status.ERR_UNSUPPORTED), t))
            self.stream_temps = p.temperatures
            self.start_stream(p.rate_hz, p.jacobian)
            return Message(rsp, seq, p)
        if t == MsgType.STREAM_STOP_REQ:
            self.stop_stream()
            return Message(rsp, seq, None)
        return Message(MsgType.ERROR_RSP, seq, ErrorReply(int(Status.ERR_UNSUPPORTED), t))

    def close(self) -> None:
        self.stop_stream()


class SerialFakeServer:
    """The fake on a localhost TCP socket speaking serial frames (``socket://`` for pyserial)."""

    def __init__(self, device: FakeDevice | None = None) -> None:
        self.device = device or FakeDevice()
        self.device.emit = self._send_msg
        self.deframer = Deframer()
        self._srv = socket.create_server(("127.0.0.1", 0))
        self.port = self._srv.getsockname()[1]
        self.url = f"socket://127.0.0.1:{self.port}"
        self._conn: socket.socket | None = None
        self._wlock = threading.Lock()
        self._stop = threading.Event()
        self.garbage_before_response = b""
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _send_msg(self, msg: Message) -> None:
        self.send_raw(encode_frame(encode_message(msg)))

    def send_raw(self, data: bytes) -> None:
        with self._wlock:
            conn = self._conn
            if conn is None:
                return
            try:
                conn.sendall(data)
            except OSError:
                pass

    def _serve(self) -> None:
        self._srv.settimeout(0.1)
        while not self._stop.is_set():
            try:
                conn, _ = self._srv.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            # Blocking socket (a send timeout would tear frames under load);
            # select() keeps the loop responsive to close().
            conn.settimeout(None)
            self._conn = conn
            self.deframer = Deframer()
            while not self._stop.is_set():
                try:
                    ready, _, _ = select.select([conn], [], [], 0.1)
                    if not ready:
                        continue
                    data = conn.recv(4096)
                except OSError:
                    break
                if not data:
                    break
                bodies = self.deframer.feed(data)
                for body in bodies:
                    for msg in self.device.handle(body):
                        if self.garbage_before_response:
                            self.send_raw(self.garbage_before_response)
                        self._send_msg(msg)
            self.device.stop_stream()
            with self._wlock:
                self._conn = None
            conn.close()

    def drop_connection(self) -> None:
        """Close the current connection (the client sees the link go away)."""
        with self._wlock:
            if self._conn is not None:
                try:
                    self._conn.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass

    def close(self) -> None:
        self._stop.set()
        self.device.close()
        self.drop_connection()
        self._thread.join(2.0)
        self._srv.close()


class CanFakeDevice:
    """The fake as a CAN node: python-can ``virtual`` bus by default (``virtual://CHANNEL?node=N``)."""

    def __init__(
        self,
        device: FakeDevice | None = None,
        channel: str | None = None,
        interface: str = "virtual",
    ) -> None:
        self.device = device or FakeDevice()
        self.device.emit = self._send_msg
        n = self.device.node_id
        self.channel = channel or f"aacmm-test-{uuid.uuid4().hex[:12]}"
        self.url = f"{interface}://{self.channel}?node={n}"
        self.bus = can.Bus(
            interface=interface,
            channel=self.channel,
            receive_own_messages=False,
            can_filters=[{"can_id": 0x600 + n, "can_mask": 0x7FF, "extended": False}],
        )
        addr = isotp.Address(isotp.AddressingMode.Normal_11bits, txid=0x680 + n, rxid=0x600 + n)
        params = isotp_params(1000)
        params["blocking_send"] = True
        self.tp = isotp.CanStack(self.bus, address=addr, params=params, read_timeout=0.02)
        self.tp.start()
        self._send_lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def send_frame(self, arb: int, data: bytes) -> None:
        self.bus.send(can.Message(arbitration_id=arb, data=data, is_extended_id=False))

    def _send_msg(self, msg: Message) -> None:
        p = msg.payload
        with self._send_lock:
            if msg.type == MsgType.SAMPLE_EVT and isinstance(p, Sample) and p.jacobian is None:
                for fr in encode_sample_frames(p, self.device.node_id):
                    self.send_frame(fr.arbitration_id, fr.data)
                return
            if msg.type == MsgType.TRIGGER_EVT and isinstance(p, Trigger):
                # trigger frame first, then the latched sample's frames
                data = struct.pack("<IBBH", p.sample.seq, p.button, int(p.pressed), 0)
                self.send_frame(ID_TRIGGER + self.device.node_id, data)
                for fr in encode_sample_frames(p.sample, self.device.node_id):
                    self.send_frame(fr.arbitration_id, fr.data)
                return
            try:
                self.tp.send(encode_message(msg), send_timeout=2.0)
            except isotp.BlockingSendFailure:
                pass

    def _serve(self) -> None:
        while not self._stop.is_set():
            data = self.tp.recv(block=True, timeout=0.05)
            if data is None:
                continue
            for msg in self.device.handle(bytes(data)):
                self._send_msg(msg)

    def close(self) -> None:
        self._stop.set()
        self.device.close()
        self._thread.join(2.0)
        self.tp.stop()
        self.bus.shutdown()
