"""A connection to one device: requests matched to responses, retries, trigger events."""

from __future__ import annotations

import operator
import os
import random
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from aacmm.client.options import (
    DEFAULT_RETRIES,
    DEFAULT_TIMEOUT,
    ENV_PORT,
    IDEMPOTENT_REQUESTS,
    TRIGGER_QUEUE,
    check_timeout,
)
from aacmm.client.stream import SampleStream
from aacmm.errors import (
    AacmmError,
    DeviceError,
    DeviceTimeoutError,
    FrameError,
    OperationError,
    VersionMismatchError,
)
from aacmm.protocol import (
    PROTOCOL_VERSION,
    ComputeRequest,
    ComputeResult,
    DeviceInfo,
    Diagnostics,
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
    encode_message,
    status_name,
)
from aacmm.protocol.constants import (
    JOINTS_MAX,
    JOINTS_MIN,
    OLD_PROTOCOL_VERSIONS,
    RESPONSE_BIT,
    STREAM_RATE_MAX_HZ,
    STREAM_RATE_MIN_HZ,
)
from aacmm.protocol.status import Status
from aacmm.transport import Transport, open_transport


@dataclass
class ClientStats:
    """Counters of one client (never reset)."""

    requests: int = 0
    retries: int = 0
    timeouts: int = 0
    device_errors: int = 0
    stale_responses: int = 0
    """Responses that fit no waiting request by sequence number and type (late or foreign)."""
    frame_errors: int = 0
    """Invalid frames or messages the transport dropped."""
    unsolicited_samples: int = 0
    """Samples received while no stream was open."""
    unexpected_messages: int = 0
    callback_errors: int = 0
    """Exceptions raised by trigger callbacks (swallowed)."""


class _Pending:
    __slots__ = ("event", "response", "seq", "type", "version_error")

    def __init__(self, msg_type: MsgType, seq: int) -> None:
        self.type = msg_type
        self.seq = seq
        self.event = threading.Event()
        self.response: Message | None = None
        self.version_error: FrameError | None = None


def version_mismatch(err: FrameError, request: MsgType) -> DeviceError:
    """The error for a device that answered ``request`` in another protocol version."""
    old = OLD_PROTOCOL_VERSIONS
    if err.version in old:
        what = (
            f"the device speaks protocol version {err.version} ({old[err.version]}); this "
            f"host speaks version {PROTOCOL_VERSION}: update the device's firmware"
        )
    else:
        what = (
            f"the device speaks protocol version {err.version}; this host speaks version "
            f"{PROTOCOL_VERSION}"
        )
    return DeviceError(f"{what} (answering {request.name})", int(Status.ERR_VERSION), int(request))


def _answers(msg: Message, pending: _Pending) -> bool:
    """True if ``msg`` is the response to ``pending``: same sequence number, and
    the matching response type or an error response naming the request (or 0)."""
    if msg.seq != pending.seq:
        return False
    if isinstance(msg.payload, ErrorReply):
        return msg.payload.request_type in (0, int(pending.type))
    return int(msg.type) == int(pending.type) | RESPONSE_BIT


def _counts(counts: Sequence[int]) -> tuple[int, ...]:
    try:
        values = tuple(operator.index(c) for c in counts)
    except TypeError:
        raise TypeError("encoder counts must be integers") from None
    if not JOINTS_MIN <= len(values) <= JOINTS_MAX:
        raise ValueError(
            f"need {JOINTS_MIN} to {JOINTS_MAX} encoder counts (one a joint), got {len(values)}"
        )
    for i, v in enumerate(values):
        if not 0 <= v <= 0xFFFFFFFF:
            raise ValueError(f"counts[{i}]={v} outside 0..2**32-1")
    return values


def _flag(name: str, value: object) -> bool:
    if not isinstance(value, bool):
        raise TypeError(f"{name} must be a bool")
    return value


class Client:
    """A connection to one device over a started :class:`~aacmm.transport.Transport`.

    Thread-safe: requests from several threads are serialised. Use
    :func:`connect` to open one from a URL.

    Args:
        transport: an opened, not yet started transport (the client starts it
            and closes it on :meth:`close`).
        timeout: seconds to wait for each response.
        retries: extra attempts for idempotent requests.
    """

    def __init__(
        self,
        transport: Transport,
        timeout: float = DEFAULT_TIMEOUT,
        retries: int = DEFAULT_RETRIES,
    ) -> None:
        timeout = check_timeout(timeout)
        if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
            raise ValueError(f"retries must be a non-negative int, got {retries!r}")
        self.transport = transport
        self.timeout = float(timeout)
        self.retries = retries
        self.stats = ClientStats()
        self.last_frame_error: FrameError | None = None
        self.device_info: DeviceInfo | None = None
        """The last :meth:`info` answer."""
        self._lock = threading.Lock()  # guards the fields below
        self._req_lock = threading.Lock()  # one request at a time
        self._pending: _Pending | None = None
        self._stream: SampleStream | None = None
        self._link_error: BaseException | None = None
        self._closed = False
        self._seq = random.randrange(256)
        self._triggers: deque[Trigger] = deque(maxlen=TRIGGER_QUEUE)
        self._trigger_cond = threading.Condition()
        self._trigger_callbacks: list[Callable[[Trigger], None]] = []
        transport.start(self)

    # ------------------------------------------------------------ sink (reader threads)

    def on_message(self, msg: Message) -> None:
        t = msg.type
        if t == MsgType.SAMPLE_EVT:
            stream = self._stream
            if stream is not None and isinstance(msg.payload, Sample):
                stream.deliver(msg.payload)
            else:
                self.stats.unsolicited_samples += 1
            return
        if t == MsgType.TRIGGER_EVT:
            if isinstance(msg.payload, Trigger):
                self._on_trigger(msg.payload)
            return
        if t & RESPONSE_BIT:
            with self._lock:
                p = self._pending
                if p is not None and p.response is None and _answers(msg, p):
                    p.response = msg
                    p.event.set()
                    return
            self.stats.stale_responses += 1
            return
        self.stats.unexpected_messages += 1

    def on_frame_error(self, err: FrameError) -> None:
        self.stats.frame_errors += 1
        self.last_frame_error = err
        if err.status == Status.ERR_VERSION:
            # A body of another protocol version: the answer of a device that
            # does not speak ours. The request waiting for it learns why.
            with self._lock:
                p = self._pending
                if p is not None and p.response is None:
                    p.version_error = err
                    p.event.set()

    def on_link_lost(self, err: BaseException) -> None:
        with self._lock:
            self._link_error = err
            pending, stream = self._pending, self._stream
        if pending is not None:
            pending.event.set()
        if stream is not None:
            stream.finish(err)
        with self._trigger_cond:
            self._trigger_cond.notify_all()

    def _on_trigger(self, trig: Trigger) -> None:
        with self._trigger_cond:
            self._triggers.append(trig)
            self._trigger_cond.notify_all()
            callbacks = list(self._trigger_callbacks)
        for cb in callbacks:
            try:
                cb(trig)
            except Exception:  # a user callback must not kill the reader
                self.stats.callback_errors += 1

    # ------------------------------------------------------------ requests

    def _check_usable(self) -> None:
        if self._closed:
            raise OperationError("client is closed")
        if self._link_error is not None:
            raise OperationError(f"link lost: {self._link_error}") from self._link_error

    def request(
        self,
        msg_type: MsgType,
        payload: object = None,
        *,
        timeout: float | None = None,
        retries: int | None = None,
    ) -> Message:
        """Send one request and return the device's matching response.

        ``retries`` (default: the client's) applies only to idempotent
        requests (:data:`IDEMPOTENT_REQUESTS`); others are sent once.

        Raises:
            ValueError: not a request type, or a payload the codec rejects.
            DeviceTimeoutError: no answer after all attempts.
            DeviceError: the device answered with an error response.
            OperationError: closed client or lost link.
        """
        try:
            t = MsgType(msg_type)
        except ValueError:
            raise ValueError(f"unknown message type {msg_type!r}") from None
        if int(t) >= 0x40:
            raise ValueError(f"{t.name} is not a request")
        wait = self.timeout if timeout is None else check_timeout(timeout)
        extra = self.retries if retries is None else retries
        if t not in IDEMPOTENT_REQUESTS:
            extra = 0
        encode_message(Message(t, 0, payload))  # type: ignore[arg-type]  # ValueError early
        self._check_usable()
        last: AacmmError | None = None
        with self._req_lock:
            self.stats.requests += 1
            for attempt in range(1 + extra):
                if attempt:
                    self.stats.retries += 1
                self._check_usable()
                with self._lock:
                    self._seq = (self._seq + 1) & 0xFF
                    pending = _Pending(t, self._seq)
                    self._pending = pending
                body = encode_message(Message(t, pending.seq, payload))  # type: ignore[arg-type]
                try:
                    self.transport.send(body)
                    answered = pending.event.wait(wait)
                except DeviceTimeoutError as exc:
                    answered, last = False, exc
                finally:
                    with self._lock:
                        self._pending = None
                self._check_usable()
                if pending.version_error is not None:
                    self.stats.device_errors += 1
                    raise version_mismatch(pending.version_error, t)
                rsp = pending.response
                if not answered or rsp is None:
                    self.stats.timeouts += 1
                    last = DeviceTimeoutError(
                        f"{self.transport.description}: no answer to {t.name} within {wait:.3f} s"
                        + (f" ({attempt + 1} attempts)" if attempt else "")
                    )
                    continue
                if isinstance(rsp.payload, ErrorReply):
                    self.stats.device_errors += 1
                    err = DeviceError(
                        f"device refused {t.name}: {status_name(rsp.payload.status)}",
                        rsp.payload.status,
                        rsp.payload.request_type or int(t),
                    )
                    if rsp.payload.status == Status.ERR_BUSY and attempt < extra:
                        last = err
                        continue
                    raise err
                return rsp
        assert last is not None
        raise last

    def ping(self, token: int | None = None) -> float:
        """Ping the device; return the round-trip time in seconds.

        Raises:
            FrameError: the echoed token differs.
        """
        tok = random.getrandbits(32) if token is None else token
        start = time.perf_counter()
        rsp = self.request(MsgType.PING_REQ, Ping(tok))
        rtt = time.perf_counter() - start
        if not isinstance(rsp.payload, Ping) or rsp.payload.token != tok:
            raise FrameError("ping answered with another token", int(Status.ERR_FRAME))
        return rtt

    def info(self) -> DeviceInfo:
        """Device identity, firmware version, build flags and parameter state."""
        payload = self.request(MsgType.INFO_REQ).payload
        assert isinstance(payload, DeviceInfo)
        self.device_info = payload
        return payload

    def diagnostics(self) -> Diagnostics | None:
        """Storage slots, reset cause, watchdog, encoder faults and link counters.

        ``None`` when the device predates the request or does not offer it
        (it answers ERR_UNKNOWN_TYPE or ERR_UNSUPPORTED).
        """
        try:
            payload = self.request(MsgType.DIAG_REQ).payload
        except DeviceError as exc:
            if exc.status in (int(Status.ERR_UNKNOWN_TYPE), int(Status.ERR_UNSUPPORTED)):
                return None
            raise
        assert isinstance(payload, Diagnostics)
        return payload

    def get_params(self) -> ParamSet:
        """The active parameter set (kinematic parameters and encoder configuration)."""
        payload = self.request(MsgType.GET_PARAMS_REQ).payload
        assert isinstance(payload, ParamSet)
        return payload

    def set_params(self, params: ParamSet) -> int:
        """Activate ``params`` (in RAM; see :meth:`save_params`); return the device's CRC of it.

        Not retried. Raises ValueError for values the protocol cannot carry and
        DeviceError if the device refuses them.
        """
        if not isinstance(params, ParamSet):
            raise TypeError("params must be an aacmm.protocol.ParamSet")
        payload = self.request(MsgType.SET_PARAMS_REQ, params).payload
        assert isinstance(payload, ParamCrc)
        return payload.param_crc32

    def save_params(self) -> int:
        """Store the active set in non-volatile storage; return its CRC. Not retried."""
        payload = self.request(MsgType.SAVE_PARAMS_REQ).payload
        assert isinstance(payload, ParamCrc)
        return payload.param_crc32

    def restore_defaults(self) -> int:
        """Activate the built-in default parameters; return their CRC. Not retried."""
        payload = self.request(MsgType.RESTORE_DEFAULTS_REQ).payload
        assert isinstance(payload, ParamCrc)
        return payload.param_crc32

    def measure(self, jacobian: bool = False) -> Sample:
        """Read the encoders now and return the sample (with the 3 x P Jacobian if asked)."""
        payload = self.request(
            MsgType.MEASURE_REQ, MeasureRequest(_flag("jacobian", jacobian))
        ).payload
        assert isinstance(payload, Sample)
        return payload

    def compute(self, counts: Sequence[int], jacobian: bool = False) -> ComputeResult:
        """Have the device evaluate its model at its N encoder readings (0..2**32-1;
        N = :attr:`DeviceInfo.joints`: the device refuses another count with ERR_RANGE)."""
        req = ComputeRequest(_counts(counts), _flag("jacobian", jacobian))
        payload = self.request(MsgType.COMPUTE_REQ, req).payload
        assert isinstance(payload, ComputeResult)
        return payload

    def stream(
        self,
        rate_hz: int,
        jacobian: bool = False,
        *,
        timeout: float | None = None,
        max_queue: int = 1_000_000,
    ) -> SampleStream:
        """Start streaming at ``rate_hz`` (1..1000) and return the :class:`SampleStream`.

        ``timeout`` is the longest wait for one sample (default: the request
        timeout plus two sample periods, at least 1 s more); ``max_queue`` bounds the samples
        buffered for a slow consumer (the oldest are dropped and counted).

        Raises:
            ValueError: rate out of range, bad ``max_queue``.
            OperationError: a stream is already open on this client.
        """
        if isinstance(rate_hz, bool) or not isinstance(rate_hz, int):
            raise TypeError("rate_hz must be an int")
        if not STREAM_RATE_MIN_HZ <= rate_hz <= STREAM_RATE_MAX_HZ:
            raise ValueError(
                f"rate_hz={rate_hz} outside {STREAM_RATE_MIN_HZ}..{STREAM_RATE_MAX_HZ}"
            )
        if max_queue < 1:
            raise ValueError("max_queue must be at least 1")
        wait = self.timeout + max(1.0, 2.0 / rate_hz) if timeout is None else check_timeout(timeout)
        content = _flag("jacobian", jacobian)
        with self._lock:
            if self._stream is not None:
                raise OperationError("a stream is already open on this client")
        # A new stream holds only its own samples (#15.1): the device may still be
        # streaming for a client that went away (a logger killed with -9), and its
        # queued samples may follow our requests' answers (responses do not wait
        # behind samples). So stop that stream, then read the device's clock: every
        # sample of the old stream was read before that instant, every sample of the
        # new one after it; the stream takes only samples newer than this fence.
        self.request(MsgType.STREAM_STOP_REQ)
        fence_us: int | None
        try:
            fence_us = self.measure().timestamp_us
        except DeviceError:
            fence_us = None  # no clock reading: the stop alone must do
        stream = SampleStream(self, rate_hz, content, wait, max_queue, fence_us)
        with self._lock:
            if self._stream is not None:
                raise OperationError("a stream is already open on this client")
            self._stream = stream
        try:
            rsp = self.request(MsgType.STREAM_START_REQ, Stream(rate_hz, jacobian))
        except BaseException:
            with self._lock:
                self._stream = None
            stream.finish()
            raise
        assert isinstance(rsp.payload, Stream)
        stream.accepted = rsp.payload
        return stream

    def stop_stream(self, stream: SampleStream) -> None:
        """Stop ``stream`` on the device if it is this client's open stream, and end
        it on the host side (what :meth:`SampleStream.stop` calls; idempotent)."""
        with self._lock:
            if self._stream is not stream:
                return
        try:
            if not self._closed and self._link_error is None:
                self.request(MsgType.STREAM_STOP_REQ)
        finally:
            with self._lock:
                if self._stream is stream:
                    self._stream = None
            stream.finish()

    @property
    def streaming(self) -> SampleStream | None:
        """The open stream, if any."""
        return self._stream

    # ------------------------------------------------------------ trigger events

    def wait_trigger(self, timeout: float | None = None) -> Trigger:
        """The oldest probe-button event not yet taken (waits up to ``timeout`` s).

        Raises:
            DeviceTimeoutError: none arrived in time.
            OperationError: the link was lost.
        """
        wait = self.timeout if timeout is None else check_timeout(timeout, poll=True)
        deadline = time.monotonic() + wait
        with self._trigger_cond:
            while not self._triggers:
                self._check_usable()
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise DeviceTimeoutError(f"no trigger event within {wait:.3f} s")
                self._trigger_cond.wait(remaining)
            return self._triggers.popleft()

    def drain_triggers(self) -> list[Trigger]:
        """All trigger events received and not yet taken (oldest first)."""
        with self._trigger_cond:
            out = list(self._triggers)
            self._triggers.clear()
            return out

    def add_trigger_callback(self, callback: Callable[[Trigger], None]) -> None:
        """Call ``callback(trigger)`` from the reader thread for every event (keep it short)."""
        with self._trigger_cond:
            self._trigger_callbacks.append(callback)

    def remove_trigger_callback(self, callback: Callable[[Trigger], None]) -> None:
        with self._trigger_cond:
            self._trigger_callbacks.remove(callback)

    # ------------------------------------------------------------ life cycle

    def handshake(self) -> DeviceInfo:
        """Read the device info and check the protocol version.

        A device speaking another version is recognised three ways: its info
        names another version; it answers with ERR_VERSION; or its answers carry
        another version byte, so the host drops them (the request then times out
        with version frame errors counted).

        Raises:
            VersionMismatchError: the device speaks another protocol version (an
                :class:`~aacmm.errors.InitError`).
            DeviceTimeoutError, DeviceError, OperationError: the info request failed.
        """
        try:
            info = self.info()
        except DeviceTimeoutError:
            fe = self.last_frame_error
            if fe is not None and fe.status == int(Status.ERR_VERSION):
                raise VersionMismatchError(
                    f"{self.transport.description}: the device speaks another protocol "
                    f"version ({fe}); this host speaks {PROTOCOL_VERSION}"
                ) from None
            raise
        except DeviceError as exc:
            if exc.status == int(Status.ERR_VERSION):
                raise VersionMismatchError(
                    f"{self.transport.description}: the device refused protocol version "
                    f"{PROTOCOL_VERSION} ({exc})"
                ) from None
            raise
        if info.protocol_version != PROTOCOL_VERSION:
            raise VersionMismatchError(
                f"{self.transport.description}: the device speaks protocol version "
                f"{info.protocol_version}, this host {PROTOCOL_VERSION}"
            )
        return info

    @property
    def closed(self) -> bool:
        return self._closed

    def close(self) -> None:
        """Stop an open stream (best effort) and close the transport (idempotent)."""
        if self._closed:
            return
        stream = self._stream
        if stream is not None:
            try:
                stream.stop()
            except AacmmError:
                pass
        self._closed = True
        self.transport.close()
        with self._trigger_cond:
            self._trigger_cond.notify_all()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def connect(
    url: str | None = None,
    *,
    timeout: float = DEFAULT_TIMEOUT,
    retries: int = DEFAULT_RETRIES,
    handshake: bool = False,
) -> Client:
    """Open a client from a device URL (default: ``$AACMM_PORT``).

    With ``handshake=True`` the device info is read and the protocol version
    checked before returning.

    Raises:
        ValueError: no URL given nor in the environment, or a malformed URL.
        InitError: the port or bus cannot be opened; its subclass
            VersionMismatchError: the handshake found another protocol version
            (:meth:`Client.handshake`).
        DeviceTimeoutError, DeviceError: the handshake's info request failed.
    """
    if url is None:
        url = os.environ.get(ENV_PORT, "").strip()
        if not url:
            raise ValueError(f"no device URL given and {ENV_PORT} is not set")
    timeout = check_timeout(timeout)
    transport = open_transport(url, write_timeout=max(timeout, 1.0))
    try:
        client = Client(transport, timeout=timeout, retries=retries)
    except BaseException:
        transport.close()
        raise
    if handshake:
        try:
            client.handshake()
        except BaseException:
            client.close()
            raise
    return client
