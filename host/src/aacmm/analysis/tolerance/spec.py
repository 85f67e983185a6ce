"""Reading the tolerance-allocation request from TOML: every error names the file and field.

:func:`load_spec` reads a TOML file (format in docs/tolerance.md); every
error names the file and the field (``arm.toml: [parameters] d3.k: must be
> 0, got -1``). :func:`parse_spec` does the same for a parsed document.

Units: tolerances are half-widths ``t`` (the part is good if its error lies
in +-t) in the spec's ``angle_unit`` (default arcsec) and ``length_unit``
(default um); the cost of a parameter is ``c / t**k`` with ``t`` in those
units, so ``c`` reads as "the cost of holding one unit". Inside the package
angles are in rad and lengths in mm, as everywhere in aacmm.

The request's dataclasses (:class:`ToleranceSpec` and its parts) are in
:mod:`aacmm.analysis.tolerance.request`; :class:`SpecError` is
:mod:`aacmm.uncertainty.spec`'s (both: :mod:`aacmm.analysis.tolerance`).

Any arm (issue 26): ``parse_spec(doc, base, arm, model)`` reads the request
for an arm model's arm: the parameter names and groups are its own
(:func:`aacmm.uncertainty.spec.expand_name`; a name this arm does not have
but another may is an :class:`~aacmm.uncertainty.spec.ArmParameterError`),
poses and joint ranges have N angles, encoders fit joints 1..N, and
``[nominal]`` (the paper's arm's values) is refused: the model is the nominal.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from aacmm.analysis.tolerance.request import (
    DEFAULT_MIN_LENGTH_MM,
    DEFAULT_RANDOM_POSES,
    CalibrationDesign,
    Encoder,
    ParamCost,
    Target,
    ToleranceSpec,
    Workspace,
)
from aacmm.arm import Arm
from aacmm.core import FloatArray, Params
from aacmm.errors import AacmmError
from aacmm.uncertainty.spec import (
    ANGLE_UNITS,
    DISTRIBUTIONS,
    LENGTH_UNITS,
    ArmParameterError,
    SpecError,
    expand_name,
)

__all__ = [
    "FULL_TURN_ARCSEC",
    "load_spec",
    "parse_spec",
]

FULL_TURN_ARCSEC = 1_296_000.0


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


def _expand(key: str, arm: Arm) -> tuple[str, ...]:
    # the same names and groups as the uncertainty spec (one definition)
    try:
        return expand_name(key, arm)
    except SpecError as e:
        raise type(e)(f"[parameters] {key}: {e}") from e


def _param_costs(doc: Mapping[str, Any], au: str, lu: str, arm: Arm) -> tuple[ParamCost, ...]:
    entries = _table(doc, "parameters", "[parameters]")
    got: dict[str, ParamCost] = {}
    all_names, units = arm.param_names, arm.param_units
    # groups first, then single parameters: a joint entry overrides its group
    for key, entry in sorted(entries.items(), key=lambda kv: kv[0] in all_names):
        where = f"[parameters] {key}"
        names = _expand(str(key), arm)
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
            angle = units[all_names.index(n)] == "rad"
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
    missing = [n for n in all_names if n not in got]
    if missing:
        covers = "six" if arm.n_joints == 6 else str(arm.n_joints)
        raise SpecError(
            f"[parameters]: no cost model or tolerance for {', '.join(missing)} "
            f"(every parameter needs one; a group entry like d = {{ c = 1 }} covers {covers})"
        )
    return tuple(got[n] for n in all_names)


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


def _poses(value: Any, unit: str, where: str, joints: int) -> FloatArray:
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise SpecError(f"{where}: expected lists of {joints} numbers") from e
    if a.size == 0:
        return np.empty((0, joints))
    if a.ndim != 2 or a.shape[1] != joints or not np.all(np.isfinite(a)):
        raise SpecError(f"{where}: each pose needs {joints} finite joint angles")
    return np.radians(a) if unit == "deg" else a


def _workspace(
    doc: Mapping[str, Any],
    base: Path | None,
    joints: int,
    limits: Sequence[tuple[float, float]] | None = None,
) -> Workspace:
    w = _table(doc, "workspace", "[workspace]")
    _no_unknown(w, _WORKSPACE, "[workspace]")
    pu = _str(w, "pose_unit", "[workspace]", "deg", ("deg", "rad"))
    given = _poses(w.get("poses", []), pu, "[workspace].poses", joints)
    logged = np.empty((0, joints))
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
        if logged.shape[1] != joints:
            raise SpecError(
                f"[workspace].log: {p} has poses of {logged.shape[1]} joints, the arm {joints}"
            )
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
    rng = np.tile([-180.0, 180.0], (joints, 1))
    if limits is not None:  # an arm model's joint limits (rad): its random poses within them
        rng = np.degrees(np.asarray(limits, dtype=np.float64))
        rng[~np.isfinite(rng).all(axis=1)] = [-180.0, 180.0]
    if "joint_range_deg" in w:
        try:
            rng = np.asarray(w["joint_range_deg"], dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise SpecError(
                f"[workspace].joint_range_deg: expected {joints} pairs [low, high]"
            ) from e
        if (
            rng.shape != (joints, 2)
            or not np.all(np.isfinite(rng))
            or np.any(rng[:, 1] <= rng[:, 0])
        ):
            raise SpecError(
                f"[workspace].joint_range_deg: expected {joints} pairs [low, high], low < high"
            )
    try:
        return Workspace(given, logged, random, seed, np.radians(rng), log_path, joints)
    except ValueError as e:
        raise SpecError(f"[workspace]: {e}") from e


def _encoders(doc: Mapping[str, Any], joints_n: int) -> tuple[Encoder, ...]:
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
        joints = e.get("joints", list(range(1, joints_n + 1)))
        if not isinstance(joints, list) or not all(
            isinstance(j, int) and not isinstance(j, bool) for j in joints
        ):
            raise SpecError(f"{where}.joints: expected a list of joint numbers 1..{joints_n}")
        if any(not 1 <= j <= joints_n for j in joints):
            raise SpecError(
                f"{where}.joints: joint numbers are 1..{joints_n} (the arm's joints), got {joints}"
            )
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


def _nominal_file(
    nominal: Mapping[str, Any], base: Path | None, arm: Arm | None, model: str | None
) -> Params | Arm:
    """``[nominal] file = "FILE"``: the nominal arm from a parameter file (a
    calibrated set, ``aacmm calibrate -o``; relative to the spec), of the shape
    of ``arm`` (None: the paper's arm). Raises SpecError (ArmParameterError for
    a file of another arm's shape)."""
    from aacmm.records.paramfile import load_param_file

    if set(nominal) != {"file"} or not isinstance(nominal["file"], str) or not nominal["file"]:
        raise SpecError("[nominal].file: a parameter file's name, and nothing else in [nominal]")
    path = Path(nominal["file"])
    if base is not None and not path.is_absolute():
        path = base / path
    try:
        ps = load_param_file(path)
    except AacmmError as e:
        raise SpecError(f"[nominal].file: {e}") from e
    got = ps.to_arm()[0]
    want = Arm.paper() if arm is None else arm
    if (got.n_joints, got.tip, [(j.convention, j.beta_rad is None) for j in got.joints]) != (
        want.n_joints,
        want.tip,
        [(j.convention, j.beta_rad is None) for j in want.joints],
    ):
        what = "the paper's arm" if arm is None else f"model {model or '(given)'}"
        raise ArmParameterError(
            f"[nominal].file: {path} is a set of an arm of {got.n_joints} joints and "
            f"{got.n_params} parameters, not of {what} ({want.n_joints} joints, "
            f"{want.n_params} parameters)"
        )
    if arm is None:
        return ps.to_core()[0]
    return got


def parse_spec(
    doc: Mapping[str, Any],
    base: Path | None = None,
    arm: Arm | None = None,
    model: str | None = None,
    limits: Sequence[tuple[float, float]] | None = None,
) -> ToleranceSpec:
    """Build a :class:`ToleranceSpec` from a parsed TOML document.

    ``base`` is the directory relative file names (``[workspace].log``) are
    resolved against. ``arm``: the nominal arm (an arm model's, ``model`` its
    name); None or the paper's arm itself: the paper's arm, ``[nominal]``
    allowed. ``limits``: the arm's joint limits (N pairs in rad, ``(-inf,
    inf)`` for none: an arm model's ``joint_limits_rad``), the default range of
    the random workspace poses (without: every joint in [-180, 180) deg; a
    joint without limits keeps that); ``[workspace].joint_range_deg`` overrides
    it. Raises SpecError naming the field for anything invalid
    (ArmParameterError: a parameter this arm does not have).
    """
    _no_unknown(doc, _TOP, "top level")
    au = _str(doc, "angle_unit", "top level", "arcsec", tuple(ANGLE_UNITS))
    lu = _str(doc, "length_unit", "top level", "um", tuple(LENGTH_UNITS))
    params: Params | Arm
    paper = arm is None or arm == Arm.paper()
    nominal = _table(doc, "nominal", "[nominal]")
    if "file" in nominal:
        params = _nominal_file(nominal, base, arm if not paper else None, model)
        the_arm = params.to_arm() if isinstance(params, Params) else params
    elif paper:
        try:
            params = Params(**nominal)
            params.validate()
        except (TypeError, ValueError) as e:
            raise SpecError(f"[nominal]: {e}") from e
        the_arm = params.to_arm()
    else:
        if "nominal" in doc:
            raise SpecError(
                f"[nominal]: gives the paper's arm's values; the nominal arm here is the "
                f"model {model or '(given)'}: remove [nominal], give a parameter file of "
                "the arm (file = ...) or edit the model file"
            )
        assert arm is not None
        params = the_arm = arm
    target = _target(doc, lu)
    costs = _param_costs(doc, au, lu, the_arm)
    if limits is not None and len(limits) != the_arm.n_joints:
        raise ValueError(f"{len(limits)} joint limits for an arm of {the_arm.n_joints} joints")
    workspace = _workspace(doc, base, the_arm.n_joints, limits)
    encoders = _encoders(doc, the_arm.n_joints)
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
            model=model,
            joint_limits_rad=(
                None
                if limits is None or isinstance(params, Params)
                else tuple((float(lo), float(hi)) for lo, hi in limits)
            ),
        )
    except ValueError as e:
        raise SpecError(f"{e}") from e


def load_spec(
    path: str | Path,
    arm: Arm | None = None,
    model: str | None = None,
    limits: Sequence[tuple[float, float]] | None = None,
) -> ToleranceSpec:
    """Read and parse a tolerance spec file (see :func:`parse_spec`; ``arm``,
    ``model``, ``limits``: the nominal arm, its model's name and its joint
    limits, default the paper's arm with every joint in [-180, 180) deg).

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
        spec = parse_spec(doc, p.parent, arm, model, limits)
    except SpecError as e:
        raise type(e)(f"{p}: {e}") from e
    except ValueError as e:
        raise SpecError(f"{p}: {e}") from e
    return replace(spec, source=str(p))
