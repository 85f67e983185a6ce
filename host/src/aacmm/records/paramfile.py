"""Parameter-set files (TOML or JSON) for ``aacmm params``.

A file holds the eight fields of a device parameter set (docs/protocol.md
2.3), flat::

    # aacmm parameter set (mm, rad, encoder counts)
    theta_offset_rad = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    alpha_rad = [1.5707963267948966, ...]
    d_mm = [300.0, 65.5, 792.7, 65.5, 883.2, 0.0]
    a_mm = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    l_mm = 183.5
    counts_per_rev = [4294967296, ...]
    zero_offset_counts = [0, 0, 0, 0, 0, 0]
    direction = [1, 1, 1, 1, 1, 1]

or split as in a log sidecar: a ``params`` table (the five kinematic keys)
and an ``encoders`` table (the three encoder keys). A log's ``.csv.json``
sidecar (``"format": "aacmm-log-1"``) can be loaded as it is: only its
``params`` and ``encoders`` are read; so can a simulator truth file
(``"format": "aacmm-truth-1"``, docs/simulator.md): only its eight parameter
keys are read (its error tables are not parameters). The optional keys ``format`` and
``param_crc32`` are ignored on reading; any other key is an error. The format is chosen by the
suffix: ``.toml`` or ``.json``.

An optional ``arm`` table says whose set it is (``aacmm calibrate`` writes it)::

    [arm]
    serial_number = 1               # the device the calibration sessions were taken on
    firmware = "0.1.0"
    start_param_crc32 = "0xf2210b6c"  # the set in force the calibration started from

``aacmm params set`` refuses a file whose ``serial_number`` is another
device's (:func:`load_param_file_arm`, :class:`ArmIdentity`).

:func:`load_param_file` checks everything the device would check (types,
six values each, finite, encoder ranges, |angle| <= 2 pi, |length| <= 10 m)
before anything is sent; problems raise :class:`ParamFileError` naming the
file and the key.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aacmm.fileio import InputFileError, load_structured, write_output
from aacmm.protocol import ParamSet
from aacmm.protocol.constants import COUNTS_PER_REV_MAX, JOINTS
from aacmm.records.files import RecordError

KIN_KEYS = ("theta_offset_rad", "alpha_rad", "d_mm", "a_mm", "l_mm")
ENC_KEYS = ("counts_per_rev", "zero_offset_counts", "direction")
ALL_KEYS = KIN_KEYS + ENC_KEYS
IGNORED_KEYS = frozenset({"format", "param_crc32", "param_crc32_hex"})
ANGLE_MAX = 2.0 * math.pi
LENGTH_MAX_MM = 10_000.0


ARM_TABLE = "arm"
ARM_KEYS = ("serial_number", "firmware", "start_param_crc32")


class ParamFileError(RecordError):
    """A parameter file cannot be read or is not a valid parameter set (a
    ``ValueError``; ``aacmm`` exit status 2)."""


@dataclass(frozen=True)
class ArmIdentity:
    """A parameter file's ``[arm]`` table: the arm the set belongs to (None: not stated)."""

    serial_number: int | None = None
    firmware: str | None = None
    start_param_crc32: str | None = None

    def to_mapping(self) -> dict[str, Any]:
        """The table's keys that are set (TOML/JSON-ready)."""
        return {k: getattr(self, k) for k in ARM_KEYS if getattr(self, k) is not None}


def arm_identity_from_mapping(value: Any, src: str = "parameters") -> ArmIdentity:
    """An :class:`ArmIdentity` from an ``arm`` table.

    Raises:
        ParamFileError: not a table, an unknown key or a value of the wrong type.
    """
    if not isinstance(value, Mapping):
        raise ParamFileError(f"{src}: {ARM_TABLE} must be a table")
    for k in value:
        if k not in ARM_KEYS:
            raise ParamFileError(
                f"{src}: unknown key {ARM_TABLE}.{k} (expected {', '.join(ARM_KEYS)})"
            )
    serial = value.get("serial_number")
    if serial is not None and (
        isinstance(serial, bool) or not isinstance(serial, int) or not 0 <= serial <= 0xFFFFFFFF
    ):
        raise ParamFileError(f"{src}: {ARM_TABLE}.serial_number must be an integer 0..2^32-1")
    for k in ("firmware", "start_param_crc32"):
        v = value.get(k)
        if v is not None and (not isinstance(v, str) or len(v) > 64 or not v.isprintable()):
            raise ParamFileError(f"{src}: {ARM_TABLE}.{k} must be a short text")
    return ArmIdentity(serial, value.get("firmware"), value.get("start_param_crc32"))


def _floats(src: str, key: str, value: Any, n: int) -> tuple[float, ...]:
    if n == 1:
        value = [value]
    if not isinstance(value, list) or len(value) != n:
        want = "a number" if n == 1 else f"a list of {n} numbers"
        raise ParamFileError(f"{src}: {key} must be {want}")
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ParamFileError(f"{src}: {key}[{i}] must be a number, got {v!r}")
        if not math.isfinite(v):
            raise ParamFileError(f"{src}: {key}[{i}] is not finite")
        out.append(float(v))
    return tuple(out)


def _ints(src: str, key: str, value: Any, lo: int, hi: int) -> tuple[int, ...]:
    if not isinstance(value, list) or len(value) != JOINTS:
        raise ParamFileError(f"{src}: {key} must be a list of {JOINTS} integers")
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, int):
            raise ParamFileError(f"{src}: {key}[{i}] must be an integer, got {v!r}")
        if not lo <= v <= hi:
            raise ParamFileError(f"{src}: {key}[{i}]={v} outside {lo}..{hi}")
        out.append(v)
    return tuple(out)


def param_set_from_mapping(data: Any, src: str = "parameters") -> ParamSet:
    """A validated :class:`ParamSet` from a flat or split mapping (see the module doc).

    Raises:
        ParamFileError: missing, unknown or bad keys, values out of range.
    """
    if not isinstance(data, dict):
        raise ParamFileError(f"{src}: expected a table of parameters")
    fmt = data.get("format")
    if isinstance(fmt, str) and fmt.startswith("aacmm-log"):  # a log sidecar: its set only
        data = {k: data[k] for k in ("params", "encoders") if k in data}
    elif isinstance(fmt, str) and fmt.startswith("aacmm-truth"):  # a simulator truth file:
        data = {k: v for k, v in data.items() if k in ALL_KEYS}  # its set, not its error tables
    flat: dict[str, Any] = {}
    for key, value in data.items():
        if key in ("params", "encoders") and isinstance(value, dict):
            allowed = KIN_KEYS if key == "params" else ENC_KEYS
            for k, v in value.items():
                if k not in allowed:
                    raise ParamFileError(f"{src}: unknown key {key}.{k}")
                flat[k] = v
        elif key in ALL_KEYS:
            flat[key] = value
        elif key == ARM_TABLE:
            arm_identity_from_mapping(value, src)  # checked here, read by load_param_file_arm
        elif key not in IGNORED_KEYS:
            raise ParamFileError(f"{src}: unknown key {key!r} (expected {', '.join(ALL_KEYS)})")
    missing = [k for k in ALL_KEYS if k not in flat]
    if missing:
        raise ParamFileError(f"{src}: missing {', '.join(missing)}")
    kin = {k: _floats(src, k, flat[k], 1 if k == "l_mm" else JOINTS) for k in KIN_KEYS}
    for k in ("theta_offset_rad", "alpha_rad"):
        for i, v in enumerate(kin[k]):
            if abs(v) > ANGLE_MAX:
                raise ParamFileError(f"{src}: {k}[{i}]={v} beyond +-2 pi")
    for k in ("d_mm", "a_mm", "l_mm"):
        for i, v in enumerate(kin[k]):
            if abs(v) > LENGTH_MAX_MM:
                raise ParamFileError(f"{src}: {k}[{i}]={v} beyond +-{LENGTH_MAX_MM:g} mm")
    cpr = _ints(src, "counts_per_rev", flat["counts_per_rev"], 2, COUNTS_PER_REV_MAX)
    zero = _ints(src, "zero_offset_counts", flat["zero_offset_counts"], 0, 0xFFFFFFFF)
    direction = _ints(src, "direction", flat["direction"], -1, 1)
    for i in range(JOINTS):
        if direction[i] == 0:
            raise ParamFileError(f"{src}: direction[{i}] must be +1 or -1")
        if zero[i] >= cpr[i]:
            raise ParamFileError(
                f"{src}: zero_offset_counts[{i}]={zero[i]} must be < counts_per_rev[{i}]"
            )
    ps = ParamSet(
        theta_offset_rad=kin["theta_offset_rad"],
        alpha_rad=kin["alpha_rad"],
        d_mm=kin["d_mm"],
        a_mm=kin["a_mm"],
        l_mm=kin["l_mm"][0],
        counts_per_rev=cpr,
        zero_offset_counts=zero,
        direction=direction,
    )
    from aacmm.protocol import encode_param_set

    try:
        encode_param_set(ps)  # the codec's own checks, as a last line
    except ValueError as exc:
        raise ParamFileError(f"{src}: {exc}") from None
    return ps


def file_format(path: Path) -> str:
    """``"toml"`` or ``"json"`` from a parameter file's suffix.

    Raises:
        ParamFileError: another suffix.
    """
    suffix = path.suffix.lower()
    if suffix == ".toml":
        return "toml"
    if suffix == ".json":
        return "json"
    raise ParamFileError(f"{path}: unknown format (use a .toml or .json file)")


def load_param_file(path: str | Path) -> ParamSet:
    """Read and validate a parameter file (TOML or JSON by suffix).

    Raises:
        ParamFileError: unreadable, not TOML/JSON, nested deeper than
            :data:`aacmm.fileio.MAX_NESTING`, or not a valid parameter set.
    """
    p = Path(path)
    file_format(p)
    try:
        data = load_structured(p)  # bounded nesting: a hostile file is one line
    except InputFileError as exc:
        raise ParamFileError(str(exc)) from None
    return param_set_from_mapping(data, str(p))


def load_param_file_arm(path: str | Path) -> tuple[ParamSet, ArmIdentity | None]:
    """:func:`load_param_file` and the file's ``[arm]`` table (None if it has none).

    Raises:
        ParamFileError: as :func:`load_param_file`.
    """
    p = Path(path)
    file_format(p)
    try:
        data = load_structured(p)
    except InputFileError as exc:
        raise ParamFileError(str(exc)) from None
    ps = param_set_from_mapping(data, str(p))
    arm = data.get(ARM_TABLE) if isinstance(data, dict) else None
    fmt = data.get("format") if isinstance(data, dict) else None
    if arm is None or (isinstance(fmt, str) and fmt.startswith("aacmm-log")):
        return ps, None
    return ps, arm_identity_from_mapping(arm, str(p))


def param_set_dict(ps: ParamSet) -> dict[str, Any]:
    """The flat mapping of a parameter set (lists, JSON/TOML-ready)."""
    return {
        "theta_offset_rad": list(ps.theta_offset_rad),
        "alpha_rad": list(ps.alpha_rad),
        "d_mm": list(ps.d_mm),
        "a_mm": list(ps.a_mm),
        "l_mm": ps.l_mm,
        "counts_per_rev": list(ps.counts_per_rev),
        "zero_offset_counts": list(ps.zero_offset_counts),
        "direction": list(ps.direction),
    }


def dump_param_set(
    ps: ParamSet, fmt: str, crc: int | None = None, arm: Mapping[str, Any] | None = None
) -> str:
    """A parameter file's text (``fmt``: ``toml`` or ``json``); ``arm``: its ``[arm]`` table."""
    data: dict[str, Any] = {"format": "aacmm-params-1"}
    if crc is not None:
        data["param_crc32"] = crc
    data.update(param_set_dict(ps))
    if arm:
        data[ARM_TABLE] = dict(arm)
    if fmt == "json":
        return json.dumps(data, indent=2) + "\n"
    import tomli_w

    head = "# aacmm parameter set: lengths in mm, angles in rad, encoder counts\n"
    return head + tomli_w.dumps(data)


def write_param_file(
    ps: ParamSet, path: str | Path, crc: int | None = None, *, force: bool = False
) -> None:
    """Write a parameter file, format by suffix (:func:`aacmm.fileio.write_output`:
    refused if it exists unless ``force``; temporary file, fsync, rename).

    Raises:
        ParamFileError: unknown suffix.
        OutputExistsError, OutputFileError: see :func:`aacmm.fileio.atomic_output`.
        OSError: the write failed (the file is untouched).
    """
    p = Path(path)
    write_output(p, dump_param_set(ps, file_format(p), crc), force=force)
