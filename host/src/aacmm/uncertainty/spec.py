"""Parameter-uncertainty specifications for :mod:`aacmm.uncertainty`.

A spec is the nominal arm, one standard uncertainty and distribution per
structural parameter (or a full 25 x 25 covariance of correlated normal
parameters, as a calibration gives) and, optionally, poses.
:func:`load_spec` reads the TOML format (docs/montecarlo.md; ``"example"``
is the packaged example), :func:`parse_spec` a parsed document.

Errors: :class:`SpecError` (a ValueError) for unknown parameter names,
negative or non-finite uncertainties, unknown distributions or units, bad
poses, unreadable or invalid files.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from aacmm.core import JAC_COLS, JOINTS, PARAM_GROUPS, PARAM_NAMES, PARAM_UNITS, FloatArray, Params
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


@dataclass(frozen=True)
class ParamUncertainty:
    """Standard uncertainty ``u`` (rad or mm) of one parameter and its distribution."""

    name: str
    u: float
    distribution: str = "normal"

    def __post_init__(self) -> None:
        if self.name not in PARAM_NAMES:
            raise ValueError(
                f"unknown parameter name {self.name!r} "
                f"(expected theta1..6, alpha1..6, d1..6, a1..6 or l)"
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
    """Nominal arm, one :class:`ParamUncertainty` per parameter (25), and poses (k, 6) rad.

    ``covariance`` (25, 25; rad, mm), optional: correlated normal parameters
    (a calibration's result, :meth:`from_covariance`) instead of independent
    ones; the items then carry the standard uncertainties sqrt(diag).
    """

    params: Params
    items: tuple[ParamUncertainty, ...]
    poses_rad: FloatArray = field(default_factory=lambda: np.empty((0, JOINTS)))
    covariance: FloatArray | None = None

    def __post_init__(self) -> None:
        if tuple(i.name for i in self.items) != PARAM_NAMES:
            raise ValueError("items must list the 25 parameters in PARAM_NAMES order")
        p = np.asarray(self.poses_rad, dtype=np.float64).reshape(-1, JOINTS)
        object.__setattr__(self, "poses_rad", p)
        if self.covariance is not None:
            c = np.asarray(self.covariance, dtype=np.float64)
            if c.shape != (JAC_COLS, JAC_COLS) or not np.all(np.isfinite(c)):
                raise ValueError("covariance must be a finite 25 x 25 matrix")
            if not np.allclose(c, c.T, rtol=1e-9, atol=1e-300):
                raise ValueError("covariance must be symmetric")
            if np.linalg.eigvalsh(c)[0] < -1e-9 * max(float(np.abs(c).max()), 1e-300):
                raise ValueError("covariance must be positive semi-definite")
            object.__setattr__(self, "covariance", c)

    @classmethod
    def from_covariance(
        cls, covariance: FloatArray, params: Params, poses_rad: FloatArray | None = None
    ) -> UncertaintySpec:
        """Spec of correlated normal parameters with covariance (25, 25) about ``params``."""
        u = np.sqrt(np.clip(np.diag(np.asarray(covariance, dtype=np.float64)), 0.0, None))
        return cls(
            params,
            tuple(ParamUncertainty(n, float(u[k])) for k, n in enumerate(PARAM_NAMES)),
            np.empty((0, JOINTS)) if poses_rad is None else poses_rad,
            covariance,
        )

    def covariance_matrix(self) -> FloatArray:
        """The (25, 25) covariance: the given one, or diag(u^2) for independent parameters."""
        if self.covariance is not None:
            return self.covariance
        return np.diag(self.u_vector() ** 2)

    @classmethod
    def from_u(
        cls, u: Mapping[str, float], params: Params | None = None, distribution: str = "normal"
    ) -> UncertaintySpec:
        """Spec from {name: u}, names as :data:`PARAM_NAMES` or groups (theta, alpha, d, a)."""
        vals = {n: 0.0 for n in PARAM_NAMES}
        for k, v in u.items():
            for n in expand_name(k):
                vals[n] = float(v)
        return cls(
            params or Params(),
            tuple(ParamUncertainty(n, vals[n], distribution) for n in PARAM_NAMES),
        )

    def u_vector(self) -> FloatArray:
        """Standard uncertainties (25,) in Jacobian column order (rad, mm)."""
        return np.array([i.u for i in self.items], dtype=np.float64)


def expand_name(name: str) -> tuple[str, ...]:
    """The parameters a name stands for: itself (``d3``) or a group (``d``: d1..d6).

    Raises ValueError for an unknown name.
    """
    if name in PARAM_NAMES:
        return (name,)
    if name in PARAM_GROUPS[:4]:
        return tuple(f"{name}{i}" for i in range(1, JOINTS + 1))
    raise ValueError(
        f"unknown parameter name {name!r} (expected theta1..6, alpha1..6, d1..6, "
        f"a1..6, l, or a group theta, alpha, d, a)"
    )


_TOP_KEYS = {"angle_unit", "length_unit", "pose_unit", "nominal", "parameters", "poses"}
_ENTRY_KEYS = {"u", "tolerance", "distribution", "k"}


def parse_spec(doc: Mapping[str, Any]) -> UncertaintySpec:
    """Build a spec from a parsed TOML document.

    Keys: ``angle_unit`` (rad, mrad, urad, deg, arcmin, arcsec; default rad)
    and ``length_unit`` (mm, um; default mm) for the uncertainties;
    ``pose_unit`` (rad or deg; default deg) for ``poses``, a list of
    six-angle lists; ``[nominal]`` with :class:`aacmm.core.Params` fields
    (default: paper Table 1); ``[parameters]`` with one table per parameter
    or group: ``{u = ..., distribution = ...}`` (standard uncertainty) or
    ``{tolerance = ..., distribution = ..., k = ...}`` (half-width;
    u = a/sqrt(3) uniform, a/sqrt(6) triangular, a/sqrt(2) arcsine, a/k
    normal with k = 2 by default). A joint entry (``d3``) overrides its group
    (``d``) whatever the order.

    Raises SpecError for anything else.
    """
    try:
        return _parse(doc)
    except SpecError:
        raise
    except (ValueError, TypeError, KeyError) as e:
        raise SpecError(str(e)) from e


def _parse(doc: Mapping[str, Any]) -> UncertaintySpec:
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
    nominal = Params(**doc.get("nominal", {}))
    nominal.validate()
    entries = doc.get("parameters", {})
    if not isinstance(entries, Mapping) or not entries:
        raise SpecError("no [parameters] table: give at least one parameter uncertainty")
    # groups first, then single parameters, so a joint entry overrides its group
    ordered = sorted(entries.items(), key=lambda kv: kv[0] in PARAM_NAMES)
    items: dict[str, ParamUncertainty] = {n: ParamUncertainty(n, 0.0) for n in PARAM_NAMES}
    for key, entry in ordered:
        names = expand_name(str(key))
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
            scale = (
                ANGLE_UNITS[au] if PARAM_UNITS[PARAM_NAMES.index(n)] == "rad" else LENGTH_UNITS[lu]
            )
            items[n] = ParamUncertainty(n, raw * scale, dist)
    poses = (
        np.asarray(doc.get("poses", []), dtype=np.float64).reshape(-1, JOINTS)
        if doc.get("poses")
        else np.empty((0, JOINTS))
    )
    if pu == "deg":
        poses = np.radians(poses)
    if poses.size and (not np.all(np.isfinite(poses)) or np.max(np.abs(poses)) > 1024.0):
        raise SpecError("poses must be finite joint angles")
    return UncertaintySpec(nominal, tuple(items[n] for n in PARAM_NAMES), poses)


#: The name :func:`load_spec` takes for the packaged example spec.
EXAMPLE_SPEC = "example"


def load_spec(path: str | Path) -> UncertaintySpec:
    """Read and parse a parameter-uncertainty TOML file (see :func:`parse_spec`).

    ``"example"`` (:data:`EXAMPLE_SPEC`) is the packaged example
    (``aacmm/data/example_uncertainty.toml``), as ``aacmm uncertainty example``.

    Raises SpecError if the file cannot be read, is not TOML, or is invalid.
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
        return parse_spec(doc)
    except SpecError as e:
        raise SpecError(f"{p}: {e}") from e


def pose_list(values: Sequence[Sequence[float]], unit: str = "deg") -> FloatArray:
    """Poses (k, 6) in rad from lists of six angles in ``unit`` (deg or rad).

    Raises ValueError unless every pose has six finite angles.
    """
    a = np.asarray(values, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != JOINTS or not np.all(np.isfinite(a)):
        raise ValueError(f"each pose needs {JOINTS} finite joint angles")
    return np.radians(a) if unit == "deg" else a
