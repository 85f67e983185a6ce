"""``aacmm log``: stream samples to a CSV file (``aacmm summary`` reads one back).

Files of a log ``run.csv`` (format in docs/cli.md):

- ``run.csv``: one row per streamed sample, columns :data:`COLUMNS`;
  readable by ``aacmm mc --log`` (:mod:`aacmm.analysis.poselog`);
- ``run.csv.json``: the sidecar (device info, parameter set and its CRC,
  units, start and end times, counters, gaps); written when the log starts
  (``"status": "running"``), after every reconnect, and atomically replaced
  at the end;
- ``run.triggers.csv``: probe-button captures (created at the first one);
- with ``--raw FILE`` over CAN: the raw frames in python-can's log formats.

Flush policy: rows go to the operating system every :data:`FLUSH_INTERVAL_S`
seconds or :data:`FLUSH_ROWS` rows, whichever comes first, in single
``write`` calls of whole rows; so a logger killed with SIGKILL leaves a CSV
whose every line up to the last flush is complete. The files are fsynced
when the log ends.
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import math
import platform
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any

from aacmm import __version__
from aacmm.commands.common import (
    StatusLine,
    add_connection_options,
    fmt_point,
    info_dict,
    open_device,
    port_url,
    print_err,
    url_kind,
)
from aacmm.commands.exitcodes import (
    INTERRUPTED,
    OK,
    LinkLostError,
    UsageError,
    VersionMismatchError,
)
from aacmm.commands.summary import format_summary
from aacmm.errors import AacmmError, DeviceTimeoutError, InitError, OperationError
from aacmm.records.files import RowFile, utc_iso, write_json_atomic
from aacmm.records.schema import (
    LOG_COLUMNS,
    LOG_FORMAT,
    LOG_UNITS,
    default_triggers_path,
    param_set_entry,
    sample_row,
    sidecar_path,
)
from aacmm.records.schema import TRIGGER_COLUMNS as TRIGGER_COLUMNS  # re-exported

if TYPE_CHECKING:
    from aacmm.client import SampleStream
    from aacmm.commands.common import Device
    from aacmm.protocol import Sample, Trigger
    from aacmm.records.paramsets import ParamSetRecord

FORMAT = LOG_FORMAT
COLUMNS = LOG_COLUMNS
UNITS = LOG_UNITS
FLUSH_INTERVAL_S = 0.25
FLUSH_ROWS = 256
DEFAULT_RATE_HZ = 100
RAW_SUFFIXES = (".blf", ".asc", ".log")
POINT_VALID = 0x0001
RAW_RCVBUF_BYTES = 8 << 20
SO_RCVBUFFORCE = 33  # Linux; lets root exceed net.core.rmem_max
RECONNECT_PAUSE_S = 0.5


def register(sub: Any) -> None:
    p = sub.add_parser(
        "log",
        help="stream samples to a CSV file (+ JSON sidecar) until Ctrl-C, a duration or a count",
        description="Stream samples from the device into FILE.csv with a JSON sidecar "
        "FILE.csv.json; probe-button captures go to FILE.triggers.csv. Stops at Ctrl-C, "
        "SIGTERM, --duration or --count; the files are complete in every case.",
    )
    add_connection_options(p)
    p.add_argument("output", metavar="FILE.csv", help="the CSV file to write")
    p.add_argument(
        "-r",
        "--rate",
        type=int,
        default=DEFAULT_RATE_HZ,
        metavar="HZ",
        help=f"sample rate 1..1000 Hz (default {DEFAULT_RATE_HZ})",
    )
    p.add_argument("-d", "--duration", type=float, metavar="S", help="stop after S seconds")
    p.add_argument("-n", "--count", type=int, metavar="N", help="stop after N samples")
    p.add_argument(
        "--triggers",
        metavar="FILE",
        help="probe-button captures file (default: FILE.triggers.csv beside the log)",
    )
    p.add_argument("--no-triggers", action="store_true", help="do not record button captures")
    p.add_argument(
        "--raw",
        metavar="FILE",
        help="CAN only: also record the raw frames (.blf, .asc or .log, by suffix)",
    )
    p.add_argument(
        "--reconnect",
        action="store_true",
        help="when the device goes away, keep trying and continue the same log (gap recorded)",
    )
    p.add_argument(
        "--reconnect-timeout",
        type=float,
        metavar="S",
        help="with --reconnect: give up after S seconds without the device (default: never)",
    )
    p.add_argument(
        "--stall",
        type=float,
        default=2.0,
        metavar="S",
        help="no sample for S seconds means the link is lost (default 2)",
    )
    p.add_argument("-f", "--force", action="store_true", help="overwrite existing files")
    p.add_argument("-q", "--quiet", action="store_true", help="no live status line and no summary")
    p.set_defaults(func=cmd_log)


# ---------------------------------------------------------------- small helpers


def open_rows(path: Path, columns: tuple[str, ...], force: bool) -> RowFile:
    """A :class:`aacmm.records.files.RowFile` with the log's flush policy.

    Raises:
        UsageError: the file exists (without ``force``) or cannot be created.
    """
    try:
        return RowFile(path, columns, force, FLUSH_INTERVAL_S, FLUSH_ROWS)
    except FileExistsError:
        raise UsageError(f"{path} exists (use --force to overwrite)") from None
    except OSError as exc:
        raise UsageError(f"cannot create {path}: {exc.strerror}") from None


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
        from aacmm.transport.canbus import CanTransport

        if path.exists() and not force:
            raise UsageError(f"{path} exists (use --force to overwrite)")
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
        self._enlarge_rcvbuf()
        try:
            self.logger: Any = can.Logger(str(path))
        except (OSError, ValueError) as exc:
            self.bus.shutdown()
            raise UsageError(f"cannot write {path}: {exc}") from None
        self._last_rx = time.monotonic()
        self.frames = 0
        self.notifier = can.Notifier(self.bus, [self.logger, self._seen], timeout=0.1)
        self.path = path

    def _enlarge_rcvbuf(self) -> None:
        """A big socket receive buffer (best effort), so a slow writer loses no frames."""
        import socket

        sock = getattr(self.bus, "socket", None)
        if not isinstance(sock, socket.socket):
            return
        for opt in (SO_RCVBUFFORCE, socket.SO_RCVBUF):
            try:
                sock.setsockopt(socket.SOL_SOCKET, opt, RAW_RCVBUF_BYTES)
                return
            except OSError:
                continue

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


@dataclass
class Extent:
    """Bounding box of the valid points, in 1e-4 mm."""

    lo: list[int] = field(default_factory=lambda: [0, 0, 0])
    hi: list[int] = field(default_factory=lambda: [0, 0, 0])
    n: int = 0

    def add(self, p: tuple[int, ...]) -> None:
        if self.n == 0:
            self.lo, self.hi = list(p), list(p)
        else:
            for i in range(3):
                v = p[i]
                if v < self.lo[i]:
                    self.lo[i] = v
                elif v > self.hi[i]:
                    self.hi[i] = v
        self.n += 1

    def as_dict(self) -> dict[str, Any] | None:
        if self.n == 0:
            return None
        return {
            axis: {
                "min": float(fmt_point(self.lo[i])),
                "max": float(fmt_point(self.hi[i])),
                "size": float(fmt_point(self.hi[i] - self.lo[i])),
            }
            for i, axis in enumerate("xyz")
        }


@dataclass
class Session:
    """Counters of one log run (over all reconnects)."""

    samples: int = 0
    lost: int = 0
    duplicates: int = 0
    overruns: int = 0
    dropped: int = 0
    triggers: int = 0
    reconnects: int = 0
    first_host: float | None = None
    last_host: float | None = None
    last_seq: int | None = None
    extent: Extent = field(default_factory=Extent)
    gaps: list[dict[str, Any]] = field(default_factory=list)
    # time connected (sum over the stretches between reconnect gaps) and the
    # sample intervals in it: the rate while connected
    seg_first: float | None = None
    seg_rows: int = 0
    connected_s: float = 0.0
    intervals: int = 0

    def end_segment(self) -> None:
        """Close the current connected stretch (at a gap and at the end)."""
        if self.seg_first is not None and self.last_host is not None:
            self.connected_s += self.last_host - self.seg_first
            self.intervals += self.seg_rows - 1
        self.seg_first, self.seg_rows = None, 0

    def rate_hz(self) -> float | None:
        """Samples per second while connected (gaps excluded)."""
        open_s = 0.0
        open_iv = 0
        if self.seg_first is not None and self.last_host is not None:
            open_s, open_iv = self.last_host - self.seg_first, self.seg_rows - 1
        t = self.connected_s + open_s
        return (self.intervals + open_iv) / t if t > 0 else None


class StopFlag:
    """Set by SIGINT/SIGTERM; a second Ctrl-C raises KeyboardInterrupt at once."""

    def __init__(self) -> None:
        self.event = threading.Event()
        self.signal: int | None = None
        self._old: dict[int, Any] = {}

    def _handler(self, signum: int, frame: FrameType | None) -> None:
        if self.event.is_set() and signum == signal.SIGINT:
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


# ---------------------------------------------------------------- the logger


class Logger:
    """One ``aacmm log`` run (see :func:`cmd_log`)."""

    def __init__(self, args: argparse.Namespace, url: str) -> None:
        self.args = args
        self.url = url
        self.csv_path = Path(args.output)
        self.sidecar = sidecar_path(self.csv_path)
        self.trig_path: Path | None = None
        if not args.no_triggers:
            self.trig_path = (
                Path(args.triggers) if args.triggers else default_triggers_path(self.csv_path)
            )
        self.stop = StopFlag()
        self.s = Session()
        self.dev: Device | None = None
        self.rows: RowFile | None = None
        self.trig_rows: RowFile | None = None
        self.raw: RawCanRecorder | None = None
        self.meta: dict[str, Any] = {}
        self.t0 = 0.0
        self.start_wall = 0.0
        self.param_crc = 0
        self.serial_number = 0  # the device's, read at the start: reconnects take only it
        self.crc_text = ""  # the param_crc32 column of the rows being written
        self.param_sets: dict[int, ParamSetRecord] = {}
        self.trig_queue: collections.deque[tuple[float, Trigger]] = collections.deque()
        self.status = StatusLine(args.count, enabled=not args.quiet)
        self.granted_rate: int | None = None
        self.lost_error: str | None = None

    # ---------------------------------------------------------- set-up

    def check_outputs(self) -> None:
        a = self.args
        paths = [self.csv_path, self.sidecar]
        if self.trig_path is not None:
            paths.append(self.trig_path)
        if a.raw:
            paths.append(Path(a.raw))
        if len({p.resolve() for p in paths}) != len(paths):
            raise UsageError("the log, trigger and raw files must be different files")
        if not a.force:
            for p in paths:
                if p.exists():
                    raise UsageError(f"{p} exists (use --force to overwrite)")
        parent = self.csv_path.resolve().parent
        if not parent.is_dir():
            raise UsageError(f"directory {parent} does not exist")

    def _on_trigger(self, trig: Trigger) -> None:  # reader thread
        self.trig_queue.append((time.time(), trig))

    def connect(self) -> Device:
        dev = open_device(self.url, self.args.timeout, self.args.retries)
        dev.client.add_trigger_callback(self._on_trigger)
        return dev

    def base_meta(self, dev: Device, ps: ParamSetRecord) -> dict[str, Any]:
        a = self.args
        return {
            "format": FORMAT,
            "status": "running",
            "csv": self.csv_path.name,
            "columns": list(COLUMNS),
            "units": UNITS,
            "triggers_csv": None,
            "trigger_columns": list(TRIGGER_COLUMNS),
            "raw_can": Path(a.raw).name if a.raw else None,
            "port": self.url,
            "transport": dev.client.transport.description,
            "device": info_dict(dev.info),
            # the first set (what `aacmm params set run.csv.json` restores) ...
            "param_crc32": ps.crc32,
            "param_crc32_hex": ps.crc_hex,
            "params": ps.params_json(),
            "encoders": ps.encoders_json(),
            # ... and every set in force, each from the row where it began
            "param_sets": [],
            "rate_hz_requested": a.rate,
            "rate_hz": None,
            "limits": {"duration_s": a.duration, "count": a.count},
            "flush_policy": {"interval_s": FLUSH_INTERVAL_S, "rows": FLUSH_ROWS},
            "start_time": utc_iso(self.start_wall),
            "start_unix": self.start_wall,
            "end_time": None,
            "end_unix": None,
            "host": {
                "aacmm": __version__,
                "python": platform.python_version(),
                "node": platform.node(),
            },
        }

    def write_meta(self, status: str, end_reason: str | None = None) -> None:
        s = self.s
        m = self.meta
        m["status"] = status
        m["rate_hz"] = self.granted_rate
        m["samples"] = s.samples
        m["lost_samples"] = s.lost + s.dropped
        m["lost_detail"] = {
            "sequence_gaps": s.lost,
            "host_queue_dropped": s.dropped,
            "duplicates": s.duplicates,
            "overrun_flags": s.overruns,
        }
        m["triggers"] = s.triggers
        if self.trig_rows is not None:
            m["triggers_csv"] = self.trig_rows.path.name
        m["reconnects"] = s.reconnects
        m["gaps"] = s.gaps
        m["first_sample_host_time"] = s.first_host
        m["last_sample_host_time"] = s.last_host
        m["extent_mm"] = s.extent.as_dict()
        m["rate_hz_connected"] = s.rate_hz()
        if end_reason is not None:
            now = time.time()
            m["end_time"] = utc_iso(now)
            m["end_unix"] = now
            m["end_reason"] = end_reason
        write_json_atomic(self.sidecar, m)

    def use_param_set(self, ps: ParamSetRecord) -> None:
        """Rows from now on are taken with ``ps``; a set new to this log is added to the
        sidecar's ``param_sets`` (written by the caller's next :meth:`write_meta`)."""
        self.param_crc = ps.crc32
        self.crc_text = ps.crc_hex
        if ps.crc32 not in self.param_sets:
            self.param_sets[ps.crc32] = ps
            self.meta["param_sets"].append(
                param_set_entry(ps, self.s.samples, utc_iso(time.time()))
            )

    # ---------------------------------------------------------- writing

    def take(self, sample: Sample, host_time: float) -> None:
        s = self.s
        assert self.rows is not None
        self.rows.add(sample_row(sample, host_time, self.crc_text))
        s.samples += 1
        if s.first_host is None:
            s.first_host = host_time
        if s.seg_first is None:
            s.seg_first = host_time
        s.seg_rows += 1
        s.last_host = host_time
        s.last_seq = sample.seq
        if sample.status & POINT_VALID:
            s.extent.add(sample.point_100nm)

    def take_triggers(self) -> None:
        while self.trig_queue:
            host_time, trig = self.trig_queue.popleft()
            if self.trig_path is None:
                continue
            if self.trig_rows is None:
                self.trig_rows = open_rows(self.trig_path, TRIGGER_COLUMNS, True)
            extra = (trig.button, int(trig.pressed))
            self.trig_rows.add(sample_row(trig.sample, host_time, self.crc_text, extra))
            self.s.triggers += 1

    def account(self, stream: SampleStream) -> None:
        st = stream.stats
        self.s.lost += st.lost
        self.s.duplicates += st.duplicates
        self.s.overruns += st.overruns
        self.s.dropped += st.dropped

    # ---------------------------------------------------------- the run

    def target_reached(self) -> str | None:
        a = self.args
        if a.count is not None and self.s.samples >= a.count:
            return "count"
        if a.duration is not None and time.monotonic() - self.t0 >= a.duration:
            return "duration"
        return None

    def stream_once(self, dev: Device) -> str:
        """Stream until a stop condition; return the reason (or raise LinkLostError)."""
        a = self.args
        client = dev.client
        stall = max(a.stall, 2.0 / a.rate + 0.1)
        stream = client.stream(a.rate, timeout=stall, max_queue=1_000_000)
        if stream.accepted is not None:
            self.granted_rate = stream.accepted.rate_hz
        last_sample = time.monotonic()
        pending_status = 0
        last_status = last_sample
        reason: str | None = None
        link_error: BaseException | None = None
        try:
            while True:
                reason = self.target_reached()
                if reason is not None:
                    break
                if self.stop.set:
                    reason = "signal"
                    break
                try:
                    sample = stream.get(timeout=0.1)
                except DeviceTimeoutError:
                    now = time.monotonic()
                    if now - last_sample >= stall:
                        link_error = LinkLostError(f"no sample for {now - last_sample:.1f} s")
                        break
                    sample = None
                except StopIteration:
                    link_error = LinkLostError("the stream ended unexpectedly")
                    break
                except OperationError as exc:
                    link_error = LinkLostError(f"link lost: {exc}")
                    break
                now = time.monotonic()
                if sample is not None:
                    last_sample = now
                    self.take(sample, time.time())
                    pending_status += 1
                if self.trig_queue:
                    self.take_triggers()
                assert self.rows is not None
                self.rows.maybe_flush(now)
                if self.trig_rows is not None:
                    self.trig_rows.maybe_flush(now)
                if now - last_status >= 0.25:
                    self.status.update(pending_status, self.status_text(stream))
                    pending_status, last_status = 0, now
        finally:
            self.status.update(pending_status, self.status_text(stream))
            if link_error is None and not client.closed:
                with contextlib.suppress(AacmmError):
                    stream.stop()
            # samples received before the stop are still queued
            while True:
                try:
                    leftover = stream.get(timeout=0.0)
                except (StopIteration, AacmmError):
                    break
                if self.args.count is not None and self.s.samples >= self.args.count:
                    break
                self.take(leftover, time.time())
            self.take_triggers()
            self.account(stream)
        if link_error is not None:
            raise link_error
        assert reason is not None
        return reason

    def status_text(self, stream: SampleStream | None) -> str:
        lost = self.s.lost + self.s.dropped
        if stream is not None:
            lost += stream.stats.lost + stream.stats.dropped
        text = f"lost {lost}"
        if self.s.triggers:
            text += f", triggers {self.s.triggers}"
        if self.s.reconnects:
            text += f", reconnects {self.s.reconnects}"
        return text

    @staticmethod
    def drop(dev: Device) -> None:
        """Close a device whose link is lost without waiting for it: the transport
        first, so no STREAM_STOP is sent (over CAN a silent device would cost
        a full request timeout with its retries)."""
        with contextlib.suppress(Exception):
            dev.client.transport.close()
        dev.close()

    def check_same_device(self, dev: Device, gap: dict[str, Any]) -> None:
        """A reconnect takes only the device the log began with (its serial number):
        another one answering at the port (another arm plugged in, or a port name
        now given to someone else's device) is refused, said once, and waited past.

        Raises:
            InitError: another device.
        """
        serial = dev.info.serial_number
        if serial == self.serial_number:
            return
        why = (
            f"{self.url}: another device answers (serial {serial}; this log's is "
            f"{self.serial_number}): not taken"
        )
        if gap.get("last_error") != why:
            print_err("log", f"warning: {why}")
        raise InitError(why)

    def reconnect(self, err: BaseException) -> Device | None:
        """Try to get the device back; None if stopped or given up."""
        a = self.args
        gap: dict[str, Any] = {
            "start_time": utc_iso(time.time()),
            "after_row": self.s.samples,
            "last_seq": self.s.last_seq,
            "reason": str(err),
        }
        self.s.gaps.append(gap)
        self.s.end_segment()
        self.write_meta("running")
        if not a.quiet:
            self.status.note("link lost, reconnecting")
        print_err("log", f"{err}; reconnecting (Ctrl-C to stop)")
        t_lost = time.monotonic()
        attempts = 0
        while True:
            if self.stop.set or self.target_reached() == "duration":
                gap["end_time"] = None
                return None
            if a.reconnect_timeout is not None and time.monotonic() - t_lost >= a.reconnect_timeout:
                gap["end_time"] = None
                gap["gave_up"] = True
                return None
            self.stop.event.wait(RECONNECT_PAUSE_S)
            if self.stop.set:
                continue
            attempts += 1
            from aacmm.records.paramsets import ParamSetRecord

            try:
                dev = self.connect()
                try:
                    self.check_same_device(dev, gap)
                    ps = ParamSetRecord.from_device(dev.client.get_params())
                except BaseException:
                    self.drop(dev)
                    raise
            except VersionMismatchError:
                raise
            except (InitError, DeviceTimeoutError, OperationError) as exc:
                gap["last_error"] = str(exc)
                continue
            except AacmmError as exc:
                gap["last_error"] = str(exc)
                continue
            break
        now = time.time()
        gap["end_time"] = utc_iso(now)
        gap["duration_s"] = round(time.monotonic() - t_lost, 3)
        gap["attempts"] = attempts
        gap["param_crc32"] = ps.crc32
        if ps.crc32 != self.param_crc:
            gap["params_changed"] = True
            print_err(
                "log",
                f"warning: the device's parameter set changed (crc {ps.crc_hex}, was "
                f"0x{self.param_crc:08x}); rows from {self.s.samples + 1} on use it "
                "(sidecar param_sets)",
            )
        self.use_param_set(ps)
        gap.pop("last_error", None)
        self.s.reconnects += 1
        self.write_meta("running")
        print_err("log", f"reconnected after {gap['duration_s']:.1f} s; logging on")
        return dev

    def run(self) -> int:
        a = self.args
        self.check_outputs()
        kind, channel, node = url_kind(self.url)
        if a.raw:
            if kind not in ("socketcan", "virtual"):
                raise UsageError("--raw records CAN frames: it needs a socketcan:// port")
            raw_path = Path(a.raw)
            if raw_path.suffix.lower() not in RAW_SUFFIXES:
                raise UsageError(
                    f"--raw {raw_path}: the suffix picks the format: {', '.join(RAW_SUFFIXES)}"
                )
            self.raw = RawCanRecorder(raw_path, kind, channel, node, a.force)
        self.stop.install()
        try:
            code = self._run()
            if self.lost_error is not None:
                raise OperationError(self.lost_error)
            return code
        finally:
            self.stop.restore()
            self.status.close()
            if self.raw is not None:
                self.raw.stop()

    def _run(self) -> int:
        from aacmm.records.paramsets import ParamSetRecord

        a = self.args
        dev = self.connect()
        self.serial_number = dev.info.serial_number
        end_status, end_reason = "error", "error"
        error: BaseException | None = None
        try:
            ps = ParamSetRecord.from_device(dev.client.get_params())
            if ps.crc32 != dev.info.param_crc32:
                print_err(
                    "log",
                    f"warning: the device reports parameter CRC 0x{dev.info.param_crc32:08x}, "
                    f"its parameter set hashes to {ps.crc_hex}",
                )
            self.start_wall = time.time()
            self.t0 = time.monotonic()
            self.rows = open_rows(self.csv_path, COLUMNS, a.force)
            self.meta = self.base_meta(dev, ps)
            self.use_param_set(ps)
            self.write_meta("running")
            self.dev = dev
            while True:
                try:
                    reason = self.stream_once(dev)
                except LinkLostError as exc:
                    self.drop(dev)
                    self.dev = None
                    if not a.reconnect:
                        raise
                    new = self.reconnect(exc)
                    if new is None:
                        reason = "signal" if self.stop.set else self.target_reached() or ""
                        if not reason:
                            raise LinkLostError(
                                f"{exc}; device not back within {a.reconnect_timeout:g} s"
                            ) from None
                        break
                    dev = self.dev = new
                    continue
                break
            if reason == "signal":
                sig = "SIGTERM" if self.stop.signal == signal.SIGTERM else "SIGINT"
                open_ended = a.count is None and a.duration is None
                end_status = "complete" if open_ended else "interrupted"
                end_reason = sig
                code = OK if open_ended else INTERRUPTED
            else:
                end_status, end_reason, code = "complete", reason, OK
            if end_status == "complete":
                # a run that lost samples, or bridged gaps, is not complete (#14.2)
                lost = self.s.lost + self.s.dropped
                why = []
                if lost:
                    why.append(f"{lost} samples lost")
                    self.lost_error = (
                        f"{lost} samples lost ({self.s.lost} in sequence gaps, "
                        f"{self.s.dropped} dropped on the host); the log is kept, status incomplete"
                    )
                if self.s.gaps:
                    why.append(f"{len(self.s.gaps)} reconnect gaps")
                if why:
                    end_status = "incomplete"
                    end_reason = f"{end_reason}; " + ", ".join(why)
            return code
        except LinkLostError as exc:
            end_status, end_reason = "link_lost", str(exc)
            error = exc
            raise LinkLostError(
                f"{exc}; {self.s.samples} samples kept in {self.csv_path}"
            ) from None
        except BaseException as exc:
            error = exc
            end_reason = f"{type(exc).__name__}: {exc}"
            if isinstance(exc, KeyboardInterrupt):
                end_status, end_reason = "interrupted", "SIGINT"
            raise
        finally:
            if self.dev is not None:
                self.dev.close()
            self.take_triggers()
            if self.rows is not None:
                self.rows.close()
                if self.trig_rows is not None:
                    self.trig_rows.close()
                self.write_meta(end_status, end_reason)
            if not a.quiet and self.rows is not None:
                self.status.close()
                self.print_summary(error)

    def print_summary(self, error: BaseException | None) -> None:
        s = self.s
        elapsed = (s.last_host - s.first_host) if s.first_host and s.last_host else 0.0
        summary = {
            "samples": s.samples,
            "duration_s": elapsed,
            "rate_hz": s.rate_hz(),
            "gap_s": [g.get("duration_s") for g in s.gaps],
            "lost_samples": s.lost + s.dropped,
            "triggers": s.triggers,
            "reconnects": s.reconnects,
            "extent_mm": s.extent.as_dict(),
        }
        files = [self.csv_path, self.sidecar]
        if self.trig_rows is not None:
            files.append(self.trig_rows.path)
        if self.raw is not None:
            files.append(self.raw.path)
        out = sys.stdout if error is None and self.lost_error is None else sys.stderr
        print(format_summary(summary, files), file=out, flush=True)


def cmd_log(args: argparse.Namespace) -> int:
    if not 1 <= args.rate <= 1000:
        raise UsageError(f"--rate {args.rate} outside 1..1000 Hz")
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise UsageError("--duration must be a positive number of seconds")
    if args.count is not None and args.count < 1:
        raise UsageError("--count must be at least 1")
    if args.reconnect_timeout is not None and not args.reconnect_timeout > 0:
        raise UsageError("--reconnect-timeout must be positive")
    if not args.stall > 0:
        raise UsageError("--stall must be positive")
    if args.no_triggers and args.triggers:
        raise UsageError("--triggers and --no-triggers exclude each other")
    url = port_url(args)
    return Logger(args, url).run()
