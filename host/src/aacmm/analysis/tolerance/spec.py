"""The tolerance-allocation request: target, cost model, workspace, encoders.

:func:`load_spec` reads a TOML file (format in docs/tolerance.md); every
error names the file and the field (``arm.toml: [parameters] d3.k: must be
> 0, got -1``). :func:`parse_spec` does the same for a parsed document.

Units: tolerances are half-widths ``t`` (the part is good if its error lies
in +-t) in the spec's ``angle_unit`` (default arcsec) and ``length_unit``
(default um); the cost of a parameter is ``c / t**k`` with ``t`` in those
units, so ``c`` reads as "the cost of holding one unit". Inside the package
angles are in rad and lengths in mm, as everywhere in aacmm.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from aacmm.analysis.uncertainty import ANGLE_UNITS, DISTRIBUTIONS, LENGTH_UNITS, TOLERANCE_FACTOR
from aacmm.analysis.uncertainty import _expand as expand_names
from aacmm.core import JOINTS, PARAM_NAMES, PARAM_UNITS, FloatArray, Params
from aacmm.errors import AacmmError

ARCSEC_RAD = ANGLE_UNITS["arcsec"]
FULL_TURN_ARCSEC = 1_296_000.0
DEFAULT_RANDOM_POSES = 200
DEFAULT_MIN_LENGTH_MM = 100.0
MAX_POSES = 20_000


class SpecError(AacmmError, ValueError):
    """The tolerance spec is unreadable or invalid (message: file, field, reason)."""


@dataclass(frozen=True)
class ParamCost:
    """How one parameter may be toleranced, and what that costs.

    ``t`` is the tolerance half-width in ``unit`` (``scale`` rad or mm per
    unit). Allocated parameters cost ``c / t**k`` and must lie in
    ``[t_min, t_max]`` (process capability; ``t_max`` may be inf). A
    parameter with ``fixed`` set keeps that tolerance (a bought part, a
    given process) and costs nothing here. Within its tolerance the error
    follows ``distribution``; a normal tolerance is ``coverage_k`` standard
    uncertainties.
    """

    name: str
    unit: str
    scale: float
    c: float = 1.0
    k: float = 2.0
    t_min: float = 0.0
    t_max: float = math.inf
    fixed: float | None = None
    distribution: str = "uniform"
    coverage_k: float = 2.0

    def __post_init__(self) -> None:
        if self.name not in PARAM_NAMES:
            raise ValueError(f"unknown parameter {self.name!r}")
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"distribution must be one of {', '.join(DISTRIBUTIONS)}")
        for what, v, lo in (("c", self.c, 0.0), ("t_min", self.t_min, 0.0)):
            if not (math.isfinite(v) and v >= lo):
                raise ValueError(f"{what} must be finite and >= {lo:g}, got {v}")
        if not (math.isfinite(self.k) and self.k > 0):
            raise ValueError(f"k must be finite and > 0, got {self.k}")
        if not (self.t_max > 0 and not math.isnan(self.t_max)) or self.t_max < self.t_min:
            raise ValueError(f"max must be > 0 and >= min, got {self.t_max}")
        if self.fixed is not None and not (math.isfinite(self.fixed) and self.fixed >= 0):
            raise ValueError(f"tolerance must be finite and >= 0, got {self.fixed}")
        if not (math.isfinite(self.coverage_k) and self.coverage_k > 0):
            raise ValueError(f"coverage factor k_normal must be > 0, got {self.coverage_k}")

    @property
    def allocated(self) -> bool:
        """True if the tolerance is chosen by the allocation (not fixed)."""
        return self.fixed is None

    @property
    def u_per_t(self) -> float:
        """Standard uncertainty (rad or mm) per unit of tolerance half-width."""
        f = (
            1.0 / self.coverage_k
            if self.distribution == "normal"
            else TOLERANCE_FACTOR[self.distribution]
        )
        return f * self.scale

    def cost(self, t: float) -> float:
        """``c / t**k`` (0 for a fixed parameter or an unbounded tolerance)."""
        if not self.allocated or math.isinf(t) or self.c == 0.0:
            return 0.0
        return self.c / t**self.k if t > 0 else math.inf


@dataclass(frozen=True)
class Encoder:
    """One catalogue entry: resolution and accuracy (+- bound) in arc seconds, cost.

    The reading error is the accuracy error (``distribution`` within
    +-``accuracy_arcsec``) plus the quantisation error (uniform within half a
    count). ``joints`` lists the joints (1..6) it fits.
    """

    name: str
    resolution_arcsec: float
    accuracy_arcsec: float
    cost: float
    joints: tuple[int, ...] = tuple(range(1, JOINTS + 1))
    distribution: str = "uniform"

    def __post_init__(self) -> None:
        for what, v in (
            ("resolution_arcsec", self.resolution_arcsec),
            ("accuracy_arcsec", self.accuracy_arcsec),
            ("cost", self.cost),
        ):
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{what} must be finite and >= 0, got {v}")
        if not self.joints or any(j not in range(1, JOINTS + 1) for j in self.joints):
            raise ValueError(f"joints must be a non-empty list of 1..{JOINTS}")
        if self.distribution not in DISTRIBUTIONS or self.distribution == "normal":
            raise ValueError("distribution must be uniform, triangular or arcsine")

    @property
    def u_rad(self) -> float:
        """Standard uncertainty of one reading (rad): accuracy and quantisation."""
        acc = self.accuracy_arcsec * TOLERANCE_FACTOR[self.distribution]
        quant = self.resolution_arcsec / math.sqrt(12.0)
        return math.hypot(acc, quant) * ARCSEC_RAD


@dataclass(frozen=True)
class Target:
    """What the arm must reach.

    ``quantity``: ``"point"``, the expanded uncertainty of the probe point
    (the radius about the true point that holds ``coverage`` of the probed
    points; or ``coverage_factor`` times the combined standard uncertainty
    u_c = sqrt(u_x^2 + u_y^2 + u_z^2) if that is given), or ``"length"``, the
    length measurement error (its symmetric ``coverage`` interval must lie in
    +-MPE(L), MPE(L) = ``value_mm + per_metre_mm * L / 1000``). ``over``:
    ``"worst"`` (every pose or length) or ``"rms"`` (RMS over them).
    """

    quantity: Literal["point", "length"] = "point"
    value_mm: float = 0.03
    over: Literal["worst", "rms"] = "worst"
    coverage: float = 0.95
    coverage_factor: float | None = None
    per_metre_mm: float = 0.0
    min_length_mm: float = DEFAULT_MIN_LENGTH_MM

    def __post_init__(self) -> None:
        if self.quantity not in ("point", "length"):
            raise ValueError(f"quantity must be point or length, got {self.quantity!r}")
        if self.over not in ("worst", "rms"):
            raise ValueError(f"over must be worst or rms, got {self.over!r}")
        if not (math.isfinite(self.value_mm) and self.value_mm > 0):
            raise ValueError(f"value must be > 0, got {self.value_mm}")
        if not 0.5 <= self.coverage < 1.0:
            raise ValueError(f"coverage must be in [0.5, 1), got {self.coverage}")
        if self.coverage_factor is not None:
            if not (math.isfinite(self.coverage_factor) and self.coverage_factor > 0):
                raise ValueError(f"coverage_factor must be > 0, got {self.coverage_factor}")
            if self.quantity != "point":
                raise ValueError("coverage_factor applies to the point target only")
        if not (math.isfinite(self.per_metre_mm) and self.per_metre_mm >= 0):
            raise ValueError(f"per_metre must be >= 0, got {self.per_metre_mm}")
        if not (math.isfinite(self.min_length_mm) and self.min_length_mm >= 0):
            raise ValueError(f"min_length_mm must be >= 0, got {self.min_length_mm}")

    def limit_mm(self, length_mm: FloatArray | float) -> FloatArray:
        """The permitted value (mm) for each length (point target: constant)."""
        return np.asarray(self.value_mm + self.per_metre_mm * np.asarray(length_mm) / 1000.0)


@dataclass(frozen=True)
class Workspace:
    """The poses the target applies to (rad, (n, 6)): given, from a log, random."""

    given: FloatArray = field(default_factory=lambda: np.empty((0, JOINTS)))
    logged: FloatArray = field(default_factory=lambda: np.empty((0, JOINTS)))
    random: int = DEFAULT_RANDOM_POSES
    seed: int = 1
    joint_range_rad: FloatArray = field(
        default_factory=lambda: np.tile([-math.pi, math.pi], (JOINTS, 1))
    )
    log_path: str | None = None

    def __post_init__(self) -> None:
        for name in ("given", "logged"):
            a = np.asarray(getattr(self, name), dtype=np.float64).reshape(-1, JOINTS)
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{name} poses must be finite")
            object.__setattr__(self, name, a)
        r = np.asarray(self.joint_range_rad, dtype=np.float64)
        if r.shape != (JOINTS, 2) or not np.all(np.isfinite(r)) or np.any(r[:, 1] <= r[:, 0]):
            raise ValueError(f"joint ranges need {JOINTS} pairs [low, high] with low < high")
        object.__setattr__(self, "joint_range_rad", r)
        if isinstance(self.random, bool) or not isinstance(self.random, int) or self.random < 0:
            raise ValueError(f"random must be an integer >= 0, got {self.random!r}")
        if self.size == 0:
            raise ValueError("no poses: give random > 0, poses or a log")
        if self.size > MAX_POSES:
            raise ValueError(f"{self.size} poses: at most {MAX_POSES}")

    @property
    def size(self) -> int:
        return int(self.given.shape[0] + self.logged.shape[0] + self.random)

    def poses(self) -> FloatArray:
        """All poses (n, 6) in rad: given, then logged, then random (seeded)."""
        rng = np.random.default_rng(self.seed)
        lo, hi = self.joint_range_rad[:, 0], self.joint_range_rad[:, 1]
        rand = lo + (hi - lo) * rng.random((self.random, JOINTS))
        return np.concatenate([self.given, self.logged, rand])

    def describe(self) -> str:
        parts = []
        if self.given.shape[0]:
            parts.append(f"{self.given.shape[0]} given")
        if self.logged.shape[0]:
            parts.append(f"{self.logged.shape[0]} from {self.log_path}")
        if self.random:
            rng = self.joint_range_rad
            full = np.allclose(rng, np.tile([-math.pi, math.pi], (JOINTS, 1)))
            how = "joints uniform in [-180, 180) deg" if full else "joints uniform in their ranges"
            parts.append(f"{self.random} random ({how}, seed {self.seed})")
        return ", ".join(parts) + " poses"


@dataclass(frozen=True)
class CalibrationDesign:
    """Allocate for an arm calibrated with ``plan`` (docs/tolerance.md).

    ``plan``: a shipped plan name or a plan file; the simulated operator's
    articulations for it (``seed``) on the nominal arm, each point with
    ``sigma_mm`` of probing uncertainty per axis, make the design's
    observations; ``free``: the parameters the calibration estimates (None:
    all); ``base_known``: reference points are in the arm's base frame.
    """

    plan: str
    sigma_mm: float = 0.005
    seed: int = 0
    free: tuple[str, ...] | None = None
    base_known: bool = False

    def __post_init__(self) -> None:
        if not (math.isfinite(self.sigma_mm) and self.sigma_mm > 0):
            raise ValueError(f"sigma must be > 0, got {self.sigma_mm}")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}")


@dataclass(frozen=True)
class ToleranceSpec:
    """A whole allocation request (see docs/tolerance.md)."""

    costs: tuple[ParamCost, ...]
    target: Target = field(default_factory=Target)
    workspace: Workspace = field(default_factory=Workspace)
    encoders: tuple[Encoder, ...] = ()
    params: Params = field(default_factory=Params)
    residual_u_mm: float = 0.0
    angle_unit: str = "arcsec"
    length_unit: str = "um"
    calibration: CalibrationDesign | None = None
    source: str = "<spec>"

    def __post_init__(self) -> None:
        if tuple(c.name for c in self.costs) != PARAM_NAMES:
            raise ValueError("costs must list the 25 parameters in PARAM_NAMES order")
        if not (math.isfinite(self.residual_u_mm) and self.residual_u_mm >= 0):
            raise ValueError(f"residual u must be >= 0, got {self.residual_u_mm}")
        if self.encoders:
            for j in range(1, JOINTS + 1):
                if not any(j in e.joints for e in self.encoders):
                    raise ValueError(f"no encoder in the catalogue fits joint {j}")

    @property
    def length_scale(self) -> float:
        """mm per ``length_unit``."""
        return LENGTH_UNITS[self.length_unit]


# --------------------------------------------------------------------------
# Parsing
# --------------------------------------------------------------------------

_TOP = {
    "angle_unit",
    "length_unit",
    "target",
    "workspace",
    "parameters",
    "encoder",
    "nominal",
    "residual",
    "calibration",
}
_TARGET = {
    "quantity",
    "value",
    "over",
    "coverage",
    "coverage_factor",
    "per_metre",
    "min_length_mm",
}
_WORKSPACE = {"random", "seed", "joint_range_deg", "poses", "pose_unit", "log", "log_max"}
_PARAM = {"c", "k", "min", "max", "tolerance", "distribution", "k_normal"}
_ENCODER = {
    "name",
    "resolution_arcsec",
    "bits",
    "accuracy_arcsec",
    "cost",
    "joints",
    "distribution",
}
_RESIDUAL = {"u"}
_CALIBRATION = {"plan", "sigma", "seed", "free", "base_known"}


def _table(doc: Mapping[str, Any], key: str, where: str) -> Mapping[str, Any]:
    v = doc.get(key, {})
    if not isinstance(v, Mapping):
        raise SpecError(f"{where}: expected a table")
    return v


def _no_unknown(t: Mapping[str, Any], allowed: set[str], where: str) -> None:
    bad = set(t) - allowed
    if bad:
        raise SpecError(
            f"{where}: unknown key(s) {', '.join(sorted(bad))} "
            f"(allowed: {', '.join(sorted(allowed))})"
        )


def _num(t: Mapping[str, Any], key: str, where: str, default: float | None = None) -> float:
    if key not in t:
        if default is None:
            raise SpecError(f"{where}.{key}: missing")
        return default
    v = t[key]
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise SpecError(f"{where}.{key}: expected a number, got {v!r}")
    if not math.isfinite(float(v)):
        raise SpecError(f"{where}.{key}: must be finite, got {v!r}")
    return float(v)


def _int(t: Mapping[str, Any], key: str, where: str, default: int) -> int:
    v = t.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int):
        raise SpecError(f"{where}.{key}: expected an integer, got {v!r}")
    return v


def _str(t: Mapping[str, Any], key: str, where: str, default: str, allowed: tuple[str, ...]) -> str:
    v = t.get(key, default)
    if not isinstance(v, str) or v not in allowed:
        raise SpecError(f"{where}.{key}: must be one of {', '.join(allowed)}, got {v!r}")
    return v


def _expand(key: str) -> tuple[str, ...]:
    # the same names and groups as the uncertainty spec (one definition)
    try:
        return expand_names(key)
    except ValueError as e:
        raise SpecError(f"[parameters] {key}: {e}") from e


def _param_costs(doc: Mapping[str, Any], au: str, lu: str) -> tuple[ParamCost, ...]:
    entries = _table(doc, "parameters", "[parameters]")
    got: dict[str, ParamCost] = {}
    # groups first, then single parameters: a joint entry overrides its group
    for key, entry in sorted(entries.items(), key=lambda kv: kv[0] in PARAM_NAMES):
        where = f"[parameters] {key}"
        names = _expand(str(key))
        if not isinstance(entry, Mapping):
            raise SpecError(f"{where}: expected a table like {{ c = 1.0, k = 2 }}")
        _no_unknown(entry, _PARAM, where)
        dist = _str(entry, "distribution", where, "uniform", DISTRIBUTIONS)
        kn = _num(entry, "k_normal", where, 2.0)
        if "k_normal" in entry and dist != "normal":
            raise SpecError(f"{where}.k_normal: applies only to distribution = 'normal'")
        if "tolerance" in entry and ({"c", "k", "min", "max"} & set(entry)):
            raise SpecError(
                f"{where}: give either tolerance (fixed) or the cost model c, k, min, max"
            )
        for n in names:
            angle = PARAM_UNITS[PARAM_NAMES.index(n)] == "rad"
            unit = au if angle else lu
            scale = ANGLE_UNITS[au] if angle else LENGTH_UNITS[lu]
            try:
                if "tolerance" in entry:
                    got[n] = ParamCost(
                        n,
                        unit,
                        scale,
                        fixed=_num(entry, "tolerance", where),
                        distribution=dist,
                        coverage_k=kn,
                    )
                else:
                    got[n] = ParamCost(
                        n,
                        unit,
                        scale,
                        c=_num(entry, "c", where, 1.0),
                        k=_num(entry, "k", where, 2.0),
                        t_min=_num(entry, "min", where, 0.0),
                        t_max=_num(entry, "max", where, math.inf),
                        distribution=dist,
                        coverage_k=kn,
                    )
            except SpecError:
                raise
            except ValueError as e:
                raise SpecError(f"{where}: {e}") from e
    missing = [n for n in PARAM_NAMES if n not in got]
    if missing:
        raise SpecError(
            f"[parameters]: no cost model or tolerance for {', '.join(missing)} "
            f"(every parameter needs one; a group entry like d = {{ c = 1 }} covers six)"
        )
    return tuple(got[n] for n in PARAM_NAMES)


def _target(doc: Mapping[str, Any], lu: str) -> Target:
    t = _table(doc, "target", "[target]")
    if not t:
        raise SpecError("[target]: missing (give at least value = ...)")
    _no_unknown(t, _TARGET, "[target]")
    quantity = _str(t, "quantity", "[target]", "point", ("point", "length"))
    over = _str(t, "over", "[target]", "worst", ("worst", "rms"))
    if quantity == "point":
        for key in ("per_metre", "min_length_mm"):
            if key in t:
                raise SpecError(f"[target].{key}: applies only to quantity = 'length'")
    elif "coverage_factor" in t:
        raise SpecError("[target].coverage_factor: applies only to quantity = 'point'")
    if "coverage" in t and "coverage_factor" in t:
        raise SpecError("[target]: give coverage or coverage_factor, not both")
    scale = LENGTH_UNITS[lu]
    try:
        return Target(
            quantity=quantity,  # type: ignore[arg-type]
            value_mm=_num(t, "value", "[target]") * scale,
            over=over,  # type: ignore[arg-type]
            coverage=_num(t, "coverage", "[target]", 0.95),
            coverage_factor=_num(t, "coverage_factor", "[target]")
            if "coverage_factor" in t
            else None,
            per_metre_mm=_num(t, "per_metre", "[target]", 0.0) * scale,
            min_length_mm=_num(t, "min_length_mm", "[target]", DEFAULT_MIN_LENGTH_MM),
        )
    except SpecError:
        raise
    except ValueError as e:
        raise SpecError(f"[target]: {e}") from e


def _poses(value: Any, unit: str, where: str) -> FloatArray:
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise SpecError(f"{where}: expected lists of {JOINTS} numbers") from e
    if a.size == 0:
        return np.empty((0, JOINTS))
    if a.ndim != 2 or a.shape[1] != JOINTS or not np.all(np.isfinite(a)):
        raise SpecError(f"{where}: each pose needs {JOINTS} finite joint angles")
    return np.radians(a) if unit == "deg" else a


def _workspace(doc: Mapping[str, Any], base: Path | None) -> Workspace:
    w = _table(doc, "workspace", "[workspace]")
    _no_unknown(w, _WORKSPACE, "[workspace]")
    pu = _str(w, "pose_unit", "[workspace]", "deg", ("deg", "rad"))
    given = _poses(w.get("poses", []), pu, "[workspace].poses")
    logged = np.empty((0, JOINTS))
    log_path = None
    if "log" in w:
        if not isinstance(w["log"], str) or not w["log"]:
            raise SpecError("[workspace].log: expected a file name")
        from aacmm.analysis.poselog import read_pose_log

        p = Path(w["log"])
        if not p.is_absolute() and base is not None:
            p = base / p
        log_path = str(p)
        try:
            logged = read_pose_log(p).theta_rad
        except ValueError as e:
            raise SpecError(f"[workspace].log: {e}") from e
        cap = _int(w, "log_max", "[workspace]", 2000)
        if cap < 1:
            raise SpecError(f"[workspace].log_max: must be >= 1, got {cap}")
        if logged.shape[0] > cap:  # evenly spaced, so a long log keeps its spread
            logged = logged[np.linspace(0, logged.shape[0] - 1, cap).round().astype(int)]
    elif "log_max" in w:
        raise SpecError("[workspace].log_max: applies only with log = ...")
    has_other = given.shape[0] > 0 or logged.shape[0] > 0
    random = _int(w, "random", "[workspace]", 0 if has_other else DEFAULT_RANDOM_POSES)
    seed = _int(w, "seed", "[workspace]", 1)
    if seed < 0:
        raise SpecError(f"[workspace].seed: must be >= 0, got {seed}")
    rng = np.tile([-180.0, 180.0], (JOINTS, 1))
    if "joint_range_deg" in w:
        try:
            rng = np.asarray(w["joint_range_deg"], dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise SpecError("[workspace].joint_range_deg: expected 6 pairs [low, high]") from e
        if (
            rng.shape != (JOINTS, 2)
            or not np.all(np.isfinite(rng))
            or np.any(rng[:, 1] <= rng[:, 0])
        ):
            raise SpecError(
                f"[workspace].joint_range_deg: expected {JOINTS} pairs [low, high], low < high"
            )
    try:
        return Workspace(given, logged, random, seed, np.radians(rng), log_path)
    except ValueError as e:
        raise SpecError(f"[workspace]: {e}") from e


def _encoders(doc: Mapping[str, Any]) -> tuple[Encoder, ...]:
    raw = doc.get("encoder", [])
    if isinstance(raw, Mapping) or not isinstance(raw, list):
        raise SpecError("[[encoder]]: expected an array of tables ([[encoder]] entries)")
    out = []
    for i, e in enumerate(raw):
        where = f"[[encoder]] #{i + 1}"
        if not isinstance(e, Mapping):
            raise SpecError(f"{where}: expected a table")
        _no_unknown(e, _ENCODER, where)
        name = e.get("name", f"encoder {i + 1}")
        if not isinstance(name, str) or not name.strip():
            raise SpecError(f"{where}.name: expected a non-empty string")
        where = f"[[encoder]] {name!r}"
        if ("bits" in e) == ("resolution_arcsec" in e):
            raise SpecError(f"{where}: give exactly one of resolution_arcsec or bits")
        if "bits" in e:
            bits = _int(e, "bits", where, 0)
            if not 1 <= bits <= 40:
                raise SpecError(f"{where}.bits: must be in 1..40, got {bits}")
            res = FULL_TURN_ARCSEC / 2.0**bits
        else:
            res = _num(e, "resolution_arcsec", where)
        joints = e.get("joints", list(range(1, JOINTS + 1)))
        if not isinstance(joints, list) or not all(
            isinstance(j, int) and not isinstance(j, bool) for j in joints
        ):
            raise SpecError(f"{where}.joints: expected a list of joint numbers 1..{JOINTS}")
        try:
            out.append(
                Encoder(
                    name,
                    res,
                    _num(e, "accuracy_arcsec", where),
                    _num(e, "cost", where),
                    tuple(joints),
                    _str(e, "distribution", where, "uniform", ("uniform", "triangular", "arcsine")),
                )
            )
        except SpecError:
            raise
        except ValueError as err:
            raise SpecError(f"{where}: {err}") from err
    names = [e.name for e in out]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise SpecError(f"[[encoder]]: duplicate name(s) {', '.join(sorted(dup))}")
    return tuple(out)


def _calibration(doc: Mapping[str, Any], lu: str, base: Path | None) -> CalibrationDesign | None:
    if "calibration" not in doc:
        return None
    c = _table(doc, "calibration", "[calibration]")
    _no_unknown(c, _CALIBRATION, "[calibration]")
    plan = c.get("plan")
    if not isinstance(plan, str) or not plan:
        raise SpecError("[calibration].plan: expected a shipped plan name or a plan file")
    if base is not None and not Path(plan).is_absolute() and (base / plan).exists():
        plan = str(base / plan)
    free = c.get("free")
    if free is not None:
        if not isinstance(free, list) or not all(isinstance(x, str) for x in free):
            raise SpecError("[calibration].free: expected a list of parameter names or groups")
        from aacmm.calibration import parse_names

        try:
            free = parse_names(free)
        except ValueError as e:
            raise SpecError(f"[calibration].free: {e}") from e
    known = c.get("base_known", False)
    if not isinstance(known, bool):
        raise SpecError("[calibration].base_known: expected true or false")
    try:
        return CalibrationDesign(
            plan,
            _num(c, "sigma", "[calibration]", 5.0) * LENGTH_UNITS[lu],
            _int(c, "seed", "[calibration]", 0),
            free,
            known,
        )
    except ValueError as e:
        raise SpecError(f"[calibration]: {e}") from e


def parse_spec(doc: Mapping[str, Any], base: Path | None = None) -> ToleranceSpec:
    """Build a :class:`ToleranceSpec` from a parsed TOML document.

    ``base`` is the directory relative file names (``[workspace].log``) are
    resolved against. Raises SpecError naming the field for anything invalid.
    """
    _no_unknown(doc, _TOP, "top level")
    au = _str(doc, "angle_unit", "top level", "arcsec", tuple(ANGLE_UNITS))
    lu = _str(doc, "length_unit", "top level", "um", tuple(LENGTH_UNITS))
    try:
        params = Params(**_table(doc, "nominal", "[nominal]"))
        params.validate()
    except (TypeError, ValueError) as e:
        raise SpecError(f"[nominal]: {e}") from e
    target = _target(doc, lu)
    costs = _param_costs(doc, au, lu)
    workspace = _workspace(doc, base)
    encoders = _encoders(doc)
    res = _table(doc, "residual", "[residual]")
    _no_unknown(res, _RESIDUAL, "[residual]")
    residual = _num(res, "u", "[residual]", 0.0)
    if residual < 0:
        raise SpecError(f"[residual].u: must be >= 0, got {residual}")
    calibration = _calibration(doc, lu, base)
    try:
        return ToleranceSpec(
            costs,
            target,
            workspace,
            encoders,
            params,
            residual * LENGTH_UNITS[lu],
            au,
            lu,
            calibration,
        )
    except ValueError as e:
        raise SpecError(f"{e}") from e


def load_spec(path: str | Path) -> ToleranceSpec:
    """Read and parse a tolerance spec file (see :func:`parse_spec`).

    Raises SpecError ("FILE: FIELD: reason") if the file cannot be read, is
    not TOML (or is nested absurdly deep), or is invalid.
    """
    from aacmm.fileio import InputFileError, load_toml

    p = Path(path)
    try:
        doc = load_toml(p)
    except InputFileError as e:
        raise SpecError(str(e)) from e
    try:
        spec = parse_spec(doc, p.parent)
    except (SpecError, ValueError) as e:
        raise SpecError(f"{p}: {e}") from e
    return replace(spec, source=str(p))
