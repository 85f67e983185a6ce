"""A sample stream of the client: samples queued from the reader thread, gaps counted."""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from types import TracebackType
from typing import TYPE_CHECKING

from aacmm.client.options import check_timeout
from aacmm.errors import AacmmError, DeviceTimeoutError, OperationError
from aacmm.protocol import Sample, SampleStatus, Stream

if TYPE_CHECKING:
    from aacmm.client.connection import Client


@dataclass
class StreamStats:
    """Counters of one sample stream."""

    received: int = 0
    lost: int = 0
    """Samples missing according to the sequence numbers (gaps)."""
    duplicates: int = 0
    """Samples whose sequence number was not newer than the previous one."""
    overruns: int = 0
    """Samples flagged OVERRUN by the device (it dropped samples before them)."""
    dropped: int = 0
    """Samples discarded on the host because the consumer fell ``max_queue`` behind."""
    foreign: int = 0
    """Samples of an earlier stream (device time before this one began), not taken."""
    first_seq: int | None = None
    last_seq: int | None = None


class SampleStream:
    """Samples streamed by the device: an iterator and a context manager.

    Made by :meth:`Client.stream`, which has already started the stream;
    leaving the ``with`` block (or :meth:`stop`) stops it. Iteration yields
    :class:`~aacmm.protocol.Sample` objects in arrival order, raises
    :class:`~aacmm.errors.DeviceTimeoutError` when no sample came for
    ``timeout`` seconds, and ends once the stream is stopped and the samples
    received before the stop are consumed. Gaps and repeats in the sequence
    numbers are counted in :attr:`stats`, not hidden.
    """

    def __init__(
        self,
        client: Client,
        rate_hz: int,
        jacobian: bool,
        timeout: float,
        max_queue: int,
        fence_us: int | None = None,
    ) -> None:
        self._client = client
        self.rate_hz = rate_hz
        self.jacobian = jacobian
        self.timeout = timeout
        self.max_queue = max_queue
        self.accepted: Stream | None = None
        """The device's STREAM_START_RSP (rate and content it runs with)."""
        self.stats = StreamStats()
        self._queue: deque[Sample] = deque()
        # device time after the previous stream stopped (None: no clock reading)
        self._fence_us = fence_us
        self._cond = threading.Condition()
        self._ended = False
        self._error: BaseException | None = None

    def deliver(self, sample: Sample) -> None:
        """Take one received sample (the client calls this from the transport's
        reader thread): counted, and queued unless it predates the stream."""
        st = self.stats
        with self._cond:
            if self._ended:
                return
            fence = self._fence_us
            if fence is not None and not device_time_after(sample.timestamp_us, fence):
                st.foreign += 1  # read before this stream began: an earlier stream's
                return
            st.received += 1
            if st.last_seq is None:
                st.first_seq = sample.seq
            else:
                step = (sample.seq - st.last_seq) & 0xFFFFFFFF
                if step == 0 or step >= 1 << 31:
                    st.duplicates += 1
                elif step > 1:
                    st.lost += step - 1
            if step_is_newer(st.last_seq, sample.seq):
                st.last_seq = sample.seq
            if sample.status & SampleStatus.OVERRUN:
                st.overruns += 1
            if len(self._queue) >= self.max_queue:
                self._queue.popleft()
                st.dropped += 1
            self._queue.append(sample)
            self._cond.notify()

    def finish(self, error: BaseException | None = None) -> None:
        """End the stream on the host side (the client calls this when the stream
        is stopped or the link is lost with ``error``); queued samples stay readable."""
        with self._cond:
            self._ended = True
            if error is not None and self._error is None:
                self._error = error
            self._cond.notify_all()

    @property
    def active(self) -> bool:
        """True until the stream is stopped or the link is lost."""
        return not self._ended

    def pending(self) -> int:
        """Samples received and not yet consumed."""
        with self._cond:
            return len(self._queue)

    def get(self, timeout: float | None = None) -> Sample:
        """The next sample.

        Raises:
            DeviceTimeoutError: none within ``timeout`` (default: the stream's).
            OperationError: the link was lost and the queue is empty.
            StopIteration: the stream was stopped and the queue is empty.
        """
        wait = self.timeout if timeout is None else check_timeout(timeout, poll=True)
        deadline = time.monotonic() + wait
        with self._cond:
            while not self._queue:
                if self._ended:
                    if self._error is not None:
                        raise OperationError(f"stream ended: {self._error}") from self._error
                    raise StopIteration
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise DeviceTimeoutError(f"no sample within {wait:.3f} s")
                self._cond.wait(remaining)
            return self._queue.popleft()

    def __iter__(self) -> Iterator[Sample]:
        return self

    def __next__(self) -> Sample:
        return self.get()

    def stop(self) -> None:
        """Stop the stream on the device (idempotent). Samples already received stay readable.

        Raises:
            DeviceTimeoutError, DeviceError, OperationError: the stop request failed
                (the stream is ended on the host side regardless).
        """
        self._client.stop_stream(self)

    def __enter__(self) -> SampleStream:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.stop()
            return
        try:
            self.stop()
        except AacmmError:
            pass  # do not mask the exception that ended the block


def device_time_after(t_us: int, fence_us: int) -> bool:
    """Device time ``t_us`` is later than ``fence_us``, compared on the low 32 bits
    (CAN sample frames carry only those; a difference beyond 2^31 us, 35 min, is
    earlier)."""
    d = (t_us - fence_us) & 0xFFFFFFFF
    return 0 < d < 1 << 31


def step_is_newer(last: int | None, seq: int) -> bool:
    """True if sample counter ``seq`` comes after ``last`` (modulo 2**32)."""
    if last is None:
        return True
    step = (seq - last) & 0xFFFFFFFF
    return 0 < step < 1 << 31
