"""Reading a capture session: :func:`read_session` checks every row into a :class:`Session`.

The folder's layout: :mod:`aacmm.records.session_format`; the public names
are ``aacmm.records.read_session``, ``Session``, ``CapturedPoint``,
``session_exists``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aacmm.plans import Plan, PlanError, loads_plan
from aacmm.records.files import CsvTable, RecordError, read_json, truncate_partial_line
from aacmm.records.paramsets import ParamSetRecord
from aacmm.records.rows import Recorded
from aacmm.records.schema import TEMP_MAX_C, TEMP_MIN_C, joint_count, temp_columns
from aacmm.records.session_format import (
    JOINTS,
    LABEL_COLUMNS,
    POINTS_CSV,
    SESSION_FORMAT,
    SIDECAR,
    count_columns,
    label_fields,
    point_columns,
)


@dataclass(frozen=True)
class CapturedPoint:
    """One accepted point of a session: its labels (see :class:`aacmm.plans.Slot`),
    the latched sample and the parameter set in force."""

    slot: int
    step_index: int
    step_id: str
    procedure: str
    artefact: str | None
    position_index: int | None
    end: str | None
    articulation_index: int | None
    point_index: int
    seq: int
    device_time_us: int
    host_time: float
    button: int
    counts: tuple[int, ...]
    point_mm: tuple[float, float, float]
    flags: int
    param_set: ParamSetRecord
    temp_c: tuple[float | None, ...] | None = None
    """The device's link temperatures of the sample (degC; None for a link without a
    reading); None in a session written before device temperatures."""


@dataclass(frozen=True, eq=False)
class Session(Recorded):
    """A session read from its folder (:func:`read_session`).

    ``points`` in plan order; the arrays (``counts``, ``param_crc32`` from
    :class:`Recorded`, and the others below) have one row per point.
    ``recompute``: use :meth:`points_mm` (each point with its own set in force,
    double precision) or ``points_mm(params)`` with other parameters.
    """

    meta: dict[str, Any]
    plan: Plan
    points: tuple[CapturedPoint, ...]
    device_points_mm: npt.NDArray[np.float64]
    device_time_us: npt.NDArray[np.int64]
    step_index: npt.NDArray[np.int64]
    point_index: npt.NDArray[np.int64]
    warnings: tuple[str, ...] = ()
    device_temp_c: npt.NDArray[np.float64] | None = None
    """(n, N) the device's link temperatures per point, degC (NaN: no reading); None
    when the session has no temperature columns (written before device temperatures)."""

    @property
    def status(self) -> str:
        return str(self.meta.get("status", "unknown"))

    def row_temperatures(self) -> npt.NDArray[np.float64] | None:
        return self.device_temp_c

    @property
    def device(self) -> dict[str, Any] | None:
        d = self.meta.get("device")
        return d if isinstance(d, dict) else None

    @property
    def complete(self) -> bool:
        """Every slot of the plan has its point."""
        return len(self.points) == len(self.plan.slots)

    @property
    def damage(self) -> tuple[str, ...]:
        """What the sidecar and ``points.csv`` disagree on (empty for a sound session):
        a session closed as ``complete`` without every point, or one whose sidecar
        counts more accepted points than the file holds (rows lost). A session
        still ``running`` (its capture killed) is judged only by what it holds."""
        out = []
        n, want = len(self.points), len(self.plan.slots)
        if self.status == "complete" and n < want:
            out.append(f"status complete, but {POINTS_CSV} holds {n} of the plan's {want} points")
        accepted = self.meta.get("accepted")
        if (
            self.status != "running"
            and isinstance(accepted, int)
            and not isinstance(accepted, bool)
            and accepted > n
        ):
            out.append(
                f"{SIDECAR} counts {accepted} accepted points, {POINTS_CSV} holds {n} "
                f"({accepted - n} lost)"
            )
        return tuple(out)

    def rows_of(self, step: int | str) -> npt.NDArray[np.intp]:
        """Row numbers of the points of one step (by index or id)."""
        i = self.plan.step(step).index
        return np.flatnonzero(self.step_index == i)

    def points_of(self, step: int | str) -> tuple[CapturedPoint, ...]:
        """The captured points of one step (by index or id)."""
        return tuple(self.points[int(r)] for r in self.rows_of(step))


def _int(t: CsvTable, line: int, name: str, v: str, lo: int, hi: int) -> int:
    try:
        x = int(v)
    except ValueError:
        raise t.fail(line, f"{name}: {v!r} is not an integer") from None
    if not lo <= x <= hi:
        raise t.fail(line, f"{name}: {x} outside {lo}..{hi}")
    return x


def _temp(t: CsvTable, line: int, name: str, v: str) -> float | None:
    """A link temperature field: degC, or empty for no reading."""
    if v == "":
        return None
    try:
        x = float(v)
    except ValueError:
        x = math.nan
    if not (math.isfinite(x) and TEMP_MIN_C <= x <= TEMP_MAX_C):
        raise t.fail(line, f"{name}: {v!r} is not a temperature in degC")
    return x


def _opt_int(t: CsvTable, line: int, name: str, v: str) -> int | None:
    return None if v == "" else _int(t, line, name, v, 0, 1 << 31)


def read_session(folder: str | Path, repair: bool = False) -> Session:
    """Read a session folder.

    Every row is checked: its labels must be those of its slot in the
    session's plan, in plan order, and its parameter set must be one the
    sidecar lists (whose values match its CRC). A last row cut short by a
    kill is dropped (with ``repair``, also from the file).

    Raises:
        RecordError: not a session folder, an unknown format, a damaged or
            inconsistent file (message names the file and line).
    """
    path = Path(folder)
    side = path / SIDECAR
    if not path.is_dir():
        raise RecordError(f"{path}: not a session folder")
    if not side.is_file():
        raise RecordError(f"{path}: not a session folder (no {SIDECAR})")
    meta = read_json(side)
    fmt = meta.get("format")
    if fmt != SESSION_FORMAT:
        raise RecordError(f"{side}: format {fmt!r} is not {SESSION_FORMAT!r}")
    pm = meta.get("plan")
    if not isinstance(pm, dict) or not isinstance(pm.get("source"), str):
        raise RecordError(f"{side}: no plan in the sidecar")
    try:
        plan = loads_plan(pm["source"], f"{side}: plan {pm.get('name', '')}".rstrip())
    except PlanError as exc:
        raise RecordError(f"the session's plan is invalid: {exc}") from None
    sets_raw = meta.get("param_sets")
    if not isinstance(sets_raw, list):
        raise RecordError(f"{side}: param_sets must be a list")
    sets = {
        ps.crc32: ps
        for ps in (
            ParamSetRecord.from_json(d, f"{side}: param_sets[{i}]") for i, d in enumerate(sets_raw)
        )
    }
    pts_path = path / POINTS_CSV
    warnings: list[str] = []
    if not pts_path.exists():
        raise RecordError(f"{path}: no {POINTS_CSV}")
    if repair and truncate_partial_line(pts_path):
        warnings.append(f"{pts_path}: dropped a last row cut short (never acknowledged)")
    t = CsvTable(pts_path, "points file")
    if t.cut_short:
        warnings.append(f"{pts_path}: ignored a last row cut short (never acknowledged)")
    joints = joint_count(t.header, "count")
    has_temps = "temp1_c" in t.header
    if not 4 <= joints <= 7 or tuple(t.header) != point_columns(joints, has_temps):
        raise RecordError(f"{pts_path}:{t.header_line}: header is not that of {SESSION_FORMAT}")
    _check_joints(meta, side, pts_path, joints, sets)
    columns = point_columns(joints, has_temps)
    count_cols = count_columns(joints)
    temp_cols = temp_columns(joints) if has_temps else ()
    points: list[CapturedPoint] = []
    for n, (line, row) in enumerate(t):
        if len(row) != len(columns):
            raise t.fail(line, f"{len(row)} fields, expected {len(columns)}")
        f = dict(zip(columns, row, strict=True))
        slot_i = _int(t, line, "slot", f["slot"], 0, 1 << 31)
        if slot_i != n:
            raise t.fail(
                line, f"slot {slot_i} (point {slot_i + 1}) where point {n + 1} was expected "
                "(rows out of order)",
            )  # fmt: skip
        if n >= len(plan.slots):
            raise t.fail(line, f"more points than the plan's {len(plan.slots)}")
        slot = plan.slots[n]
        if row[: len(LABEL_COLUMNS)] != label_fields(slot):
            raise t.fail(line, f"labels do not match point {n + 1} of the plan ({slot.text})")
        crc_s = f["param_crc32"]
        try:
            crc = int(crc_s, 16) if crc_s.startswith("0x") else -1
        except ValueError:
            crc = -1
        if crc not in sets:
            raise t.fail(line, f"parameter set {crc_s!r} is not listed in {SIDECAR}")
        counts = tuple(_int(t, line, c, f[c], 0, 0xFFFFFFFF) for c in count_cols)
        temps = tuple(_temp(t, line, c, f[c]) for c in temp_cols) if has_temps else None
        try:
            xyz = (float(f["x_mm"]), float(f["y_mm"]), float(f["z_mm"]))
            host_time = float(f["host_time"])
        except ValueError:
            raise t.fail(line, "bad number in host_time or x_mm, y_mm, z_mm") from None
        points.append(
            CapturedPoint(
                slot=n,
                step_index=slot.step_index,
                step_id=slot.step_id,
                procedure=slot.procedure,
                artefact=slot.artefact,
                position_index=slot.position_index,
                end=slot.end,
                articulation_index=slot.articulation_index,
                point_index=slot.point_index,
                seq=_int(t, line, "seq", f["seq"], 0, 0xFFFFFFFF),
                device_time_us=_int(t, line, "device_time_us", f["device_time_us"], 0, 1 << 64),
                host_time=host_time,
                button=_int(t, line, "button", f["button"], 0, 255),
                counts=counts,
                point_mm=xyz,
                flags=_int(t, line, "flags", f["flags"], 0, 0xFFFFFFFF),
                param_set=sets[crc],
                temp_c=temps,
            )
        )
    n = len(points)
    dev_temps = None
    if has_temps:
        dev_temps = np.array(
            [[np.nan if v is None else v for v in p.temp_c or ()] for p in points],
            dtype=np.float64,
        ).reshape(n, joints)
    return Session(
        path=path,
        counts=np.array([p.counts for p in points], dtype=np.uint64).reshape(n, joints),
        param_crc32=np.array([p.param_set.crc32 for p in points], dtype=np.uint32),
        param_sets=sets,
        meta=meta,
        plan=plan,
        points=tuple(points),
        device_points_mm=np.array([p.point_mm for p in points], dtype=np.float64).reshape(n, 3),
        device_time_us=np.array([p.device_time_us for p in points], dtype=np.int64),
        step_index=np.array([p.step_index for p in points], dtype=np.int64),
        point_index=np.array([p.point_index for p in points], dtype=np.int64),
        warnings=tuple(warnings),
        device_temp_c=dev_temps,
    )


def _check_joints(
    meta: dict[str, Any],
    side: Path,
    pts_path: Path,
    joints: int,
    sets: dict[int, ParamSetRecord],
) -> None:
    """The sidecar's ``joints`` (default six), the count columns and every parameter
    set must describe one arm: else one line, before anything is read or computed."""
    want = meta.get("joints", JOINTS)
    if isinstance(want, bool) or not isinstance(want, int):
        raise RecordError(f"{side}: joints must be an integer")
    if want != joints:
        raise RecordError(
            f"{pts_path}: {joints} count columns, but {SIDECAR} says the arm has {want} joints"
        )
    for ps in sets.values():
        if ps.joints != joints:
            raise RecordError(
                f"{side}: parameter set {ps.crc_hex} is an arm of {ps.describe()}, but the "
                f"session's points have {joints} count columns: the session and its model "
                "do not match"
            )


def session_exists(folder: str | Path) -> bool:
    """True if ``folder`` holds a session sidecar."""
    return (Path(folder) / SIDECAR).is_file()
