"""Logs written by ``aacmm log``: the schema, row formatting, and the reader.

A log ``run.csv`` has a sidecar ``run.csv.json`` and a trigger file
``run.triggers.csv`` (format in docs/cli.md). Format ``aacmm-log-2`` adds,
on every row, the CRC of the parameter set in force (``param_crc32``), and
to the sidecar every set in force (``param_sets``, with the row where each
began), so a log that spans a reconnect to a device with another set is
converted row by row with the right one. ``aacmm-log-1`` logs (one set in
the sidecar) are read as well; rows after a recorded parameter change are
refused, since that format did not keep the new set.

A log of an arm of N joints (4 to 7) has the count columns
``count1..countN``; its parameter sets are arms of N joints. The reader
takes N from the header and refuses a log whose parameter sets are arms of
another joint count (one line, :class:`RecordError`), before anything is
computed.

The reader also accepts plain CSV files of poses (``count1..count6`` or
``c1..c6``, or ``theta1..theta6`` in rad; ``#`` comments) with an optional
sidecar holding ``encoders`` and ``params``, for ``aacmm mc --log``.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aacmm.core import EncoderConfig, FloatArray, Params
from aacmm.protocol import Sample, param_set_crc32
from aacmm.records.files import CsvTable, RecordError, crc_hex, read_json
from aacmm.records.paramsets import SHAPE_KEYS, ParamSetRecord, param_set_from_json
from aacmm.records.rows import Recorded
from aacmm.records.schema import (
    COUNT_COLUMNS,
    JOINTS,
    JOINTS_MAX,
    JOINTS_MIN,
    LOG_FORMAT,
    LOG_FORMATS_READ,
    POINT_COLUMNS,
    TEMP_MAX_C,
    TEMP_MIN_C,
    TEMP_NONE_WIRE,
    THETA_COLUMNS,
    count_aliases,
    count_columns,
    default_triggers_path,
    joint_count,
    sidecar_path,
    temp_columns,
    theta_columns,
)

__all__ = [
    "Log",
    "LoggedTrigger",
    "column",
    "connected_segments",
    "log_summary",
    "read_log",
    "read_triggers",
    "temperature_summary",
]

# ---------------------------------------------------------------- reader

#: Sidecar statuses of a log whose logger ended (its counts are final).
FINAL_LOG_STATUSES: tuple[str, ...] = (
    "complete",
    "incomplete",
    "interrupted",
    "link_lost",
    "error",
)


@dataclass(frozen=True, eq=False)
class Log(Recorded):
    """A log (or a plain CSV of poses) read by :func:`read_log`.

    ``counts``/``param_crc32``/``param_sets`` as :class:`Recorded` (empty
    counts for a file of angles); ``theta_rad`` holds the angles of a file of
    angles, else None. ``params_given``: the kinematic parameters come from
    the file (a set in force, or a sidecar's ``params``), not defaults.
    """

    meta: dict[str, Any]
    format: str | None
    columns: tuple[str, ...]
    table: CsvTable
    sidecar: Path | None
    theta_given: FloatArray | None = None
    params_given: bool = False
    warnings: tuple[str, ...] = field(default=())

    def angles_rad(self) -> FloatArray:
        if self.theta_given is not None:
            return self.theta_given
        return super().angles_rad()

    def where(self, row: int) -> str:
        return f"{self.path}:{self.table.rows[row][0]}"

    def column(self, name: str, kind: str = "float") -> npt.NDArray[Any]:
        """A column as an array (``kind``: "float", "int" or "str").

        Raises:
            RecordError: no such column, or a value that is not a number (with its line).
        """
        return column(self.table, name, kind)

    def row_temperatures(self) -> FloatArray | None:
        return self.temperatures_c()

    def temperatures_c(self) -> FloatArray | None:
        """The device's link temperatures (n, N) in degC, NaN where a sample has no
        reading; None for a log without the columns (written before issue 27).

        Raises:
            RecordError: a value that is not a number (with its line).
        """
        cols = temp_columns(self.joints)
        if not all(c in self.table.header for c in cols):
            return None
        k = [self.table.index(c) for c in cols]
        out = np.full((len(self.table), len(cols)), np.nan)
        for r, (line, row) in enumerate(self.table):
            for j, i in enumerate(k):
                v = row[i] if i < len(row) else ""
                if v == "":
                    continue
                try:
                    x = float(v)
                except ValueError:
                    x = math.nan
                # the device sends i16 hundredths of a degree: NaN, inf or 999 are damage
                if not (math.isfinite(x) and TEMP_MIN_C <= x <= TEMP_MAX_C):
                    raise self.table.fail(line, f"{cols[j]}: {v!r} is not a temperature in degC")
                out[r, j] = x
        return out

    @property
    def damage(self) -> tuple[str, ...]:
        """What the sidecar and the files disagree on (empty for a sound log): a
        finished log whose CSV holds other than the samples its sidecar counts (cut
        short, or rows added), or whose trigger file holds other than its triggers.
        A log still ``running`` (its logger killed) is not judged: its sidecar's
        counts were never final."""
        meta = self.meta
        if self.format is None or meta.get("status") not in FINAL_LOG_STATUSES:
            return ()
        out = []
        want = meta.get("samples")
        if isinstance(want, int) and not isinstance(want, bool) and want != len(self.table):
            out.append(
                f"the sidecar counts {want} samples, {self.path.name} holds {len(self.table)} "
                f"rows ({'cut short' if len(self.table) < want else 'rows added'})"
            )
        trig = self.trigger_path
        want_t = meta.get("triggers")
        if trig is not None and isinstance(want_t, int) and not isinstance(want_t, bool):
            try:
                have_t = len(CsvTable(trig, "trigger file")) if trig.is_file() else 0
            except RecordError:
                have_t = -1
            if have_t != want_t and not (have_t == 0 and want_t == 0):
                held = "is unreadable" if have_t < 0 else f"holds {have_t} rows"
                out.append(f"the sidecar counts {want_t} trigger rows, {trig.name} {held}")
        return tuple(out)

    @property
    def trigger_path(self) -> Path | None:
        """The trigger file the sidecar names (None when it names none)."""
        name = self.meta.get("triggers_csv")
        return self.path.with_name(name) if isinstance(name, str) and name else None

    @property
    def gaps(self) -> list[dict[str, Any]]:
        g = self.meta.get("gaps")
        return [x for x in g if isinstance(x, dict)] if isinstance(g, list) else []


def column(t: CsvTable, name: str, kind: str = "float", what: str = "") -> npt.NDArray[Any]:
    """A column of a table as an array (see :meth:`Log.column`)."""
    if name not in t.header:
        raise RecordError(f"{t.path}: no column {name!r}")
    i = t.index(name)
    raw = [row[i] if i < len(row) else "" for _, row in t.rows]
    if kind == "str":
        return np.array(raw, dtype=object)
    dtype = np.float64 if kind == "float" else np.int64
    try:
        return np.array(raw, dtype=dtype)
    except (ValueError, OverflowError):
        for (line, _), v in zip(t.rows, raw, strict=True):
            try:
                float(v) if kind == "float" else np.int64(int(v))
            except (ValueError, OverflowError):
                raise t.fail(line, f"{what}{name}: {v!r} is not a number") from None
        raise


def _find_sidecar(path: Path) -> Path | None:
    for cand in (sidecar_path(path), path.with_suffix(".json")):
        if cand != path and cand.is_file():
            return cand
    return None


def _plain_set(
    meta: dict[str, Any], side: Path | None, joints: int, path: Path
) -> tuple[ParamSetRecord, bool]:
    """The one set of a plain CSV's sidecar (``encoders``/``params``, no CRC needed)."""
    kin = meta.get("params")
    if joints != JOINTS or (isinstance(kin, dict) and any(k in kin for k in SHAPE_KEYS)):
        return _plain_arm_set(meta, side, joints, path), True
    enc, params, given = EncoderConfig(), Params(), False
    if "encoders" in meta:
        e = meta["encoders"]
        try:
            enc = EncoderConfig(
                counts_per_rev=e.get("counts_per_rev", enc.counts_per_rev),
                zero_offset_counts=e.get("zero_offset_counts", enc.zero_offset_counts),
                direction=e.get("direction", enc.direction),
            )
            enc.to_c()
        except (AttributeError, TypeError, ValueError) as exc:
            raise RecordError(f'{side}: bad "encoders": {exc}') from None
    if "params" in meta:
        try:
            params = Params(**meta["params"])
            params.validate()
        except (TypeError, ValueError) as exc:
            raise RecordError(f'{side}: bad "params": {exc}') from None
        given = True
    ps = ParamSetRecord(0, params, enc)
    try:
        crc = param_set_crc32(ps.to_device())
    except ValueError as exc:
        raise RecordError(f"{side}: bad parameter set: {exc}") from None
    return ParamSetRecord(crc, params, enc), given


def _plain_arm_set(
    meta: dict[str, Any], side: Path | None, joints: int, path: Path
) -> ParamSetRecord:
    """A plain CSV of an arm other than the paper's: its sidecar's ``params`` (N values
    per list, the shape keys of a log's sets) and ``encoders`` (default: 2^32 counts
    per revolution, offset 0, direction +1)."""
    kin, enc = meta.get("params"), meta.get("encoders", {})
    if not isinstance(kin, dict):
        raise RecordError(
            f"{path}: {joints} joint columns: a file of poses of an arm other than the "
            "paper's needs a sidecar with the arm's \"params\" (one value per joint)"
        )
    if not isinstance(enc, dict):
        raise RecordError(f'{side}: "encoders" must be an object')
    d = EncoderConfig.default(joints)
    full = {
        "counts_per_rev": enc.get("counts_per_rev", list(d.counts_per_rev)),
        "zero_offset_counts": enc.get("zero_offset_counts", list(d.zero_offset_counts)),
        "direction": enc.get("direction", list(d.direction)),
    }
    return ParamSetRecord.from_device(param_set_from_json(kin, full, str(side)))


def _v1_sets(
    meta: dict[str, Any], side: Path, n: int, path: Path
) -> tuple[dict[int, ParamSetRecord], npt.NDArray[np.uint32]]:
    """aacmm-log-1: the sidecar's one set for every row, unless a gap changed it."""
    first = ParamSetRecord.from_json(
        {k: meta.get(k) for k in ("param_crc32", "params", "encoders")}, str(side)
    )
    for gap in meta.get("gaps") or []:
        if isinstance(gap, dict) and gap.get("params_changed"):
            row = gap.get("after_row")
            raise RecordError(
                f"{path}: the parameter set changed after row {row} (reconnect), and this "
                "log format (aacmm-log-1) kept only the first set: rows after it cannot "
                "be converted; cut the log there"
            )
    return {first.crc32: first}, np.full(n, first.crc32, dtype=np.uint32)


def _v2_sets(
    meta: dict[str, Any], side: Path, t: CsvTable
) -> tuple[dict[int, ParamSetRecord], npt.NDArray[np.uint32]]:
    raw = meta.get("param_sets")
    if not isinstance(raw, list) or not raw:
        raise RecordError(f"{side}: param_sets must be a non-empty list")
    sets = {
        ps.crc32: ps
        for ps in (
            ParamSetRecord.from_json(d, f"{side}: param_sets[{i}]") for i, d in enumerate(raw)
        )
    }
    crcs = column(t, "param_crc32", "str")
    out = np.empty(len(crcs), dtype=np.uint32)
    cache: dict[str, int] = {}
    for k, (s, (line, _)) in enumerate(zip(crcs, t.rows, strict=True)):
        c = cache.get(s)
        if c is None:
            try:
                c = int(s, 16) if s.startswith("0x") else -1
            except ValueError:
                c = -1
            if c not in sets:
                raise t.fail(line, f"parameter set {s!r} is not listed in {side.name}")
            cache[s] = c
        out[k] = c
    return sets, out


def read_log(path: str | Path, encoders: EncoderConfig | None = None) -> Log:
    """Read a log (or a plain CSV of poses) with its sidecar.

    ``encoders`` overrides the encoder configuration of every row (plain
    files and tests). A last row cut short by a killed logger is dropped.

    Raises:
        RecordError: unreadable file or sidecar, no joint columns, a bad value
            (with its line), no rows, a parameter set that does not match its
            CRC, or rows whose parameter set the file does not hold.
    """
    p = Path(path)
    t = CsvTable(p, "log")
    header = t.header
    for stem, names in (("count", count_columns), ("c", count_aliases), ("theta", theta_columns)):
        joints = joint_count(header, stem)
        if joints:
            cols = names(joints)
            break
    else:
        raise RecordError(
            f"{p}: header has no joint columns (need {','.join(COUNT_COLUMNS)} "
            f"or {','.join(THETA_COLUMNS)}, one per joint); got {','.join(header)}"
        )
    if not JOINTS_MIN <= joints <= JOINTS_MAX:
        raise RecordError(
            f"{p}: {joints} joint columns ({cols[0]}..{cols[-1]}); an arm has "
            f"{JOINTS_MIN} to {JOINTS_MAX} joints"
        )
    if not t.rows:
        raise RecordError(f"{p}: log has a header but no poses")
    side = _find_sidecar(p)
    meta: dict[str, Any] = read_json(side) if side is not None else {}
    fmt = meta.get("format") if isinstance(meta.get("format"), str) else None
    if fmt is not None and fmt.startswith("aacmm-log-") and fmt not in LOG_FORMATS_READ:
        raise RecordError(f"{side}: log format {fmt!r} is newer than this aacmm reads")
    n = len(t.rows)
    theta = None
    counts = np.zeros((0, joints), dtype=np.uint64)
    if stem == "theta":
        theta = np.column_stack([column(t, c, what="bad joint value: ") for c in cols])
        if not np.all(np.isfinite(theta)):
            raise RecordError(f"{p}: joint angles must be finite")
    else:
        raw = np.column_stack([column(t, c, "int", "bad joint value: ") for c in cols])
        bad = np.flatnonzero(((raw < 0) | (raw > 0xFFFFFFFF)).any(axis=1))
        if bad.size:
            raise t.fail(t.rows[int(bad[0])][0], "encoder reading outside 0 .. 2^32-1")
        counts = raw.astype(np.uint64)
    given = False
    if fmt == LOG_FORMAT and side is not None:
        sets, crc = _v2_sets(meta, side, t)
        given = True
    elif fmt == "aacmm-log-1" and side is not None:
        sets, crc = _v1_sets(meta, side, n, p)
        given = True
    else:
        ps, given = _plain_set(meta, side, joints, p)
        sets, crc = {ps.crc32: ps}, np.full(n, ps.crc32, dtype=np.uint32)
    for ps in sets.values():
        if ps.joints != joints:
            raise RecordError(
                f"{p}: {joints} joint columns ({cols[0]}..{cols[-1]}), but its parameter set "
                f"{ps.crc_hex} is an arm of {ps.describe()}: the log and its model do not match"
            )
    if encoders is not None:
        if encoders.joints != joints:
            raise RecordError(
                f"{p}: {joints} joint columns, but the encoder configuration given describes "
                f"{encoders.joints} joints"
            )
        sets = {
            c: ParamSetRecord(c, ps.model, encoders) for c, ps in sets.items()
        }  # same keys: rows keep their set, with other encoders
    log = Log(
        path=p,
        counts=counts if theta is None else np.zeros((n, joints), dtype=np.uint64),
        param_crc32=crc,
        param_sets=sets,
        meta=meta,
        format=fmt,
        columns=cols,
        table=t,
        sidecar=side,
        theta_given=theta,
        params_given=given,
        warnings=(f"{p}: dropped a last row cut short",) if t.cut_short else (),
    )
    for c in (*POINT_COLUMNS, "host_time"):
        if c in header:  # a log's points and times are finite: anything else is damage
            v = column(t, c)
            bad = np.flatnonzero(~np.isfinite(v))
            if bad.size:
                line, row = t.rows[int(bad[0])]
                raise t.fail(line, f"{c}: {row[t.index(c)]!r} is not a finite number")
    if theta is None:
        log.angles_rad()  # refuse readings beyond the configured resolution now, with the row
    return log


# ---------------------------------------------------------------- summary


def connected_segments(n: int, gaps: list[dict[str, Any]]) -> list[tuple[int, int]]:
    """Row ranges ``[start, end)`` between reconnect gaps."""
    cuts = sorted(
        {int(g["after_row"]) for g in gaps if isinstance(g.get("after_row"), int)} - {0, n}
    )
    bounds = [0, *[c for c in cuts if 0 < c < n], n]
    return [(a, b) for a, b in itertools.pairwise(bounds) if b > a]


def temperature_summary(temps: FloatArray | None) -> dict[str, Any] | None:
    """The range of the device's link temperatures (n, N) in degC (NaN: no reading):
    overall and per link (``links``, None for a link never read), and how many rows
    carry every reading; None when the rows carry no temperatures or none was read."""
    if temps is None or temps.size == 0 or not np.isfinite(temps).any():
        return None
    read = np.isfinite(temps)
    links: list[dict[str, float] | None] = []
    for j in range(temps.shape[1]):
        v = temps[read[:, j], j]
        links.append(
            {"min": round(float(v.min()), 2), "max": round(float(v.max()), 2)} if v.size else None
        )
    known = temps[read]
    return {
        "min": round(float(known.min()), 2),
        "max": round(float(known.max()), 2),
        "rows_read": int(np.count_nonzero(read.all(axis=1))),
        "links": links,
    }


def log_summary(log: Log) -> dict[str, Any]:
    """Samples, duration, rate while connected, gaps, lost samples, parameter sets,
    extent and the range of the link temperatures (:func:`temperature_summary`).

    Raises:
        RecordError: a temperature field that is not one (with its line).
    """
    meta = log.meta
    host = log.column("host_time")
    n = int(host.size)
    segs = connected_segments(n, log.gaps)
    connected = float(sum(host[b - 1] - host[a] for a, b in segs))
    intervals = sum(b - a - 1 for a, b in segs)
    ext = None
    if all(c in log.table.header for c in (*POINT_COLUMNS, "flags")):
        flags = log.column("flags", "int")
        pts = np.column_stack([log.column(c) for c in POINT_COLUMNS])[(flags & 1) != 0]
        if pts.size:
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            ext = {
                ax: {
                    "min": round(float(lo[i]), 4),
                    "max": round(float(hi[i]), 4),
                    "size": round(float(hi[i] - lo[i]), 4),
                }
                for i, ax in enumerate("xyz")
            }
    gap_s = [g.get("duration_s") for g in log.gaps]
    return {
        "file": str(log.path),
        "format": log.format,
        "status": meta.get("status", "unknown"),
        "joints": log.joints,
        "samples": n,
        "duration_s": float(host[-1] - host[0]) if n else 0.0,
        "connected_s": connected,
        "rate_hz": intervals / connected if connected > 0 else None,
        "gaps": len(log.gaps),
        "gap_s": [float(g) if isinstance(g, int | float) else None for g in gap_s],
        "lost_samples": meta.get("lost_samples", 0),
        "triggers": meta.get("triggers", 0),
        "presses": _presses(log),
        "reconnects": meta.get("reconnects", 0),
        "param_sets": [crc_hex(c) for _, c in log.set_changes()] if log.format else [],
        "extent_mm": ext,
        "temperature_c": temperature_summary(log.temperatures_c()),
        "damage": list(log.damage),
    }


def _presses(log: Log) -> int | None:
    """Button presses (a press and its release are two trigger rows): the sidecar's
    count, or for a log without one the pressed rows of its trigger file."""
    n = log.meta.get("presses")
    if isinstance(n, int) and not isinstance(n, bool):
        return n
    trig = log.trigger_path
    if trig is None or not trig.is_file():
        return None
    try:
        t = CsvTable(trig, "trigger file")
        if "pressed" not in t.header:
            return None
        i = t.index("pressed")
        return sum(1 for _, row in t if i < len(row) and row[i].strip() == "1")
    except RecordError:
        return None


# ---------------------------------------------------------------- triggers


@dataclass(frozen=True)
class LoggedTrigger:
    """One row of a log's trigger file."""

    line: int
    host_time: float
    button: int
    pressed: bool
    sample: Sample
    param_set: ParamSetRecord


def read_triggers(log: Log, path: Path | None = None) -> list[LoggedTrigger]:
    """The trigger file of a log (default: the sidecar's ``triggers_csv``, else
    ``<stem>.triggers.csv``), each row with its parameter set in force.

    Raises:
        RecordError: missing or damaged trigger file, or a row whose set the log lacks.
    """
    if path is None:
        name = log.meta.get("triggers_csv")
        path = (
            log.path.with_name(name) if isinstance(name, str) else default_triggers_path(log.path)
        )
    t = CsvTable(path, "trigger file")
    count_cols = count_columns(log.joints)
    need = ("seq", "device_time_us", "host_time", "button", "pressed", *count_cols, "flags")
    if not t.has(*need, *POINT_COLUMNS):
        raise RecordError(f"{path}: not an aacmm trigger file (header {','.join(t.header)})")
    if joint_count(t.header, "count") != log.joints:
        raise RecordError(
            f"{path}: {joint_count(t.header, 'count')} count columns, the log "
            f"{log.joints}: not this log's trigger file"
        )
    idx = {c: t.index(c) for c in (*need, *POINT_COLUMNS)}
    temp_idx = [t.index(c) for c in temp_columns(log.joints)] if t.has("temp1_c") else None
    has_crc = "param_crc32" in t.header
    only = next(iter(log.param_sets.values()))
    out = []
    for line, row in t:
        try:
            counts = tuple(int(row[idx[c]]) for c in count_cols)
            pt = tuple(round(float(row[idx[c]]) * 10000) for c in POINT_COLUMNS)
            temp = None
            if temp_idx is not None:
                temp = tuple(
                    TEMP_NONE_WIRE if row[k] == "" else round(float(row[k]) * 100) for k in temp_idx
                )
            sample = Sample(
                int(row[idx["seq"]]),
                int(row[idx["device_time_us"]]),
                counts,
                pt,
                int(row[idx["flags"]]),
                temp=temp,
            )
            host_time = float(row[idx["host_time"]])
            button, pressed = int(row[idx["button"]]), int(row[idx["pressed"]])
        except (ValueError, IndexError):
            raise t.fail(line, "bad row") from None
        ps = only
        if has_crc:
            s = row[t.index("param_crc32")]
            try:
                key = int(s, 16)
            except ValueError:
                key = -1
            if key not in log.param_sets:
                raise t.fail(line, f"parameter set {s!r} is not in the log's sidecar")
            ps = log.param_sets[key]
        elif len(log.param_sets) > 1:
            raise t.fail(line, "the log has several parameter sets and this row names none")
        out.append(LoggedTrigger(line, host_time, button, pressed == 1, sample, ps))
    return out
