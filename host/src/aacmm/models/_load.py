"""Reading and validating a model file (schema ``aacmm-model-1``, docs/models.md)."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from aacmm.arm import CONVENTIONS, JOINTS_MAX, JOINTS_MIN, TIPS, Arm, Joint
from aacmm.core import KinematicsError, Model
from aacmm.errors import ModelError
from aacmm.fileio import InputFileError, loads_toml
from aacmm.models.model import (
    COUNTS_PER_REV_MAX,
    COUNTS_PER_REV_MIN,
    DEFAULT_CALIBRATION_PLAN,
    DEFAULT_VERIFICATION_PLAN,
    ENCODER_INTERFACES,
    MODEL_FORMAT,
    ArmModel,
    Encoder,
)
from aacmm.tomlsource import SourceContext, format_path, value_kind

KeyPath = tuple[str | int, ...]

#: The largest model file accepted (a model is about 3 kB).
MAX_MODEL_BYTES = 1 << 20
#: Finite joint limits lie within +-360 deg and span less than one turn.
LIMIT_MAX_DEG = 360.0
_NAME_CHARS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-.")
_AT_LINE = re.compile(r"\s*\(at line (\d+), column \d+\)")
_TOP_KEYS = (
    "format",
    "name",
    "description",
    "source",
    "notes",
    "encoder",
    "tip",
    "joints",
    "plans",
)
_PLANS_KEYS = ("calibration", "verification")
_ENCODER_KEYS = ("counts_per_rev", "zero_offset_counts", "direction", "interface")
_BASE_ENCODER_KEYS = (*_ENCODER_KEYS, "assumed")
_TIP_KEYS = ("kind", "vector_mm", "assumed")
# Angle fields: each given in degrees (_deg) or radians (_rad), exactly one.
_ANGLES = ("theta_offset", "alpha", "beta")
_JOINT_KEYS = (
    "convention",
    *(f"{a}_{u}" for a in _ANGLES for u in ("deg", "rad")),
    "d_mm",
    "a_mm",
    "limits_deg",
    "limits_rad",
    "encoder",
    "assumed",
)
# What a joint's ``assumed`` list may name, and the figure each stands for.
_JOINT_FIGURES = {
    "convention": "convention",
    "theta_offset": "theta",
    "alpha": "alpha",
    "d_mm": "d",
    "a_mm": "a",
    "beta": "beta",
    "limits": "limits",
    "encoder": "encoder",
}


def _field(path: KeyPath) -> str:
    """``joint 3 d_mm``, ``tip.vector_mm item 3``: joints and list items counted
    from 1, as a person reads them."""
    head = ""
    if len(path) >= 2 and path[0] == "joints" and isinstance(path[1], int):
        head, path = f"joint {path[1] + 1}", path[2:]
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f" item {part + 1}"
        else:
            out += f".{format_path((part,))}" if out else format_path((part,))
    return f"{head} {out}" if head and out else head or out


class _Ctx(SourceContext):
    """A model file being read: errors are ModelErrors at the key's line,
    fields named as a person counts (joint 2, item 3)."""

    error = ModelError

    def field(self, path: KeyPath) -> str:
        return _field(path)

    def need(self, table: dict[str, Any], path: KeyPath, key: str) -> Any:
        if key not in table:
            self.fail((*path, key), "missing field")
        return table[key]

    def number(self, path: KeyPath, v: Any, allow_inf: bool = False) -> float:
        if isinstance(v, bool) or not isinstance(v, int | float):
            self.fail(path, f"must be a number, got {value_kind(v)}")
        if isinstance(v, int):
            self.int64(path, v)
        f = float(v)
        if math.isnan(f) or (math.isinf(f) and not allow_inf):
            self.fail(path, "must be finite" if not math.isnan(f) else "must be a number, not nan")
        return f

    def integer(self, path: KeyPath, v: Any) -> int:
        if isinstance(v, bool) or not isinstance(v, int):
            self.fail(path, f"must be a whole number, got {value_kind(v)}")
        self.int64(path, v)
        return int(v)

    def int64(self, path: KeyPath, v: int) -> None:
        """TOML's integers are 64-bit (tomllib reads any size)."""
        if not -(1 << 63) <= v < (1 << 63):
            self.fail(path, f"an integer of {len(str(abs(v)))} digits is beyond TOML's 64 bits")

    def text(self, path: KeyPath, v: Any, empty: bool = False) -> str:
        if not isinstance(v, str):
            self.fail(path, f"must be a string, got {value_kind(v)}")
        if not empty and not v.strip():
            self.fail(path, "must not be empty")
        if "\n" in v.strip() and path[-1] != "notes":
            self.fail(path, "must be one line")
        return v.strip()

    def table(self, path: KeyPath, v: Any) -> dict[str, Any]:
        if not isinstance(v, dict):
            self.fail(path, f"must be a table, got {value_kind(v)}")
        return v

    def choice(self, path: KeyPath, v: Any, options: tuple[str, ...]) -> str:
        s = self.text(path, v)
        if s not in options:
            self.fail(path, f"unknown value {s!r} (one of: {', '.join(options)})")
        return s

    def angle(
        self, table: dict[str, Any], path: KeyPath, base: str, required: bool = True
    ) -> float | None:
        """``base_deg`` or ``base_rad`` (exactly one) in rad; None if absent and optional."""
        deg, rad = f"{base}_deg", f"{base}_rad"
        if deg in table and rad in table:
            self.fail((*path, rad), f"give {deg} or {rad}, not both")
        if deg in table:
            return math.radians(self.number((*path, deg), table[deg]))
        if rad in table:
            return self.number((*path, rad), table[rad])
        if required:
            self.fail((*path, deg), f"missing field ({deg} or {rad})")
        return None


def _encoder(c: _Ctx, table: dict[str, Any], path: KeyPath, base: dict[str, Any]) -> dict[str, Any]:
    """The encoder fields of ``table`` over ``base`` (checked one by one)."""
    c.keys(table, path, _ENCODER_KEYS)
    out = dict(base)
    if "counts_per_rev" in table:
        cpr = c.integer((*path, "counts_per_rev"), table["counts_per_rev"])
        if not COUNTS_PER_REV_MIN <= cpr <= COUNTS_PER_REV_MAX:
            c.fail((*path, "counts_per_rev"), f"must be in 2 .. 4294967296 (2^32), got {cpr}")
        out["counts_per_rev"] = cpr
    if "zero_offset_counts" in table:
        out["zero_offset_counts"] = c.integer(
            (*path, "zero_offset_counts"), table["zero_offset_counts"]
        )
    if "direction" in table:
        d = c.integer((*path, "direction"), table["direction"])
        if d not in (1, -1):
            c.fail((*path, "direction"), f"must be 1 or -1, got {d}")
        out["direction"] = d
    if "interface" in table:
        out["interface"] = c.choice((*path, "interface"), table["interface"], ENCODER_INTERFACES)
    return out


def _limits(c: _Ctx, j: dict[str, Any], path: KeyPath) -> tuple[float, float]:
    deg, rad = "limits_deg", "limits_rad"
    if deg in j and rad in j:
        c.fail((*path, rad), f"give {deg} or {rad}, not both")
    key = deg if deg in j else rad if rad in j else None
    if key is None:
        c.fail(
            (*path, deg), f"missing field ({deg} or {rad}: [lowest, highest], [-inf, inf] for none)"
        )
    v = j[key]
    p = (*path, key)
    if not isinstance(v, list) or len(v) != 2:
        c.fail(p, "must be a list of 2 numbers [lowest, highest] ([-inf, inf]: no limit)")
    lo, hi = (c.number((*p, i), e, allow_inf=True) for i, e in enumerate(v))
    if math.isinf(lo) != math.isinf(hi) or (math.isinf(lo) and not (lo < 0 < hi)):
        c.fail(p, "a joint without limits has [-inf, inf]; otherwise both limits are finite")
    if not lo < hi:
        c.fail(p, f"inverted or empty: the lowest ({lo:g}) must be below the highest ({hi:g})")
    if key == deg:
        bound = LIMIT_MAX_DEG
        lo_r, hi_r = (lo, hi) if math.isinf(lo) else (math.radians(lo), math.radians(hi))
    else:
        bound = math.radians(LIMIT_MAX_DEG)
        lo_r, hi_r = lo, hi
    if not math.isinf(lo) and (abs(lo) > bound or abs(hi) > bound):
        c.fail(p, f"finite limits lie within +-{LIMIT_MAX_DEG:g} deg")
    if not math.isinf(lo) and hi - lo >= bound:
        c.fail(p, "finite limits span less than one turn (a joint without limits has [-inf, inf])")
    return (lo_r, hi_r)


def _assumed(c: _Ctx, table: dict[str, Any], path: KeyPath, allowed: dict[str, str]) -> list[str]:
    """The figure names a table's ``assumed`` list marks (keys of ``allowed``)."""
    if "assumed" not in table:
        return []
    v = table["assumed"]
    p = (*path, "assumed")
    if not isinstance(v, list):
        c.fail(p, "must be a list of field names")
    out = []
    for i, e in enumerate(v):
        s = c.text((*p, i), e)
        key = next((b for b in (*_ANGLES, "limits") if s in (b, f"{b}_deg", f"{b}_rad")), s)
        if key not in allowed:
            c.fail((*p, i), f"{s!r} is not a figure of this table (one of: {', '.join(allowed)})")
        out.append(allowed[key])
    return out


def _joint(
    c: _Ctx, v: Any, i: int, base_encoder: dict[str, Any]
) -> tuple[Joint, tuple[float, float], Encoder, list[str]]:
    path: KeyPath = ("joints", i)
    j = c.table(path, v)
    c.keys(j, path, _JOINT_KEYS)
    convention = c.choice((*path, "convention"), c.need(j, path, "convention"), CONVENTIONS)
    theta = c.angle(j, path, "theta_offset")
    alpha = c.angle(j, path, "alpha")
    beta = c.angle(j, path, "beta", required=False)
    d = c.number((*path, "d_mm"), c.need(j, path, "d_mm"))
    a = c.number((*path, "a_mm"), c.need(j, path, "a_mm"))
    if beta is not None and i == 0:
        key = "beta_deg" if "beta_deg" in j else "beta_rad"
        c.fail((*path, key), "joint 1 cannot have a beta (it has no previous axis)")
    limits = _limits(c, j, path)
    enc_path = (*path, "encoder")
    enc_fields = (
        _encoder(c, c.table(enc_path, j["encoder"]), enc_path, base_encoder)
        if "encoder" in j
        else base_encoder
    )
    if enc_fields["zero_offset_counts"] >= enc_fields["counts_per_rev"] or (
        enc_fields["zero_offset_counts"] < 0
    ):
        where = enc_path if "encoder" in j else ("encoder",)
        c.fail(
            (*where, "zero_offset_counts"),
            f"must be in 0 .. counts_per_rev - 1 ({enc_fields['counts_per_rev'] - 1}) "
            f"for joint {i + 1}, got {enc_fields['zero_offset_counts']}",
        )
    allowed = dict(_JOINT_FIGURES)
    if beta is None:
        del allowed["beta"]
    figures = [f"{f}{i + 1}" for f in _assumed(c, j, path, allowed)]
    try:
        joint = Joint(convention, theta or 0.0, alpha or 0.0, d, a, beta)
    except ValueError as exc:
        c.fail(path, str(exc))
    return joint, limits, Encoder(**enc_fields), figures


def _plans(c: _Ctx, data: dict[str, Any]) -> tuple[str, str]:
    """The ``[plans]`` table: a shipped plan's name or a plan file per purpose."""
    from aacmm.plans import shipped_plans

    out = {"calibration": DEFAULT_CALIBRATION_PLAN, "verification": DEFAULT_VERIFICATION_PLAN}
    if "plans" not in data:
        return out["calibration"], out["verification"]
    table = c.table(("plans",), data["plans"])
    c.keys(table, ("plans",), _PLANS_KEYS)
    for key in _PLANS_KEYS:
        if key not in table:
            continue
        spec = c.text(("plans", key), table[key])
        is_file = "/" in spec or "\\" in spec or spec.endswith(".toml")
        if not is_file and spec not in shipped_plans():
            c.fail(
                ("plans", key),
                f"no shipped plan {spec!r} (shipped: {', '.join(shipped_plans())}; "
                "a plan file is a path ending in .toml)",
            )
        out[key] = spec
    return out["calibration"], out["verification"]


def loads_model(text: str, name: str = "<model>") -> ArmModel:
    """Parse and validate a model from its TOML text; ``name`` is used in messages.

    Raises:
        ModelError: not TOML, or a break of the schema (one line, FILE:LINE).
    """
    try:
        data = loads_toml(text, name)
    except InputFileError as exc:
        msg = str(exc).removeprefix(f"{name}: ")
        m = _AT_LINE.search(msg)
        line = int(m.group(1)) if m else None
        raise ModelError(name, line, "", _AT_LINE.sub("", msg)) from None
    c = _Ctx(name, text)
    c.keys(data, (), _TOP_KEYS)
    fmt = c.text(("format",), c.need(data, (), "format"))
    if fmt != MODEL_FORMAT:
        c.fail(("format",), f"unsupported format {fmt!r} (this aacmm reads {MODEL_FORMAT})")
    model_name = c.text(("name",), c.need(data, (), "name"))
    if not set(model_name) <= _NAME_CHARS:
        c.fail(("name",), f"{model_name!r} is not a valid name (letters, digits, '_', '-', '.')")
    description = c.text(("description",), c.need(data, (), "description"))
    source = c.text(("source",), c.need(data, (), "source"))
    notes = c.text(("notes",), data["notes"], empty=True) if "notes" in data else ""

    base: dict[str, Any] = {
        "counts_per_rev": COUNTS_PER_REV_MAX,
        "zero_offset_counts": 0,
        "direction": 1,
        "interface": "biss",
    }
    encoders_assumed = False
    if "encoder" in data:
        enc_t = c.table(("encoder",), data["encoder"])
        c.keys(enc_t, ("encoder",), _BASE_ENCODER_KEYS)
        if "assumed" in enc_t:
            encoders_assumed = enc_t["assumed"]
            if not isinstance(encoders_assumed, bool):
                c.fail(
                    ("encoder", "assumed"),
                    f"must be true or false, got {value_kind(encoders_assumed)}",
                )
        enc_t = {k: v for k, v in enc_t.items() if k != "assumed"}
        base = _encoder(c, enc_t, ("encoder",), base)

    if "joints" not in data:
        c.fail(
            ("joints",),
            f"missing field (a [[joints]] table per joint, {JOINTS_MIN} to {JOINTS_MAX})",
        )
    joints_v = data["joints"]
    if not isinstance(joints_v, list):
        c.fail(("joints",), "must be an array of tables ([[joints]])")
    if not JOINTS_MIN <= len(joints_v) <= JOINTS_MAX:
        c.fail(
            ("joints",),
            f"an arm has {JOINTS_MIN} to {JOINTS_MAX} joints, this one {len(joints_v)}",
        )
    parsed = [_joint(c, v, i, base) for i, v in enumerate(joints_v)]

    tip_t = c.table(("tip",), c.need(data, (), "tip"))
    calibration_plan, verification_plan = _plans(c, data)
    c.keys(tip_t, ("tip",), _TIP_KEYS)
    kind = c.choice(("tip", "kind"), c.need(tip_t, ("tip",), "kind"), TIPS)
    vec = c.need(tip_t, ("tip",), "vector_mm")
    if not isinstance(vec, list) or len(vec) != 3:
        c.fail(("tip", "vector_mm"), "must be a list of 3 numbers [x, y, z] (mm, last frame)")
    tx, ty, tz = (c.number(("tip", "vector_mm", k), e) for k, e in enumerate(vec))
    if kind == "z" and (tx != 0.0 or ty != 0.0):
        c.fail(("tip", "vector_mm"), "a tip of kind 'z' (the paper's l) has x = y = 0")
    tip_names = ["tx", "ty", "tz"] if kind == "xyz" else ["l"]
    tip_fig = _assumed(c, tip_t, ("tip",), {"vector_mm": "tip"})
    assumed = [f for _, _, _, figs in parsed for f in figs]
    if encoders_assumed:
        assumed += [f"encoder{i + 1}" for i in range(len(parsed))]
    if tip_fig:
        assumed += tip_names

    try:
        arm = Arm(joints=tuple(p[0] for p in parsed), tip=kind, tip_mm=(tx, ty, tz))
    except ValueError as exc:
        c.fail(("tip",), str(exc))
    try:
        Model(arm)  # the core's own validation: a model the core rejects is no model
    except KinematicsError as exc:
        c.fail(("joints",), f"the kinematics core rejects this arm: {exc}")
    # joint figures named by kind (theta, d ..) as parameter names (theta1, d1 ..)
    names = set(arm.param_names)
    figures = frozenset(
        f for f in assumed if f in names or f.startswith(("limits", "encoder", "convention"))
    )
    return ArmModel(
        name=model_name,
        description=description,
        source=source,
        arm=arm,
        joint_limits_rad=tuple(p[1] for p in parsed),
        encoders=tuple(p[2] for p in parsed),
        assumed=figures,
        notes=notes,
        file=None if name.startswith("<") else name,
        calibration_plan=calibration_plan,
        verification_plan=verification_plan,
    )


def read_model_file(path: Path) -> ArmModel:
    """Read and validate one model file.

    Raises:
        ModelError: unreadable, too large, not UTF-8, or an invalid model.
    """
    name = str(path)
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_MODEL_BYTES + 1)
    except OSError as exc:
        raise ModelError(name, None, "", f"cannot read: {exc.strerror or exc}") from None
    if len(data) > MAX_MODEL_BYTES:
        raise ModelError(name, None, "", f"larger than {MAX_MODEL_BYTES >> 20} MiB: not a model")
    try:
        text = data.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as exc:
        raise ModelError(
            name, None, "", f"not UTF-8 text ({exc.reason} at byte {exc.start})"
        ) from None
    return loads_model(text, name)
