"""The Logger: one ``aacmm log`` run on the device: stream, stop conditions, reconnects."""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aacmm.commands.common import (
    StatusLine,
    device_param_set,
    open_device,
    print_err,
    url_kind,
)
from aacmm.commands.exitcodes import INTERRUPTED, OK, UsageError
from aacmm.commands.stopflag import StopFlag
from aacmm.commands.summary import format_summary
from aacmm.errors import (
    AacmmError,
    DeviceTimeoutError,
    InitError,
    LinkLostError,
    OperationError,
    VersionMismatchError,
)
from aacmm.records.files import utc_iso
from aacmm.records.logwriter import LogOptions, LogWriter, open_rows
from aacmm.records.rawcan import RAW_SUFFIXES, RawCanRecorder
from aacmm.records.schema import log_columns

if TYPE_CHECKING:
    from aacmm.commands.common import Device
    from aacmm.protocol import Trigger

RECONNECT_PAUSE_S = 0.5


def log_options(args: argparse.Namespace) -> LogOptions:
    """The files and limits of ``aacmm log``'s arguments (checked by the command)."""
    return LogOptions(
        output=Path(args.output),
        rate_hz=args.rate,
        triggers=Path(args.triggers) if args.triggers else None,
        write_triggers=not args.no_triggers,
        raw=Path(args.raw) if args.raw else None,
        force=args.force,
        duration_s=args.duration,
        count=args.count,
    )


class Logger(LogWriter):
    """One ``aacmm log`` run (see :func:`aacmm.commands.log.cmd_log`)."""

    def print_summary(self, error: BaseException | None) -> None:
        """The summary lines, on stdout (stderr after an error or a lost link)."""
        summary, files = self.summary()
        out = sys.stdout if error is None and self.lost_error is None else sys.stderr
        print(format_summary(summary, files), file=out, flush=True)

    def __init__(self, args: argparse.Namespace, url: str) -> None:
        super().__init__(log_options(args), url)
        self.args = args
        self.stop = StopFlag()
        self.dev: Device | None = None
        self.t0 = 0.0
        self.serial_number = 0  # the device's, read at the start: reconnects take only it
        self.status = StatusLine(args.count, enabled=not args.quiet)

    # ---------------------------------------------------------- the device

    def _on_trigger(self, trig: Trigger) -> None:  # reader thread
        self.trig_queue.append((time.time(), trig))

    def connect(self) -> Device:
        dev = open_device(self.url, self.args.timeout, self.args.retries)
        dev.client.add_trigger_callback(self._on_trigger)
        return dev

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
        from aacmm.client.devstate import stream_temperatures

        ps = self.param_sets[self.param_crc]
        temps = stream_temperatures(client.transport, dev.info, ps.thermal)
        stream = client.stream(a.rate, timeout=stall, max_queue=1_000_000, temperatures=temps)
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
        self.stop.immediate = True  # until the log starts: opening the device
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

        a = self.args
        dev = self.connect()
        self.serial_number = dev.info.serial_number
        end_status, end_reason = "error", "error"
        error: BaseException | None = None
        try:
            ps = device_param_set("log", dev)
            self.start_wall = time.time()
            self.t0 = time.monotonic()
            self.stop.immediate = False  # from here a signal ends the log cleanly
            self.rows = open_rows(self.csv_path, log_columns(ps.joints), a.force)
            self.meta = self.base_meta(dev.client, dev.info, ps)
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
