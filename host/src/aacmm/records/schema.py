"""The schema of recorded files, without heavy imports (the ``aacmm log`` command
loads it at start-up): format names, columns, units, file names, row formatting.
Readers are in :mod:`aacmm.records.logs` and :mod:`aacmm.records.session_reader`."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from aacmm.records.files import fmt_point

if TYPE_CHECKING:
    from aacmm.protocol import Sample
    from aacmm.records.paramsets import ParamSetRecord

JOINTS = 6
"""The paper's arm: the joint count of the constants below (other arms: the functions)."""
JOINTS_MIN = 4
JOINTS_MAX = 7
LOG_FORMAT = "aacmm-log-2"
LOG_FORMATS_READ: tuple[str, ...] = ("aacmm-log-1", LOG_FORMAT)
POINT_COLUMNS: tuple[str, ...] = ("x_mm", "y_mm", "z_mm")


def count_columns(joints: int = JOINTS) -> tuple[str, ...]:
    """``count1 .. countN``: one column of raw encoder counts per joint."""
    return tuple(f"count{i}" for i in range(1, joints + 1))


def count_aliases(joints: int = JOINTS) -> tuple[str, ...]:
    """``c1 .. cN`` (plain CSV files of poses)."""
    return tuple(f"c{i}" for i in range(1, joints + 1))


def theta_columns(joints: int = JOINTS) -> tuple[str, ...]:
    """``theta1 .. thetaN`` in rad (plain CSV files of poses)."""
    return tuple(f"theta{i}" for i in range(1, joints + 1))


def log_columns(joints: int = JOINTS, temps: bool = True) -> tuple[str, ...]:
    """The columns of a log of an arm of ``joints`` joints; ``temps``: with the
    device's link temperatures at the end (every log written since issue 27)."""
    return (
        "seq",
        "device_time_us",
        "host_time",
        *count_columns(joints),
        *POINT_COLUMNS,
        "flags",
        "param_crc32",
        *(temp_columns(joints) if temps else ()),
    )


def trigger_columns(joints: int = JOINTS, temps: bool = True) -> tuple[str, ...]:
    """The columns of a log's trigger file of an arm of ``joints`` joints."""
    return (
        "seq",
        "device_time_us",
        "host_time",
        "button",
        "pressed",
        *count_columns(joints),
        *POINT_COLUMNS,
        "flags",
        "param_crc32",
        *(temp_columns(joints) if temps else ()),
    )


def temp_columns(joints: int = JOINTS) -> tuple[str, ...]:
    """``temp1_c .. tempN_c``: the device's link temperatures in degC (empty: no reading)."""
    return tuple(f"temp{i}_c" for i in range(1, joints + 1))


def temps_c(temp: tuple[int, ...] | None) -> tuple[float | None, ...] | None:
    """A sample's link temperatures (wire units, :attr:`aacmm.protocol.Sample.temp`) in
    degC, None for a link without a reading; None for a sample without temperatures."""
    if temp is None:
        return None
    return tuple(None if t == TEMP_NONE_WIRE else t / 100.0 for t in temp)


def temp_fields(temp: tuple[int, ...] | None, joints: int) -> list[str]:
    """The :func:`temp_columns` fields of a sample (all empty without temperatures)."""
    if temp is None:
        return [""] * joints
    return ["" if t == TEMP_NONE_WIRE else f"{t / 100.0:.2f}" for t in temp]


TEMP_NONE_WIRE = -32768
""":data:`aacmm.protocol.TEMP_NONE` (this module imports nothing heavy)."""

TEMP_MIN_C = -327.67
TEMP_MAX_C = 327.67
"""The link temperatures a file may hold, degC: what an i16 in 0.01 degC carries
(-32768 is no reading). Anything else in a log or a session is damage."""


def joint_count(header: tuple[str, ...] | list[str], stem: str) -> int:
    """N for a header holding ``<stem>1 .. <stem>N`` (0: no ``<stem>1``): the longest
    run from 1."""
    cols = set(header)
    n = 0
    while f"{stem}{n + 1}" in cols:
        n += 1
    return n


COUNT_COLUMNS: tuple[str, ...] = count_columns()
COUNT_ALIASES: tuple[str, ...] = count_aliases()
THETA_COLUMNS: tuple[str, ...] = theta_columns()
LOG_COLUMNS: tuple[str, ...] = log_columns()
TRIGGER_COLUMNS: tuple[str, ...] = trigger_columns()


def log_units(joints: int = JOINTS) -> dict[str, str]:
    """The sidecar's ``units`` for a log of ``joints`` joints."""
    names = {
        "count1..count6": f"count1..count{joints}",
        "temp1_c..temp6_c": f"temp1_c..temp{joints}_c",
    }
    return {names.get(k, k): v for k, v in LOG_UNITS.items()}


LOG_UNITS: dict[str, str] = {
    "seq": "device sample counter (u32, wraps; restarts with each stream)",
    "device_time_us": "us, device clock",
    "host_time": "s since the Unix epoch (UTC), host clock when the logger took the sample",
    "count1..count6": "encoder counts (u32)",
    "x_mm,y_mm,z_mm": "mm (resolution 0.0001 mm)",
    "flags": "sample status bits (docs/protocol.md 2.4)",
    "param_crc32": "CRC of the parameter set in force (sidecar param_sets)",
    "temp1_c..temp6_c": "the device's link temperatures, degC (0.01); empty: no reading (a "
    "sensor that did not answer, or a device without sensors; flags bit 15 TEMP_FAULT)",
    "button,pressed": "triggers file: button index (0 capture, 1 undo), 1 press / 0 release",
}


def sidecar_path(csv_path: Path) -> Path:
    """``run.csv`` -> ``run.csv.json``."""
    return csv_path.with_name(csv_path.name + ".json")


def default_triggers_path(csv_path: Path) -> Path:
    """``run.csv`` -> ``run.triggers.csv``."""
    stem = csv_path.name[: -len(csv_path.suffix)] if csv_path.suffix else csv_path.name
    return csv_path.with_name(stem + ".triggers.csv")


def sample_row(s: Sample, host_time: float, crc: str, extra: tuple[int, ...] = ()) -> str:
    """One CSV row of a log (``extra``: the trigger file's button and pressed)."""
    x, y, z = s.point_100nm
    parts = [str(s.seq), str(s.timestamp_us), f"{host_time:.6f}"]
    parts += [str(v) for v in extra]
    parts += [str(c) for c in s.counts]
    parts += [fmt_point(x), fmt_point(y), fmt_point(z), str(s.status), crc]
    parts += temp_fields(s.temp, len(s.counts))
    return ",".join(parts) + "\n"


def param_set_entry(ps: ParamSetRecord, first_row: int, when: str) -> dict[str, Any]:
    """A sidecar ``param_sets`` entry."""
    d = ps.to_json()
    d["first_row"] = first_row
    d["first_seen"] = when
    return d
