"""Parameter-uncertainty specifications for :mod:`aacmm.uncertainty`.

A spec is the nominal arm, one standard uncertainty and distribution per
structural parameter (or a full P x P covariance of correlated normal
parameters, as a calibration gives) and, optionally, poses.
:func:`load_spec` reads the TOML format (docs/montecarlo.md; ``"example"``
is the packaged example), :func:`parse_spec` a parsed document.

Any arm (issue 26): the nominal arm is the paper's (:class:`aacmm.core.Params`,
25 parameters, the default) or any :class:`aacmm.arm.Arm` (an arm model's,
``parse_spec(doc, arm)``); the parameter names are the arm's
(:attr:`aacmm.arm.Arm.param_names`), groups ``theta``, ``alpha``, ``d``,
``a``, ``beta`` (its declared betas) and ``tip`` (``l``, or ``tx, ty, tz``).

Errors: :class:`SpecError` (a ValueError) for unknown parameter names,
negative or non-finite uncertainties, unknown distributions or units, bad
poses, unreadable or invalid files; :class:`ArmParameterError` (a SpecError)
for a parameter name some arm has but this arm does not (``theta7`` for the
paper's six joints, ``beta3`` for an arm without that beta): a spec of
another arm.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from aacmm.arm import Arm
from aacmm.core import JOINTS, PARAM_NAMES, FloatArray, Params
from aacmm.errors import AacmmError
from aacmm.fileio import InputFileError, load_toml, loads_toml

ANGLE_UNITS: dict[str, float] = {
    "rad": 1.0,
    "mrad": 1e-3,
    "urad": 1e-6,
    "deg": math.pi / 180.0,
    "arcmin": math.pi / 10800.0,
    "arcsec": math.pi / 648000.0,
}
LENGTH_UNITS: dict[str, float] = {"mm": 1.0, "um": 1e-3}
#: Distribution -> standard uncertainty of a tolerance (half-width) a, as u = a * factor.
TOLERANCE_FACTOR: dict[str, float] = {
    "uniform": 1.0 / math.sqrt(3.0),
    "triangular": 1.0 / math.sqrt(6.0),
    "arcsine": 1.0 / math.sqrt(2.0),
    "normal": 0.5,  # tolerance taken as an expanded uncertainty with k = 2 unless k is given
}
DISTRIBUTIONS: tuple[str, ...] = ("normal", "uniform", "triangular", "arcsine")


class SpecError(AacmmError, ValueError):
    """A parameter-uncertainty or tolerance spec file is unreadable or invalid
    (message: file, field, reason)."""


class ArmParameterError(SpecError):
    """A spec names a parameter that some arm has but this arm does not (a
    spec of another arm: ``aacmm uncertainty`` exits with status 10)."""


#: A parameter name of any arm (4 to 7 joints): theta/alpha/d/a of a joint,
#: beta of joints 2..7, the tip l or tx, ty, tz.
_ANY_ARM_NAME = re.compile(r"^(?:(?:theta|alpha|d|a)[1-7]|beta[2-7]|l|tx|ty|tz)$")
#: Group names: a joint parameter kind (every joint) and the tip.
GROUPS: tuple[str, ...] = ("theta", "alpha", "d", "a", "beta", "tip")


def is_param_name(name: str) -> bool:
    """True for a parameter name some arm of 4 to 7 joints has (``theta7``,
    ``beta3``, ``tx`` ...): the names :class:`ParamUncertainty` accepts."""
    return bool(_ANY_ARM_NAME.match(name))


def param_group(name: str) -> str:
    """The group of a parameter: ``theta``, ``alpha``, ``d``, ``a``, ``beta``, ``l``
    (the paper's tip) or ``tip`` (a tip vector tx, ty, tz)."""
    if name in ("tx", "ty", "tz"):
        return "tip"
    return name.rstrip("0123456789")


def group_names(names: Sequence[str]) -> tuple[str, ...]:
    """The groups of an arm's parameters, in column order (paper: theta, alpha, d, a, l)."""
    return tuple(dict.fromkeys(param_group(n) for n in names))


def _arm_of(params: Params | Arm) -> Arm:
    return params.to_arm() if isinstance(params, Params) else params


def _describe_names(arm: Arm) -> str:
    """``theta1..6, alpha1..6, d1..6, a1..6, l`` for an arm."""
    n = arm.n_joints
    parts = [f"{g}1..{n}" for g in ("theta", "alpha", "d", "a")]
    if arm.beta_joints:
        parts.append(", ".join(f"beta{j + 1}" for j in arm.beta_joints))
    parts.append("tx, ty, tz" if arm.tip == "xyz" else "l")
    return ", ".join(parts)


def _unknown_name(name: str, arm: Arm) -> SpecError:
    """The error for a name that is not a parameter or group of ``arm``."""
    if _ANY_ARM_NAME.match(name):
        return ArmParameterError(
            f"parameter {name!r} is not one of this arm's ({arm.n_joints} joints, "
            f"{arm.n_params} parameters: {_describe_names(arm)}): a spec of another arm? "
            "(give its model with --model)"
        )
    return SpecError(
        f"unknown parameter name {name!r} (expected {_describe_names(arm)}, "
        f"or a group {', '.join(group_names(arm.param_names))})"
    )


@dataclass(frozen=True)
class ParamUncertainty:
    """Standard uncertainty ``u`` (rad or mm) of one parameter and its distribution."""

    name: str
    u: float
    distribution: str = "normal"

    def __post_init__(self) -> None:
        if not is_param_name(self.name):
            raise ValueError(
                f"unknown parameter name {self.name!r} (expected theta<j>, alpha<j>, d<j>, "
                f"a<j> (j = 1..7), beta<j> (j = 2..7), l, tx, ty or tz)"
            )
        if not math.isfinite(self.u) or self.u < 0:
            raise ValueError(f"{self.name}: uncertainty must be finite and >= 0, got {self.u}")
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(
                f"{self.name}: unknown distribution {self.distribution!r} "
                f"(one of {', '.join(DISTRIBUTIONS)})"
            )

    def sample(self, rng: np.random.Generator, m: int) -> FloatArray:
        """``m`` zero-mean draws with standard deviation ``u``."""
        u = self.u
        if u == 0.0:
            return np.zeros(m)
        if self.distribution == "normal":
            return u * rng.standard_normal(m)
        if self.distribution == "uniform":
            a = u * math.sqrt(3.0)
            return rng.uniform(-a, a, m)
        if self.distribution == "triangular":
            a = u * math.sqrt(6.0)
            return rng.triangular(-a, 0.0, a, m)
        a = u * math.sqrt(2.0)  # arcsine on [-a, a]
        return a * np.sin(2.0 * math.pi * rng.random(m))


@dataclass(frozen=True)
class UncertaintySpec:
    """Nominal arm, one :class:`ParamUncertainty` per parameter (P), and poses (k, N) rad.

    ``params`` is the paper's arm (:class:`aacmm.core.Params`, P = 25, N = 6,
    the default) or any :class:`aacmm.arm.Arm`; ``items`` follow its
    :attr:`param_names`. ``covariance`` (P, P; rad, mm), optional:
    correlated normal parameters (a calibration's result,
    :meth:`from_covariance`) instead of independent ones; the items then
    carry the standard uncertainties sqrt(diag). ``model`` names the arm
    model for reports (None: the paper's arm, or an arm made in code).
    """

    params: Params | Arm
    items: tuple[ParamUncertainty, ...]
    poses_rad: FloatArray = field(default_factory=lambda: np.empty((0, JOINTS)))
    covariance: FloatArray | None = None
    model: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.params, Params | Arm):
            raise ValueError(f"a spec needs Params or an Arm, got {type(self.params).__name__}")
        names = self.param_names
        if tuple(i.name for i in self.items) != names:
            raise ValueError(
                f"items must list the arm's {len(names)} parameters in column order "
                f"({names[0]} .. {names[-1]})"
            )
        p = np.asarray(self.poses_rad, dtype=np.float64)
        if p.size == 0:
            p = np.empty((0, self.joints))
        elif p.ndim != 2 or p.shape[1] != self.joints:
            raise ValueError(f"poses need {self.joints} joint angles each (the arm's joints)")
        object.__setattr__(self, "poses_rad", p)
        if self.covariance is not None:
            c = np.asarray(self.covariance, dtype=np.float64)
            k = len(names)
            if c.shape != (k, k) or not np.all(np.isfinite(c)):
                raise ValueError(f"covariance must be a finite {k} x {k} matrix")
            if not np.allclose(c, c.T, rtol=1e-9, atol=1e-300):
                raise ValueError("covariance must be symmetric")
            if np.linalg.eigvalsh(c)[0] < -1e-9 * max(float(np.abs(c).max()), 1e-300):
                raise ValueError("covariance must be positive semi-definite")
            object.__setattr__(self, "covariance", c)

    @property
    def arm(self) -> Arm:
        """The nominal arm as an :class:`aacmm.arm.Arm` (the paper's: ``Params.to_arm``)."""
        return _arm_of(self.params)

    @property
    def param_names(self) -> tuple[str, ...]:
        """The P parameter names in Jacobian column order (paper: :data:`PARAM_NAMES`)."""
        return PARAM_NAMES if isinstance(self.params, Params) else self.params.param_names

    @property
    def param_units(self) -> tuple[str, ...]:
        """The unit of each parameter (rad or mm), column order."""
        return self.arm.param_units

    @property
    def joints(self) -> int:
        """N, the arm's joints: the width of every pose."""
        return JOINTS if isinstance(self.params, Params) else self.params.n_joints

    @classmethod
    def from_covariance(
        cls,
        covariance: FloatArray,
        params: Params | Arm,
        poses_rad: FloatArray | None = None,
        model: str | None = None,
    ) -> UncertaintySpec:
        """Spec of correlated normal parameters with covariance (P, P) about ``params``."""
        u = np.sqrt(np.clip(np.diag(np.asarray(covariance, dtype=np.float64)), 0.0, None))
        names = PARAM_NAMES if isinstance(params, Params) else params.param_names
        if u.size != len(names):
            raise ValueError(f"covariance must be a {len(names)} x {len(names)} matrix")
        joints = JOINTS if isinstance(params, Params) else params.n_joints
        return cls(
            params,
            tuple(ParamUncertainty(n, float(u[k])) for k, n in enumerate(names)),
            np.empty((0, joints)) if poses_rad is None else poses_rad,
            covariance,
            model,
        )

    def covariance_matrix(self) -> FloatArray:
        """The (P, P) covariance: the given one, or diag(u^2) for independent parameters."""
        if self.covariance is not None:
            return self.covariance
        return np.diag(self.u_vector() ** 2)

    @classmethod
    def from_u(
        cls,
        u: Mapping[str, float],
        params: Params | Arm | None = None,
        distribution: str = "normal",
        model: str | None = None,
    ) -> UncertaintySpec:
        """Spec from {name: u}, names of the arm's parameters or groups (theta, alpha,
        d, a, beta, tip; :func:`expand_name`); the paper's arm by default.

        Raises SpecError (ArmParameterError) for a name the arm does not have.
        """
        nominal = params or Params()
        arm = _arm_of(nominal)
        names = arm.param_names
        vals = {n: 0.0 for n in names}
        for k, v in u.items():
            for n in expand_name(k, arm):
                vals[n] = float(v)
        return cls(
            nominal,
            tuple(ParamUncertainty(n, vals[n], distribution) for n in names),
            model=model,
        )

    def u_vector(self) -> FloatArray:
        """Standard uncertainties (P,) in Jacobian column order (rad, mm)."""
        return np.array([i.u for i in self.items], dtype=np.float64)


def expand_name(name: str, arm: Arm | None = None) -> tuple[str, ...]:
    """The parameters of ``arm`` (default: the paper's) a name stands for: itself
    (``d3``) or a group (``d``: d1..dN; ``beta``: the declared betas, none on
    an arm without; ``tip``: ``l`` or tx, ty, tz).

    Raises SpecError for an unknown name: :class:`ArmParameterError` for one
    another arm has (``theta7`` on six joints), SpecError otherwise.
    """
    a = arm if arm is not None else Arm.paper()
    names = a.param_names
    if name in names:
        return (name,)
    if name in GROUPS:
        # "beta" is every declared beta: none on an arm without (a spec that fits many arms)
        return tuple(n for n in names if param_group(n) == name or (name == "tip" and n == "l"))
    raise _unknown_name(name, a)


_TOP_KEYS = {"angle_unit", "length_unit", "pose_unit", "nominal", "parameters", "poses"}
_ENTRY_KEYS = {"u", "tolerance", "distribution", "k"}


def parse_spec(
    doc: Mapping[str, Any], arm: Arm | None = None, model: str | None = None
) -> UncertaintySpec:
    """Build a spec from a parsed TOML document.

    Keys: ``angle_unit`` (rad, mrad, urad, deg, arcmin, arcsec; default rad)
    and ``length_unit`` (mm, um; default mm) for the uncertainties;
    ``pose_unit`` (rad or deg; default deg) for ``poses``, a list of
    N-angle lists; ``[nominal]`` with :class:`aacmm.core.Params` fields
    (default: paper Table 1; the paper's arm only); ``[parameters]`` with
    one table per parameter or group (:func:`expand_name`):
    ``{u = ..., distribution = ...}`` (standard uncertainty) or
    ``{tolerance = ..., distribution = ..., k = ...}`` (half-width;
    u = a/sqrt(3) uniform, a/sqrt(6) triangular, a/sqrt(2) arcsine, a/k
    normal with k = 2 by default). A joint entry (``d3``) overrides its group
    (``d``) whatever the order.

    ``arm``: the nominal arm (an arm model's, ``model`` its name); None, or
    the paper's arm itself, is the paper's arm in its :class:`Params` form
    (``[nominal]`` allowed). Another arm takes no ``[nominal]`` (the model
    is the nominal).

    Raises SpecError for anything else; ArmParameterError (a SpecError) for
    a parameter this arm does not have but another may.
    """
    try:
        return _parse(doc, arm, model)
    except SpecError:
        raise
    except (ValueError, TypeError, KeyError) as e:
        raise SpecError(str(e)) from e


def _parse(doc: Mapping[str, Any], arm: Arm | None, model: str | None) -> UncertaintySpec:
    unknown = set(doc) - _TOP_KEYS
    if unknown:
        raise SpecError(
            f"unknown key(s) {', '.join(sorted(unknown))} (allowed: {', '.join(sorted(_TOP_KEYS))})"
        )
    au = str(doc.get("angle_unit", "rad"))
    lu = str(doc.get("length_unit", "mm"))
    pu = str(doc.get("pose_unit", "deg"))
    if au not in ANGLE_UNITS:
        raise SpecError(f"unknown angle_unit {au!r} (one of {', '.join(ANGLE_UNITS)})")
    if lu not in LENGTH_UNITS:
        raise SpecError(f"unknown length_unit {lu!r} (one of {', '.join(LENGTH_UNITS)})")
    if pu not in ("rad", "deg"):
        raise SpecError(f"unknown pose_unit {pu!r} (rad or deg)")
    nominal: Params | Arm
    if arm is None or arm == Arm.paper():
        nominal = Params(**doc.get("nominal", {}))
        nominal.validate()
    else:
        if "nominal" in doc:
            raise SpecError(
                f"[nominal] gives the paper's arm's values; the nominal arm here is "
                f"the model {model or '(given)'}: remove [nominal] (or edit the model file)"
            )
        nominal = arm
    the_arm = _arm_of(nominal)
    all_names = the_arm.param_names
    units = the_arm.param_units
    joints = the_arm.n_joints
    entries = doc.get("parameters", {})
    if not isinstance(entries, Mapping) or not entries:
        raise SpecError("no [parameters] table: give at least one parameter uncertainty")
    # groups first, then single parameters, so a joint entry overrides its group
    ordered = sorted(entries.items(), key=lambda kv: kv[0] in all_names)
    items: dict[str, ParamUncertainty] = {n: ParamUncertainty(n, 0.0) for n in all_names}
    for key, entry in ordered:
        names = expand_name(str(key), the_arm)
        if not isinstance(entry, Mapping):
            raise SpecError(f"{key}: expected a table like {{ u = 1.0 }}")
        bad = set(entry) - _ENTRY_KEYS
        if bad:
            raise SpecError(
                f"{key}: unknown key(s) {', '.join(sorted(bad))} "
                f"(allowed: {', '.join(sorted(_ENTRY_KEYS))})"
            )
        dist = str(entry.get("distribution", "normal" if "u" in entry else "uniform"))
        if dist not in DISTRIBUTIONS:
            raise SpecError(
                f"{key}: unknown distribution {dist!r} (one of {', '.join(DISTRIBUTIONS)})"
            )
        if ("u" in entry) == ("tolerance" in entry):
            raise SpecError(
                f"{key}: give exactly one of u (standard uncertainty) or tolerance (half-width)"
            )
        raw = float(entry["u"] if "u" in entry else entry["tolerance"])
        if not math.isfinite(raw) or raw < 0:
            raise SpecError(f"{key}: uncertainty must be finite and >= 0, got {raw}")
        if "tolerance" in entry:
            if dist == "normal":
                k = float(entry.get("k", 2.0))
                if not math.isfinite(k) or k <= 0:
                    raise SpecError(f"{key}: coverage factor k must be > 0, got {k}")
                raw /= k
            else:
                if "k" in entry:
                    raise SpecError(f"{key}: k applies only to a normal tolerance")
                raw *= TOLERANCE_FACTOR[dist]
        elif "k" in entry:
            raise SpecError(f"{key}: k applies only to a tolerance")
        for n in names:
            scale = ANGLE_UNITS[au] if units[all_names.index(n)] == "rad" else LENGTH_UNITS[lu]
            items[n] = ParamUncertainty(n, raw * scale, dist)
    raw_poses = doc.get("poses")
    if raw_poses:
        try:
            poses = np.asarray(raw_poses, dtype=np.float64)
        except (ValueError, TypeError) as e:
            raise SpecError(f"poses: expected lists of {joints} numbers") from e
        if poses.ndim != 2 or poses.shape[1] != joints:
            raise SpecError(
                f"poses: each pose needs {joints} joint angles (the arm's joints)"
                + ("" if arm is not None else "; a spec of another arm? (give its model)")
            )
    else:
        poses = np.empty((0, joints))
    if pu == "deg":
        poses = np.radians(poses)
    if poses.size and (not np.all(np.isfinite(poses)) or np.max(np.abs(poses)) > 1024.0):
        raise SpecError("poses must be finite joint angles")
    return UncertaintySpec(nominal, tuple(items[n] for n in all_names), poses, model=model)


#: The name :func:`load_spec` takes for the packaged example spec.
EXAMPLE_SPEC = "example"


def load_spec(
    path: str | Path, arm: Arm | None = None, model: str | None = None
) -> UncertaintySpec:
    """Read and parse a parameter-uncertainty TOML file (see :func:`parse_spec`;
    ``arm``, ``model``: the nominal arm and its model's name, default the paper's).

    ``"example"`` (:data:`EXAMPLE_SPEC`) is the packaged example
    (``aacmm/data/example_uncertainty.toml``), as ``aacmm uncertainty example``.

    Raises SpecError if the file cannot be read, is not TOML, or is invalid
    (ArmParameterError: it names a parameter this arm does not have).
    """
    p = Path(path)
    try:  # bounded nesting: a hostile file is one clear error, not a RecursionError
        if isinstance(path, str) and path == EXAMPLE_SPEC:
            src = resources.files("aacmm").joinpath("data", "example_uncertainty.toml")
            doc = loads_toml(src.read_text(encoding="utf-8"), str(p))
        else:
            doc = load_toml(p)
    except InputFileError as e:
        raise SpecError(str(e)) from None
    try:
        return parse_spec(doc, arm, model)
    except SpecError as e:
        raise type(e)(f"{p}: {e}") from e


def pose_list(
    values: Sequence[Sequence[float]], unit: str = "deg", joints: int = JOINTS
) -> FloatArray:
    """Poses (k, N) in rad from lists of N angles in ``unit`` (deg or rad);
    N = ``joints`` (six: the paper's arm).

    Raises ValueError unless every pose has N finite angles.
    """
    try:
        a = np.asarray(values, dtype=np.float64)
    except ValueError as e:
        raise ValueError(f"each pose needs {joints} finite joint angles") from e
    if a.ndim != 2 or a.shape[1] != joints or not np.all(np.isfinite(a)):
        raise ValueError(f"each pose needs {joints} finite joint angles")
    return np.radians(a) if unit == "deg" else a
