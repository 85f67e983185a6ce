"""Measured points for the analysis commands (``verify``, ``fit``, ``export``).

Points are always recomputed from the raw counts with the parameter set in
force for each row (:meth:`aacmm.records.Recorded.points_mm`, the C core in
double precision), never taken from the device's rounded point.

Errors: :class:`aacmm.records.RecordError` (a ``ValueError``; ``aacmm`` exit
status 2) for a missing, unreadable or unusable input, naming the file.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aacmm.records.files import RecordError

if TYPE_CHECKING:
    from aacmm.errmodel import ErrorModel
    from aacmm.geometry._base import FloatArray
    from aacmm.plans import Plan
    from aacmm.records import CapturedPoint


@dataclass(frozen=True)
class Measured:
    """Points of a session or a log with their labels.

    ``names[i]`` is a short label (``sphere1#3``, ``length4 p2 A#1``, ``row 17``);
    ``step_ids[i]`` the plan step (None in a log); ``labels`` the session's
    captured points (None for a log).
    """

    source: Path
    kind: str
    points: FloatArray
    names: list[str]
    step_ids: list[str | None]
    probe_diameter_mm: float
    plan: Plan | None = None
    labels: tuple[CapturedPoint, ...] | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    #: per point of a session, the links' temperature its capture run states (degC,
    #: ``aacmm capture --temperature``; None where the run states none)
    stated_temperature_c: tuple[float | None, ...] | None = None
    #: per point of a session (n, N), the device's link temperatures (degC, NaN where
    #: a link has no reading); None for a session without them
    device_temp_c: npt.NDArray[np.float64] | None = None

    def step_table(self) -> list[str]:
        """The plan's steps as ``id (procedure, artefact)``, by step index."""
        if self.plan is None:
            return []
        return [f"{s.id} ({s.procedure}, {s.artefact or '-'})" for s in self.plan.steps]

    def label_numbers(self, i: int) -> list[int]:
        """step, point, position, end (1 A, 2 B), articulation, counted from 1 as the
        prompts count them; 0 where not applicable (a log's points have only a number)."""
        if self.labels is None:
            return [0, i + 1, 0, 0, 0]
        p = self.labels[i]
        end = {"A": 1, "B": 2}.get(p.end or "", 0)
        pos = 0 if p.position_index is None else p.position_index + 1
        art = 0 if p.articulation_index is None else p.articulation_index + 1
        return [p.step_index + 1, p.point_index + 1, pos, end, art]

    def csv_labels(self, i: int) -> list[str]:
        """step id, procedure, artefact, point, position, end, articulation (1-based counts)."""
        if self.labels is None:
            return ["", "", "", str(i + 1), "", "", ""]
        p = self.labels[i]
        return [
            p.step_id,
            p.procedure,
            p.artefact or "",
            str(p.point_index + 1),
            "" if p.position_index is None else str(p.position_index + 1),
            p.end or "",
            "" if p.articulation_index is None else str(p.articulation_index + 1),
        ]


def _name(p: CapturedPoint) -> str:
    parts = [p.step_id]
    if p.position_index is not None:
        parts.append(f"p{p.position_index + 1}")
    if p.end:
        parts.append(p.end)
    if p.articulation_index is not None:
        parts.append(f"a{p.articulation_index + 1}")
    return " ".join(parts) + f"#{p.point_index + 1}"


def _session_meta(s: Any) -> dict[str, Any]:
    meta: dict[str, Any] = {"status": s.status, "points": f"{len(s.points)} of {len(s.plan.slots)}"}
    plan_meta = s.meta.get("plan")
    if isinstance(plan_meta, dict) and isinstance(plan_meta.get("name"), str):
        meta["plan"] = Path(plan_meta["name"]).name
    dev = s.device
    if dev:
        serial = dev.get("serial_number")
        fw = dev.get("firmware")
        if serial is not None:
            meta["device"] = f"serial {serial}"
        if fw is not None:
            meta["firmware"] = str(fw)
    crcs = sorted({p.param_set.crc_hex for p in s.points})
    if crcs:
        meta["params_crc32"] = ", ".join(crcs)
        # which error terms beside the arm the device corrected (issue 27)
        models = sorted({p.param_set.errmodel_text() for p in s.points})
        meta["errmodel"] = "; ".join(models)
    runs = s.meta.get("runs") or []
    if runs and isinstance(runs[0], dict) and "start" in runs[0]:
        meta["captured"] = str(runs[0]["start"])[:19].replace("T", " ") + " UTC"
    return meta


def stated_temperatures(s: Any) -> tuple[float | None, ...]:
    """Per point of session ``s``, the links' temperature its capture run states
    (``temperature_c`` of the run, ``aacmm capture --temperature``), None where none:
    a point belongs to the last run that started at or before its host time."""
    starts: list[tuple[float, float | None]] = []
    for run in s.meta.get("runs") or []:
        if not isinstance(run, dict) or not isinstance(run.get("start"), str):
            continue
        try:
            t0 = dt.datetime.fromisoformat(run["start"]).timestamp()
        except ValueError:
            continue
        temp = run.get("temperature_c")
        if isinstance(temp, (int, float)) and not isinstance(temp, bool) and math.isfinite(temp):
            starts.append((t0, float(temp)))
        else:
            starts.append((t0, None))
    starts.sort(key=lambda r: r[0])
    out: list[float | None] = []
    for p in s.points:
        before = [t for t0, t in starts if t0 <= p.host_time]
        out.append(before[-1] if before else None)
    return tuple(out)


#: device readings and a statement differing by more than this (degC) are warned of
TEMP_DISAGREE_C = 1.0


def per_point_temperatures(
    stated: Sequence[float | None],
    device: npt.NDArray[np.float64] | None,
    joints: int,
    statement: str = "aacmm capture --temperature",
) -> tuple[npt.NDArray[np.float64], int, str | None]:
    """The link temperatures (n, N) of a session's points (degC, NaN where nothing is
    known): the device's reading of each link where it has one, else the ``stated``
    temperature of the point (on every link); how many points have all N readings,
    and a warning when readings and statements differ by more than
    :data:`TEMP_DISAGREE_C` (the readings are used)."""
    n = len(stated)
    out = np.array(
        [[np.nan if t is None else t] * joints for t in stated], dtype=np.float64
    ).reshape(n, joints)
    if device is None or device.shape != (n, joints):
        return out, 0, None
    read = np.isfinite(device)
    full = int(np.count_nonzero(read.all(axis=1)))
    with np.errstate(invalid="ignore"):
        diff = np.where(read & np.isfinite(out), np.abs(device - out), 0.0)
    worst = diff.max(axis=1) if n else np.zeros(0)
    bad = np.flatnonzero(worst > TEMP_DISAGREE_C)
    warning = None
    if bad.size:
        k = int(bad[0])
        warning = (
            f"the device's link temperatures differ from the stated ones ({statement}) by up "
            f"to {float(worst.max()):.1f} C at {bad.size} of {n} points (first: point {k + 1}, "
            f"read {span_text([float(v) for v in device[k][read[k]]])}, stated "
            f"{float(np.nanmax(out[k])):g} C): the device's readings are used"
        )
    out = np.where(read, device, out)
    return out, full, warning


class TemperatureNotStatedError(RecordError):
    """Thermal expansion to apply and a point whose link temperature nobody stated."""


def span_text(values: Sequence[float]) -> str:
    """``20 C`` or ``20 .. 28 C``: the range of some temperatures."""
    lo, hi = min(values), max(values)
    return f"{lo:g} C" if lo == hi else f"{lo:g} .. {hi:g} C"


def link_temperatures(
    m: Measured, em: ErrorModel | None, temp_c: float | None, source: str | None = None
) -> tuple[npt.NDArray[np.float64] | None, dict[str, Any]]:
    """The link temperatures (n, N) to compensate ``m``'s points at, None for no
    thermal compensation, and the report's entries for them (``temperature``,
    ``temperature_range_c``, and ``temperature_warning`` when the device's readings
    and a statement differ by more than :data:`TEMP_DISAGREE_C`).

    Per point and link the device's reading wins (a session whose samples carry the
    link temperatures); where it has none: ``temp_c`` on every link if given (the
    operator's statement, ``aacmm verify --temperature``), else, when ``em`` has
    thermal expansion, what the point's capture run states (``aacmm capture
    --temperature``). A session with temperatures and no CTEs to apply reports them,
    not compensated. ``source``: the error model's file, for the words.

    Raises:
        TemperatureNotStatedError: ``em`` has thermal expansion and a point has a link
            whose temperature nobody read nor stated (the message names it).
    """
    dev = m.device_temp_c
    if dev is None or not np.isfinite(dev).any():
        return _stated_link_temperatures(m, em, temp_c, source)
    from aacmm.records.paramfile import has_thermal

    n, joints = len(m.points), dev.shape[1]
    if em is not None and em.joints != joints:  # refused by the points' recomputation
        return _stated_link_temperatures(m, em, temp_c, source)
    what = "--temperature" if temp_c is not None else "aacmm capture --temperature"
    stated = [temp_c] * n if temp_c is not None else list(m.stated_temperature_c or [None] * n)
    temps, full, warning = per_point_temperatures(stated, dev, joints, what)
    entries: dict[str, Any] = {}
    if warning is not None:
        entries["temperature_warning"] = warning
    origin = f"read by the device at {full} of {n} points"
    if full < n:
        origin += f"; elsewhere {'--temperature' if temp_c is not None else 'stated at capture'}"
    known = temps[np.isfinite(temps)]
    lo, hi = float(known.min()), float(known.max())
    entries["temperature_range_c"] = [lo, hi]
    complete = bool(np.isfinite(temps).all())
    if em is not None and has_thermal(em):
        if not complete:
            k = int(np.flatnonzero(~np.isfinite(temps).all(axis=1))[0]) + 1
            raise TemperatureNotStatedError(
                f"point {k} has a link whose temperature the device did not read and its "
                "capture run states none"
            )
        entries["temperature"] = f"{span_text([lo, hi])} ({origin})"
        return temps, entries
    in_force = {p.param_set.crc32: p.param_set for p in m.labels or ()}
    if em is None and in_force and all(ps.thermal for ps in in_force.values()):
        crcs = ", ".join(ps.crc_hex for ps in in_force.values())
        entries["temperature"] = (
            f"{span_text([lo, hi])} ({origin}; compensated by the thermal block of the "
            f"parameter set in force, {crcs})"
        )
        return temps, entries
    why = "no --params with cte_per_k" if em is None else f"{source} has no cte_per_k"
    entries["temperature"] = f"{span_text([lo, hi])} ({origin}; not compensated: {why})"
    return None, entries


def _stated_link_temperatures(
    m: Measured, em: ErrorModel | None, temp_c: float | None, source: str | None
) -> tuple[npt.NDArray[np.float64] | None, dict[str, Any]]:
    """:func:`link_temperatures` of a session without the device's readings."""
    from aacmm.records.paramfile import has_thermal

    stated = list(m.stated_temperature_c or ())
    given = [t for t in stated if t is not None]
    n, joints = len(m.points), (em.joints if em is not None else 0)
    if temp_c is not None:
        line = f"{temp_c:g} C on every link (stated with --temperature; the arm measures none)"
        if given and (min(given) != temp_c or max(given) != temp_c):
            line += f"; the session's capture runs state {span_text(given)}"
        entries = {"temperature": line, "temperature_range_c": [temp_c] * 2}
        return np.full((n, joints), temp_c), entries
    if em is not None and has_thermal(em):
        if not stated or None in stated:
            k = stated.index(None) + 1 if None in stated else 1
            raise TemperatureNotStatedError(f"point {k}'s capture run states no temperature")
        line = (
            f"{span_text(given)} on every link (stated at capture, aacmm capture "
            "--temperature; the arm measures none)"
        )
        temps = np.repeat(np.array(given)[:, None], joints, axis=1)
        return temps, {"temperature": line, "temperature_range_c": [min(given), max(given)]}
    if given:
        why = "no --params with cte_per_k" if em is None else f"{source} has no cte_per_k"
        line = f"{span_text(given)} (stated at capture for {len(given)} of {n} points; "
        return None, {
            "temperature": line + f"not compensated: {why})",
            "temperature_range_c": [min(given), max(given)],
        }
    return None, {}


def load_session(
    path: Path,
    partial: bool = False,
    errmodel: ErrorModel | None = None,
    temp_c: FloatArray | None = None,
) -> Measured:
    """A capture session's points (recomputed from counts), labels and plan.

    ``errmodel``: the points computed with this error model (encoder
    harmonics, thermal expansion) at link temperatures ``temp_c`` (degC, one
    per link; None: the reference), each row with its own set in force
    (:meth:`aacmm.records.Recorded.points_mm`).

    Raises:
        RecordError: not a session (a log was given), or an incomplete session
            without ``partial``.
        RecordError: a damaged session (one line naming the file and line).
    """
    from aacmm.records import read_session, session_exists

    if not session_exists(path):
        what = "a file, not a session folder" if path.is_file() else "not a session folder"
        raise RecordError(f"{path}: {what} (verify needs a session written by aacmm capture)")
    s = read_session(path)
    if not s.points:
        raise RecordError(f"{path}: the session has no points")
    if not s.complete and not partial:
        raise RecordError(
            f"{path}: the session is incomplete ({len(s.points)} of {len(s.plan.slots)} points, "
            f"status {s.status}): finish it with aacmm capture --resume, or use --partial"
        )
    return Measured(
        source=path,
        kind="session",
        points=s.points_mm(errmodel=errmodel, temp_c=temp_c),
        names=[_name(p) for p in s.points],
        step_ids=[p.step_id for p in s.points],
        probe_diameter_mm=s.plan.probe.ball_diameter_mm,
        plan=s.plan,
        labels=s.points,
        meta=_session_meta(s),
        stated_temperature_c=stated_temperatures(s),
        device_temp_c=s.device_temp_c,
    )


def load_points(path: Path, triggers: bool = False) -> Measured:
    """Points of a session folder (any status), of a log CSV (``triggers``: the
    log's probe-button presses instead of its samples), or of a file of points
    in mm measured by any instrument (:func:`load_point_file`).

    Raises:
        RecordError: no such file, ``triggers`` with a session, an empty selection.
        RecordError: a damaged file.
    """
    from aacmm.records import session_exists

    if session_exists(path):
        if triggers:
            raise RecordError("--triggers applies to a log; a session's points are its captures")
        return load_session(path, partial=True)
    if not path.is_file():
        raise RecordError(f"{path}: no such session folder or log file")
    if not _has_joint_columns(path):
        if triggers:
            raise RecordError(f"--triggers applies to a log; {path} holds points")
        return load_point_file(path)
    from aacmm.protocol import SampleStatus
    from aacmm.records import Recorded
    from aacmm.records.logs import read_log, read_triggers

    log = read_log(path)
    if triggers:
        presses = [t for t in read_triggers(log) if t.pressed and t.button == 0]
        if not presses:
            raise RecordError(f"{path}: no capture-button presses in the log's trigger file")
        rec = Recorded(
            log.path,
            np.array([t.sample.counts for t in presses], dtype=np.uint64),
            np.array([t.param_set.crc32 for t in presses], dtype=np.uint32),
            {t.param_set.crc32: t.param_set for t in presses},
        )
        pts = rec.points_mm()
        names = [f"trigger {k + 1} (line {t.line})" for k, t in enumerate(presses)]
    else:
        pts = log.points_mm()
        names = [f"row {k + 1}" for k in range(len(pts))]
        if "flags" in log.columns and len(pts):
            valid = (log.column("flags", "int") & int(SampleStatus.POINT_VALID)) != 0
            pts = pts[valid]
            names = [n for n, v in zip(names, valid, strict=True) if v]
    meta = {} if log.params_given else {"note": "no parameter set in the log: default parameters"}
    if len(pts) == 0:
        raise RecordError(f"{path}: no points")
    return Measured(
        source=path,
        kind="log",
        points=np.asarray(pts, dtype=np.float64),
        names=names,
        step_ids=[None] * len(pts),
        probe_diameter_mm=0.0,
        meta=meta,
    )


# ---------------------------------------------------------------- points from elsewhere

#: Column names of x, y, z in a file of points (any case): aacmm's own, or plain.
XYZ_COLUMNS: tuple[tuple[str, str, str], ...] = (("x_mm", "y_mm", "z_mm"), ("x", "y", "z"))


def _first_line(path: Path) -> str:
    from aacmm.fileio import MAX_INPUT_BYTES

    try:
        with open(path, "rb") as f:
            head = f.read(min(MAX_INPUT_BYTES, 1 << 16))
    except OSError as exc:
        raise RecordError(f"{path}: cannot read: {exc.strerror or exc}") from None
    for raw in head.decode("utf-8", "replace").splitlines():
        if raw.strip() and not raw.lstrip().startswith("#"):
            return raw
    return ""


def _has_joint_columns(path: Path) -> bool:
    """The file's header names joint columns (a log or a file of poses, ``aacmm.records.logs``)."""
    from aacmm.records.schema import JOINTS_MIN, joint_count

    header = [h.strip().lower() for h in _first_line(path).split(",")]
    return any(joint_count(header, stem) >= JOINTS_MIN for stem in ("count", "c", "theta"))


def _fields(line: str) -> list[str]:
    return [f.strip() for f in line.split(",")] if "," in line else line.split()


def load_point_file(path: Path) -> Measured:
    """Points in mm measured by any instrument (a CMM, a laser tracker, another
    arm, ``aacmm export``): a CSV whose header names ``x, y, z`` (or ``x_mm,
    y_mm, z_mm``; any case, other columns ignored), or rows of three numbers
    without a header, separated by commas or white space (an xyz file). ``#``
    lines and blank lines are skipped. The points are taken as they are: ball
    centres for ``--probe-diameter``, which defaults to 0 here.

    Raises:
        RecordError: unreadable, too large, not UTF-8, no x, y, z columns, a value
            that is not a finite number (with its line), or no points.
    """
    from aacmm.fileio import read_text

    text = read_text(path)  # bounded, UTF-8: one line (exit status 2) otherwise
    rows = [
        (k + 1, line)
        for k, line in enumerate(text.splitlines())
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not rows:
        raise RecordError(f"{path}: no points")
    cols = (0, 1, 2)
    first = [f.lower() for f in _fields(rows[0][1])]
    try:
        [float(v) for v in first[:3]]
        header = len(first) < 3
    except ValueError:
        header = True
    if header:
        found = next((c for c in XYZ_COLUMNS if all(n in first for n in c)), None)
        if found is None:
            raise RecordError(
                f"{path}: header has neither joint columns (count1..count6 or theta1..theta6: "
                "a log) nor x, y, z columns (points in mm); got " + ",".join(first)
            )
        cols = (first.index(found[0]), first.index(found[1]), first.index(found[2]))
        rows = rows[1:]
    pts: list[tuple[float, float, float]] = []
    names: list[str] = []
    for line, text_row in rows:
        fields = _fields(text_row)
        try:
            x, y, z = (float(fields[c]) for c in cols)
        except (ValueError, IndexError):
            raise RecordError(f"{path}:{line}: x, y, z must be numbers (mm)") from None
        if not all(math.isfinite(v) for v in (x, y, z)):
            raise RecordError(f"{path}:{line}: x, y, z must be finite numbers (mm)")
        pts.append((x, y, z))
        names.append(f"point {len(pts)} (line {line})")
    if not pts:
        raise RecordError(f"{path}: no points")
    return Measured(
        source=path,
        kind="points",
        points=np.asarray(pts, dtype=np.float64),
        names=names,
        step_ids=[None] * len(pts),
        probe_diameter_mm=0.0,
    )
