"""What an ``aacmm log`` run writes: the sample and trigger rows, the sidecar,
and the figures of its summary.

Errors: :class:`aacmm.fileio.OutputExistsError` (a file exists, no ``force``)
and :class:`aacmm.fileio.OutputFileError` (a file cannot be created).
"""

from __future__ import annotations

import collections
import platform
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aacmm import __version__
from aacmm.fileio import OutputExistsError, OutputFileError
from aacmm.records.files import RecordError, RowFile, utc_iso, write_json_atomic
from aacmm.records.logsession import Session
from aacmm.records.schema import (
    LOG_COLUMNS,
    LOG_FORMAT,
    LOG_UNITS,
    TEMP_NONE_WIRE,
    default_triggers_path,
    log_columns,
    log_units,
    param_set_entry,
    sample_row,
    sidecar_path,
    trigger_columns,
)

if TYPE_CHECKING:
    from aacmm.client import Client, SampleStream
    from aacmm.protocol import DeviceInfo, Sample, Trigger
    from aacmm.records.paramsets import ParamSetRecord
    from aacmm.records.rawcan import RawCanRecorder

FORMAT = LOG_FORMAT
COLUMNS = LOG_COLUMNS
"""The paper's arm's columns (another arm's: :func:`aacmm.records.schema.log_columns`)."""
UNITS = LOG_UNITS
FLUSH_INTERVAL_S = 0.25
FLUSH_ROWS = 256
POINT_VALID = 0x0001


def open_rows(path: Path, columns: tuple[str, ...], force: bool) -> RowFile:
    """A :class:`aacmm.records.files.RowFile` with the log's flush policy.

    Raises:
        OutputExistsError: the file exists (without ``force``).
        OutputFileError: it cannot be created.
    """
    try:
        return RowFile(path, columns, force, FLUSH_INTERVAL_S, FLUSH_ROWS)
    except FileExistsError:
        raise OutputExistsError(f"{path} exists (use --force to overwrite)") from None
    except OSError as exc:
        raise OutputFileError(f"cannot create {path}: {exc.strerror}") from None


@dataclass(frozen=True)
class LogOptions:
    """What one ``aacmm log`` run writes, and the limits its sidecar records."""

    output: Path  #: the log's CSV file (its sidecar is ``output`` + ``.json``)
    rate_hz: int  #: the sample rate asked for
    #: the trigger file; None: ``FILE.triggers.csv`` beside the log (with ``write_triggers``)
    triggers: Path | None = None
    write_triggers: bool = True  #: record button captures
    raw: Path | None = None  #: the raw CAN frames' file, if any
    force: bool = False  #: overwrite existing files
    duration_s: float | None = None  #: the run's time limit, if any
    count: int | None = None  #: the run's sample limit, if any


class LogWriter:
    """The files and counters of one ``aacmm log`` run, as ``options`` says
    (the ``aacmm log`` command adds the device)."""

    def __init__(self, options: LogOptions, url: str) -> None:
        self.options = options
        self.url = url
        self.csv_path = options.output
        self.sidecar = sidecar_path(self.csv_path)
        self.trig_path: Path | None = None
        if options.write_triggers:
            self.trig_path = options.triggers or default_triggers_path(self.csv_path)
        self.s = Session()
        self.rows: RowFile | None = None
        self.trig_rows: RowFile | None = None
        self.raw: RawCanRecorder | None = None
        self.meta: dict[str, Any] = {}
        self.start_wall = 0.0
        self.param_crc = 0
        self.crc_text = ""  # the param_crc32 column of the rows being written
        self.param_sets: dict[int, ParamSetRecord] = {}
        self.joints: int | None = None  # N of the log's count columns (its first set's)
        self.trig_queue: collections.deque[tuple[float, Trigger]] = collections.deque()
        self.granted_rate: int | None = None
        self.lost_error: str | None = None

    # ---------------------------------------------------------- set-up

    def check_outputs(self) -> None:
        """Before the device is opened: the files are distinct, absent (or ``force``)
        and their folders writable.

        Raises:
            OutputExistsError: a file exists (without ``force``).
            OutputFileError: two files are one, or a folder is missing or not writable.
        """
        a = self.options
        paths = [self.csv_path, self.sidecar]
        if self.trig_path is not None:
            paths.append(self.trig_path)
        if a.raw is not None:
            paths.append(a.raw)
        if len({p.resolve() for p in paths}) != len(paths):
            raise OutputFileError("the log, trigger and raw files must be different files")
        if not a.force:
            for p in paths:
                if p.exists():
                    raise OutputExistsError(f"{p} exists (use --force to overwrite)")
        parent = self.csv_path.resolve().parent
        if not parent.is_dir():
            raise OutputFileError(f"directory {parent} does not exist")
        from aacmm.fileio import check_writable_dir

        for d in dict.fromkeys(p.resolve().parent for p in paths):  # before the device
            check_writable_dir(d, str(self.csv_path if d == parent else d))

    def base_meta(self, client: Client, info: DeviceInfo, ps: ParamSetRecord) -> dict[str, Any]:
        from aacmm.client.devstate import info_dict

        a = self.options
        self.joints = ps.joints
        return {
            "format": FORMAT,
            "status": "running",
            "csv": self.csv_path.name,
            "joints": ps.joints,
            "columns": list(log_columns(ps.joints)),
            "units": log_units(ps.joints),
            "triggers_csv": None,
            "trigger_columns": list(trigger_columns(ps.joints)),
            "raw_can": a.raw.name if a.raw is not None else None,
            "port": self.url,
            "transport": client.transport.description,
            "device": info_dict(info),
            # the first set (what `aacmm params set run.csv.json` restores) ...
            "param_crc32": ps.crc32,
            "param_crc32_hex": ps.crc_hex,
            "params": ps.params_json(),
            "encoders": ps.encoders_json(),
            **({"errmodel": ps.errmodel_json()} if ps.errors is not None else {}),
            # ... and every set in force, each from the row where it began
            "param_sets": [],
            "rate_hz_requested": a.rate_hz,
            "rate_hz": None,
            "limits": {"duration_s": a.duration_s, "count": a.count},
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
        m["presses"] = s.presses
        if self.trig_rows is not None:
            m["triggers_csv"] = self.trig_rows.path.name
        m["reconnects"] = s.reconnects
        m["gaps"] = s.gaps
        m["first_sample_host_time"] = s.first_host
        m["last_sample_host_time"] = s.last_host
        m["extent_mm"] = s.extent.as_dict()
        m["temperature_c"] = s.temps.as_dict()
        m["rate_hz_connected"] = s.rate_hz()
        if end_reason is not None:
            now = time.time()
            m["end_time"] = utc_iso(now)
            m["end_unix"] = now
            m["end_reason"] = end_reason
        write_json_atomic(self.sidecar, m)

    def use_param_set(self, ps: ParamSetRecord) -> None:
        """Rows from now on are taken with ``ps``; a set new to this log is added to the
        sidecar's ``param_sets`` (written by the caller's next :meth:`write_meta`).

        Raises:
            RecordError: ``ps`` is an arm of another joint count than the log's columns.
        """
        if self.joints is not None and ps.joints != self.joints:
            raise RecordError(
                f"{self.csv_path}: the device's parameter set {ps.crc_hex} is an arm of "
                f"{ps.joints} joints; this log has {self.joints} count columns: start a new log"
            )
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
        s.temps.add(sample.temp, TEMP_NONE_WIRE)

    def take_triggers(self) -> None:
        while self.trig_queue:
            host_time, trig = self.trig_queue.popleft()
            if self.trig_path is None:
                continue
            if self.trig_rows is None:
                self.trig_rows = open_rows(self.trig_path, trigger_columns(self.joints or 6), True)
            extra = (trig.button, int(trig.pressed))
            self.trig_rows.add(sample_row(trig.sample, host_time, self.crc_text, extra))
            self.s.triggers += 1
            self.s.presses += int(trig.pressed)

    def account(self, stream: SampleStream) -> None:
        st = stream.stats
        self.s.lost += st.lost
        self.s.duplicates += st.duplicates
        self.s.overruns += st.overruns
        self.s.dropped += st.dropped

    def status_text(self, stream: SampleStream | None) -> str:
        lost = self.s.lost + self.s.dropped
        if stream is not None:
            lost += stream.stats.lost + stream.stats.dropped
        text = f"lost {lost}"
        if self.s.triggers:
            text += f", presses {self.s.presses}"
        if self.s.reconnects:
            text += f", reconnects {self.s.reconnects}"
        return text

    def summary(self) -> tuple[dict[str, Any], list[Path]]:
        """The run's summary figures (what ``aacmm log`` prints at its end) and the
        files it wrote."""
        s = self.s
        elapsed = (s.last_host - s.first_host) if s.first_host and s.last_host else 0.0
        summary = {
            "samples": s.samples,
            "duration_s": elapsed,
            "rate_hz": s.rate_hz(),
            "gap_s": [g.get("duration_s") for g in s.gaps],
            "lost_samples": s.lost + s.dropped,
            "triggers": s.triggers,
            "presses": s.presses,
            "reconnects": s.reconnects,
            "extent_mm": s.extent.as_dict(),
            "temperature_c": s.temps.as_dict(),
        }
        files = [self.csv_path, self.sidecar]
        if self.trig_rows is not None:
            files.append(self.trig_rows.path)
        if self.raw is not None:
            files.append(self.raw.path)
        return summary, files
