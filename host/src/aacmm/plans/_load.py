"""Reading and validating a plan file (schema in docs/plans.md)."""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any, TypeVar

from aacmm.errors import SourceFileError
from aacmm.fileio import InputFileError, loads_toml
from aacmm.plans._slots import PRESET_ISO, make_slots
from aacmm.plans.model import (
    ARTEFACT_TYPES,
    DECISION_RULES,
    MAX_PLAN_MM,
    MAX_PROBE_DIAMETER_MM,
    PLAN_FORMAT,
    PROCEDURE_ARTEFACTS,
    PROCEDURES,
    TEMPERATURE_BAND_MAX_C,
    TEMPERATURE_RANGE_C,
    Artefact,
    ConeSeat,
    EUniMpe,
    LengthPosition,
    LengthStandard,
    Mpe,
    Part,
    Plan,
    Plane,
    Probe,
    Sphere,
    Step,
    Vec3,
    Verification,
)
from aacmm.tomlsource import SourceContext, value_kind

T = TypeVar("T")
KeyPath = tuple[str | int, ...]

#: The largest plan file accepted (a plan is a few kB; this stops a mistaken argument).
MAX_PLAN_BYTES = 4 << 20
MAX_POINTS_PER_STEP = 100_000
ID_CHARS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-.")
_AT_LINE = re.compile(r"\s*\(at line (\d+), column \d+\)")


class PlanError(SourceFileError):
    """A plan file that cannot be read or breaks the schema.

    The message is one line, ``FILE:LINE: FIELD: problem``; the parts are also
    in :attr:`file`, :attr:`line` (None if unknown) and :attr:`field`.
    """


class _Ctx(SourceContext):
    """A plan file being read: errors are PlanErrors at the key's line."""

    error = PlanError

    # ---------------------------------------------------------- typed getters

    def get(
        self,
        table: dict[str, Any],
        path: KeyPath,
        key: str,
        conv: Callable[[KeyPath, Any], T],
        default: T | None = None,
        required: bool = False,
    ) -> T | None:
        if key not in table:
            if required:
                self.fail((*path, key), "missing field")
            return default
        return conv((*path, key), table[key])

    def req(
        self, table: dict[str, Any], path: KeyPath, key: str, conv: Callable[[KeyPath, Any], T]
    ) -> T:
        v = self.get(table, path, key, conv, required=True)
        assert v is not None
        return v

    def number(self, path: KeyPath, v: Any) -> float:
        if isinstance(v, bool) or not isinstance(v, int | float):
            self.fail(path, f"must be a number, got {value_kind(v)}")
        f = float(v)
        if not math.isfinite(f):
            self.fail(path, "must be finite")
        if any(isinstance(k, str) and k.endswith("_mm") for k in path) and abs(f) > MAX_PLAN_MM:
            self.fail(path, f"{_num(f)} mm is beyond any arm (at most {MAX_PLAN_MM:g} mm)")
        return f

    def positive(self, path: KeyPath, v: Any) -> float:
        f = self.number(path, v)
        if not f > 0:
            self.fail(path, f"must be positive, got {_num(f)}")
        return f

    def non_negative(self, path: KeyPath, v: Any) -> float:
        f = self.number(path, v)
        if f < 0:
            self.fail(path, f"must not be negative, got {_num(f)}")
        return f

    def count(self, path: KeyPath, v: Any, low: int = 1) -> int:
        if isinstance(v, bool) or not isinstance(v, int):
            self.fail(path, f"must be a whole number, got {value_kind(v)}")
        if not low <= v <= MAX_POINTS_PER_STEP:
            self.fail(path, f"must be in {low}..{MAX_POINTS_PER_STEP}, got {v}")
        return int(v)

    def text(self, path: KeyPath, v: Any) -> str:
        if not isinstance(v, str):
            self.fail(path, f"must be a string, got {value_kind(v)}")
        return v

    def ident(self, path: KeyPath, v: Any) -> str:
        s = self.text(path, v)
        if not s or not set(s) <= ID_CHARS:
            self.fail(path, f"{s!r} is not a valid name (letters, digits, '_', '-', '.')")
        return s

    def flag(self, path: KeyPath, v: Any) -> bool:
        if not isinstance(v, bool):
            self.fail(path, f"must be true or false, got {value_kind(v)}")
        return v

    def vec3(self, path: KeyPath, v: Any) -> Vec3:
        if not isinstance(v, list) or len(v) != 3:
            self.fail(path, "must be a list of 3 numbers [x, y, z]")
        x, y, z = (self.number((*path, i), e) for i, e in enumerate(v))
        return (x, y, z)

    def direction(self, path: KeyPath, v: Any) -> Vec3:
        x, y, z = self.vec3(path, v)
        n = math.sqrt(x * x + y * y + z * z)
        if not n > 1e-12:
            self.fail(path, "must not be the zero vector")
        return (x / n, y / n, z / n)

    def pair(self, path: KeyPath, v: Any) -> tuple[float, float]:
        if not isinstance(v, list) or len(v) != 2:
            self.fail(path, "must be a list of 2 numbers [width, height]")
        a, b = (self.positive((*path, i), e) for i, e in enumerate(v))
        return (a, b)

    def choice(self, options: tuple[str, ...]) -> Callable[[KeyPath, Any], str]:
        def conv(path: KeyPath, v: Any) -> str:
            s = self.text(path, v)
            if s not in options:
                self.fail(path, f"unknown value {s!r} (one of: {', '.join(options)})")
            return s

        return conv

    def table(self, path: KeyPath, v: Any) -> dict[str, Any]:
        if not isinstance(v, dict):
            self.fail(path, f"must be a table, got {value_kind(v)}")
        return v


def _num(f: float) -> str:
    return f"{f:g}"


# ---------------------------------------------------------------- artefacts

_COMMON_ARTEFACT_KEYS = (
    "type",
    "description",
    "location_mm",
    "location_reference",
    "location_uncertainty_mm",
    "coverage_factor",
)
_ARTEFACT_KEYS: dict[str, tuple[str, ...]] = {
    "cone": (),
    "sphere": ("diameter_mm", "diameter_uncertainty_mm", "form_mm", "pole"),
    "ballbar": ("length_mm", "length_uncertainty_mm", "ends", "end_diameter_mm"),
    "gauge": ("length_mm", "length_uncertainty_mm", "ends", "end_diameter_mm"),
    "plane": ("normal", "size_mm", "flatness_mm"),
    "part": (),
}


def _artefact(c: _Ctx, name: str, t: dict[str, Any]) -> Artefact:
    path: KeyPath = ("artefacts", name)
    typ = c.req(t, path, "type", c.choice(ARTEFACT_TYPES))
    c.keys(t, path, _COMMON_ARTEFACT_KEYS + _ARTEFACT_KEYS[typ])
    common: dict[str, Any] = {
        "id": name,
        "type": typ,
        "description": c.get(t, path, "description", c.text, ""),
        "location_mm": c.get(t, path, "location_mm", c.vec3),
        "location_reference": c.get(t, path, "location_reference", c.flag, False),
        "location_uncertainty_mm": c.get(t, path, "location_uncertainty_mm", c.non_negative),
        "coverage_factor": c.get(t, path, "coverage_factor", c.positive, 2.0),
    }
    if common["location_reference"] and common["location_mm"] is None:
        c.fail((*path, "location_reference"), "a calibrated reference needs location_mm")
    if common["location_uncertainty_mm"] is not None and not common["location_reference"]:
        c.fail(
            (*path, "location_uncertainty_mm"),
            "only a calibrated reference (location_reference = true) has an uncertainty",
        )
    if typ == "cone":
        return ConeSeat(**common)
    if typ == "sphere":
        return Sphere(
            **common,
            diameter_mm=c.req(t, path, "diameter_mm", c.positive),
            diameter_uncertainty_mm=c.get(t, path, "diameter_uncertainty_mm", c.non_negative),
            form_mm=c.get(t, path, "form_mm", c.non_negative),
            pole=c.get(t, path, "pole", c.direction, (0.0, 0.0, 1.0)) or (0.0, 0.0, 1.0),
        )
    if typ in ("ballbar", "gauge"):
        ends = c.get(t, path, "ends", c.choice(("cone", "sphere")), "cone") or "cone"
        end_d = c.get(t, path, "end_diameter_mm", c.positive, required=ends == "sphere")
        if ends == "cone" and end_d is not None:
            c.fail((*path, "end_diameter_mm"), 'only for ends = "sphere"')
        return LengthStandard(
            **common,
            length_mm=c.req(t, path, "length_mm", c.positive),
            length_uncertainty_mm=c.get(t, path, "length_uncertainty_mm", c.non_negative),
            ends=ends,
            end_diameter_mm=end_d,
        )
    if typ == "plane":
        return Plane(
            **common,
            normal=c.get(t, path, "normal", c.direction, (0.0, 0.0, 1.0)) or (0.0, 0.0, 1.0),
            size_mm=c.get(t, path, "size_mm", c.pair, (100.0, 100.0)) or (100.0, 100.0),
            flatness_mm=c.get(t, path, "flatness_mm", c.non_negative),
        )
    return Part(**common)


# ---------------------------------------------------------------- steps

_STEP_KEYS: dict[str, tuple[str, ...]] = {
    "cone": ("articulations",),
    "sphere": ("preset", "points", "max_polar_deg"),
    "length": ("positions", "points_per_end"),
    "articulation": ("preset", "articulations", "points_per_articulation"),
    "plane": ("points",),
    "points": ("points", "targets_mm"),
}


def _positions(
    c: _Ctx, path: KeyPath, v: Any, length_mm: float
) -> tuple[tuple[LengthPosition, ...] | None, int]:
    if isinstance(v, int) and not isinstance(v, bool):
        return None, c.count(path, v)
    if not isinstance(v, list) or not v:
        c.fail(path, "must be a number of positions or a list of {centre_mm, direction}")
    out = []
    for i, e in enumerate(v):
        p: KeyPath = (*path, i)
        t = c.table(p, e)
        c.keys(t, p, ("centre_mm", "direction"))
        out.append(
            LengthPosition(
                c.req(t, p, "centre_mm", c.vec3), c.req(t, p, "direction", c.direction), length_mm
            )
        )
    return tuple(out), len(out)


def _step(c: _Ctx, i: int, t: dict[str, Any], artefacts: dict[str, Artefact]) -> Step:
    path: KeyPath = ("steps", i)
    proc = c.req(t, path, "procedure", c.choice(PROCEDURES))
    sid = c.get(t, path, "id", c.ident) or f"{proc}{i + 1}"
    aname = c.get(t, path, "artefact", c.ident, required=proc != "points")
    art: Artefact | None = None
    if aname is not None:
        if aname not in artefacts:
            known = ", ".join(sorted(artefacts)) or "none"
            c.fail((*path, "artefact"), f"unknown artefact {aname!r} (defined: {known})")
        art = artefacts[aname]
        if art.type not in PROCEDURE_ARTEFACTS[proc]:
            c.fail(
                (*path, "artefact"),
                f"{aname!r} is a {art.type}; a {proc} step needs a "
                + " or ".join(PROCEDURE_ARTEFACTS[proc]),
            )
    c.keys(t, path, ("id", "procedure", "artefact", "note", *_STEP_KEYS[proc]))
    base: dict[str, Any] = {
        "index": i,
        "id": sid,
        "procedure": proc,
        "artefact": aname,
        "note": c.get(t, path, "note", c.text, ""),
    }
    preset = c.get(t, path, "preset", c.choice((PRESET_ISO,)))
    if proc == "cone":
        n = c.req(t, path, "articulations", c.count)
        return Step(**base, points=n, articulations=n, points_per_articulation=1)
    if proc == "sphere":
        if preset is not None:
            if "points" in t and t["points"] != 25:
                c.fail((*path, "points"), f"the {PRESET_ISO} preset has 25 points")
            if "max_polar_deg" in t:
                c.fail((*path, "max_polar_deg"), f"the {PRESET_ISO} preset fixes the layout")
            return Step(**base, preset=preset, points=25, max_polar_deg=90.0)
        n = c.req(t, path, "points", lambda p, v: c.count(p, v, low=4))
        cap = c.get(t, path, "max_polar_deg", c.positive, 90.0) or 90.0
        if cap > 180.0:
            c.fail((*path, "max_polar_deg"), f"must be at most 180, got {_num(cap)}")
        return Step(**base, points=n, max_polar_deg=cap)
    if proc == "length":
        assert isinstance(art, LengthStandard)
        positions, m = _positions(
            c, (*path, "positions"), c.req(t, path, "positions", lambda p, v: v), art.length_mm
        )
        k = c.get(t, path, "points_per_end", c.count)
        if art.ends == "cone":
            if k not in (None, 1):
                c.fail((*path, "points_per_end"), f"{aname!r} has seats at its ends: 1 point")
            k = 1
        elif k is None:
            k = 5
        elif k < 4:
            c.fail((*path, "points_per_end"), f"a sphere end needs at least 4 points, got {k}")
        return Step(
            **base,
            points=m * 2 * k,
            positions=positions,
            position_count=m,
            points_per_end=k,
        )
    if proc == "articulation":
        assert art is not None
        if preset is not None:
            if not isinstance(art, Sphere):
                c.fail((*path, "preset"), f"the {PRESET_ISO} preset probes a sphere")
            for key in ("articulations", "points_per_articulation"):
                if key in t and t[key] != 5:
                    c.fail((*path, key), f"the {PRESET_ISO} preset is 5 x 5")
            return Step(
                **base, preset=preset, points=25, articulations=5, points_per_articulation=5
            )
        n = c.req(t, path, "articulations", lambda p, v: c.count(p, v, low=2))
        low = 4 if isinstance(art, Sphere) else 1
        per = c.get(t, path, "points_per_articulation", lambda p, v: c.count(p, v, low=low))
        if per is None:
            if isinstance(art, Sphere):
                c.fail((*path, "points_per_articulation"), "missing field (a sphere needs >= 4)")
            per = 1
        if isinstance(art, ConeSeat) and per != 1:
            c.fail((*path, "points_per_articulation"), "a cone seat takes 1 point")
        return Step(**base, points=n * per, articulations=n, points_per_articulation=per)
    if proc == "plane":
        return Step(**base, points=c.req(t, path, "points", lambda p, v: c.count(p, v, low=3)))
    # points
    tp: KeyPath = (*path, "targets_mm")
    targets = None
    if "targets_mm" in t:
        raw = t["targets_mm"]
        if not isinstance(raw, list) or not raw:
            c.fail(tp, "must be a list of [x, y, z]")
        targets = tuple(c.vec3((*tp, j), e) for j, e in enumerate(raw))
    count = c.get(t, path, "points", c.count)
    if count is None:
        if targets is None:
            c.fail((*path, "points"), "missing field (or give targets_mm)")
        count = len(targets)
    elif targets is not None and len(targets) != count:
        c.fail((*path, "points"), f"{count} points but {len(targets)} targets_mm")
    return Step(**base, points=count, targets_mm=targets)


# ---------------------------------------------------------------- the document

_MPE_KEYS = (
    "p_size_mm",
    "p_form_mm",
    "l_dia_mm",
    "e_uni_mm",
    "e_uni",
    "effective_diameter_mm",
    "spat_2sigma_mm",
    "spat_range_mm",
    "volumetric_mm",
)


def _mpe(c: _Ctx, t: dict[str, Any]) -> Mpe:
    path: KeyPath = ("mpe",)
    c.keys(t, path, _MPE_KEYS)
    e_uni = None
    if "e_uni_mm" in t and "e_uni" in t:
        c.fail((*path, "e_uni"), "give e_uni_mm (constant) or e_uni (table), not both")
    if "e_uni_mm" in t:
        e_uni = EUniMpe(c.positive((*path, "e_uni_mm"), t["e_uni_mm"]))
    elif "e_uni" in t:
        ep: KeyPath = (*path, "e_uni")
        et = c.table(ep, t["e_uni"])
        c.keys(et, ep, ("a_mm", "k", "b_mm"))
        e_uni = EUniMpe(
            c.req(et, ep, "a_mm", c.non_negative),
            c.get(et, ep, "k", c.positive, math.inf) or math.inf,
            c.get(et, ep, "b_mm", c.positive),
        )

    def mm(key: str) -> float | None:
        return c.get(t, path, key, c.positive)

    return Mpe(
        p_size_mm=mm("p_size_mm"),
        p_form_mm=mm("p_form_mm"),
        l_dia_mm=mm("l_dia_mm"),
        e_uni=e_uni,
        effective_diameter_mm=mm("effective_diameter_mm"),
        spat_2sigma_mm=mm("spat_2sigma_mm"),
        spat_range_mm=mm("spat_range_mm"),
        volumetric_mm=mm("volumetric_mm"),
    )


def _check_ball_fits(c: _Ctx, step: Step, art: Artefact | None, ball: float) -> None:
    """A probe ball must be smaller than the sphere (or ball end) it probes."""
    if ball <= 0:
        return
    if isinstance(art, Sphere) and step.procedure in ("sphere", "articulation"):
        size, what = art.diameter_mm, "diameter_mm"
    elif isinstance(art, LengthStandard) and art.end_diameter_mm is not None:
        size, what = art.end_diameter_mm, "end_diameter_mm"
    else:
        return
    if ball >= size:
        c.fail(
            ("probe", "ball_diameter_mm"),
            f"a {_num(ball)} mm probe ball cannot probe the {_num(size)} mm {art.id} "
            f"(artefacts.{art.id}.{what}) of step {step.id!r}: it must be smaller",
        )


def _needs_ball(step: Step, art: Artefact | None) -> bool:
    if step.procedure in ("sphere", "plane"):
        return True
    if isinstance(art, Sphere) and step.procedure == "articulation":
        return True
    return isinstance(art, LengthStandard) and art.ends == "sphere"


def loads_plan(text: str, name: str = "<plan>", path: Path | None = None) -> Plan:
    """Parse and validate a plan from its TOML text; ``name`` is used in messages.

    Raises:
        PlanError: bad TOML (with the parser's line) or a schema violation
            (``name:LINE: FIELD: problem``).
    """
    try:  # bounded nesting (aacmm.fileio): a hostile file is one clear line
        doc = loads_toml(text, name)
    except InputFileError as exc:
        msg = str(exc).removeprefix(f"{name}: ")
        m = _AT_LINE.search(msg)
        line = int(m.group(1)) if m else None
        msg = _AT_LINE.sub("", msg).replace("not valid TOML", "bad TOML")
        raise PlanError(name, line, "", msg) from None
    c = _Ctx(name, text)
    root: KeyPath = ()
    c.keys(
        doc,
        root,
        ("format", "title", "description", "probe", "artefacts", "steps", "mpe", "verification"),
    )
    fmt = c.req(doc, root, "format", c.text)
    if fmt != PLAN_FORMAT:
        hint = (
            "a plan format this aacmm does not know"
            if fmt.startswith("aacmm-plan-")
            else "not an aacmm plan"
        )
        c.fail(("format",), f"{fmt!r} is {hint} (expected {PLAN_FORMAT!r})")
    probe_t: dict[str, Any] = c.get(doc, root, "probe", c.table, {}) or {}
    c.keys(probe_t, ("probe",), ("ball_diameter_mm",))
    ball = c.get(probe_t, ("probe",), "ball_diameter_mm", c.non_negative)
    arts_t: dict[str, Any] = c.get(doc, root, "artefacts", c.table, {}) or {}
    artefacts: dict[str, Artefact] = {}
    for aname, at in arts_t.items():
        c.ident(("artefacts", aname), aname)
        artefacts[aname] = _artefact(c, aname, c.table(("artefacts", aname), at))
    raw_steps = c.req(doc, root, "steps", lambda p, v: v)
    if not isinstance(raw_steps, list) or not raw_steps:
        c.fail(("steps",), "must be one or more [[steps]] tables")
    steps = tuple(_step(c, i, c.table(("steps", i), t), artefacts) for i, t in enumerate(raw_steps))
    seen: dict[str, int] = {}
    for st in steps:
        if st.id in seen:
            c.fail(("steps", st.index, "id"), f"{st.id!r} is already step {seen[st.id] + 1}")
        seen[st.id] = st.index
        if ball is None and _needs_ball(st, artefacts.get(st.artefact or "")):
            c.fail(
                ("probe", "ball_diameter_mm"),
                f"missing field (step {st.id!r} probes a surface; 0 for a point probe)",
            )
    if ball is not None and ball > MAX_PROBE_DIAMETER_MM:
        c.fail(
            ("probe", "ball_diameter_mm"),
            f"a {_num(ball)} mm probe ball is not plausible (at most {MAX_PROBE_DIAMETER_MM:g} mm)",
        )
    for st in steps:
        _check_ball_fits(c, st, artefacts.get(st.artefact or ""), ball or 0.0)
    probe = Probe(ball or 0.0)
    mpe = _mpe(c, c.table(("mpe",), doc["mpe"])) if "mpe" in doc else Mpe()
    ver_t: dict[str, Any] = c.get(doc, root, "verification", c.table, {}) or {}
    c.keys(ver_t, ("verification",), ("decision_rule", "temperature_c", "temperature_band_c"))
    temp = c.get(ver_t, ("verification",), "temperature_c", c.number)
    lo, hi = TEMPERATURE_RANGE_C
    if temp is not None and not lo <= temp <= hi:
        c.fail(
            ("verification", "temperature_c"),
            f"{_num(temp)} deg C is outside {lo:g}..{hi:g} deg C (no arm measures there)",
        )
    band = c.get(ver_t, ("verification",), "temperature_band_c", c.number)
    if band is not None and not 0 < band <= TEMPERATURE_BAND_MAX_C:
        c.fail(
            ("verification", "temperature_band_c"),
            f"a stability band of {_num(band)} deg C: it must be above 0 and at most "
            f"{TEMPERATURE_BAND_MAX_C:g} deg C",
        )
    verification = Verification(
        c.get(ver_t, ("verification",), "decision_rule", c.choice(DECISION_RULES), "simple")
        or "simple",
        temp,
        band,
    )
    return Plan(
        name=name,
        source=text,
        sha256=hashlib.sha256(text.encode("utf-8")).hexdigest(),
        title=c.get(doc, root, "title", c.text, "") or "",
        description=c.get(doc, root, "description", c.text, "") or "",
        probe=probe,
        artefacts=artefacts,
        steps=steps,
        slots=make_slots(steps, artefacts, probe),
        mpe=mpe,
        verification=verification,
        path=path,
    )


def read_plan_file(path: Path) -> Plan:
    """Read and validate a plan file.

    Raises:
        PlanError: unreadable, too large, not UTF-8, or invalid.
    """
    name = str(path)
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_PLAN_BYTES + 1)
    except OSError as exc:
        raise PlanError(name, None, "", f"cannot read: {exc.strerror or exc}") from None
    if len(data) > MAX_PLAN_BYTES:
        raise PlanError(name, None, "", f"larger than {MAX_PLAN_BYTES >> 20} MiB: not a plan")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise PlanError(name, None, "", f"not UTF-8 text ({exc.reason})") from None
    plan = loads_plan(text, name, path)
    return replace(plan, path=path)
