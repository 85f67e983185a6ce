"""The simulated arm's thermal expansion: a temperature profile of its links (issue 27).

A true arm's links grow with temperature: every length of link i (``d_i``,
``a_i``; the tip belongs to the last link) is ``L0 (1 + cte_i (T_i -
tref_i))``, the C core's thermal model (docs/kinematics.md, "Error model").
A :class:`ThermalProfile` is the truth of it: per link a material, its true
coefficient of thermal expansion (1/K) and the reference temperature at which
the truth's lengths hold (20 degC). :func:`true_points` gives the true probe
point of a :class:`~aacmm.simulation.truth.Truth` at link temperatures, and
:func:`params_at` its arm with the lengths at them (what the simulated
operator solves its poses on: ``aacmm sim --truth ... --temperature C``, the
device told the same temperatures over the control channel).

Materials (:data:`MATERIALS`, docs/simulator.md "Thermal expansion"): the
nominal CTE and the range a random profile draws from, uniform:

============  ===============  =====================
material      nominal (1/K)    random range (1/K)
============  ===============  =====================
aluminium     23e-6            22e-6 .. 24e-6
carbon-fibre  0.5e-6           0 .. 1e-6
steel         11.5e-6          10.5e-6 .. 12.5e-6
============  ===============  =====================

:func:`default_materials`: a link with a length over 400 mm is a
carbon-fibre tube (the paper's arm: links 3 and 5, the upper arm and the
forearm), every other link aluminium. :func:`random_profile` draws a profile,
:func:`profile_from_table` reads a truth file's ``[thermal]`` table.

Pure: no printing, no files.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Final

import numpy as np
import numpy.typing as npt

from aacmm.arm import Arm
from aacmm.core import Params
from aacmm.errmodel import ErrorModel, points

if TYPE_CHECKING:
    from aacmm.simulation.truth import Truth


@dataclass(frozen=True)
class Material:
    """A link material: nominal CTE and the uniform range of a random one (1/K)."""

    name: str
    cte_per_k: float
    cte_range_per_k: tuple[float, float]


#: The materials of a link (module doc).
MATERIALS: Final[dict[str, Material]] = {
    m.name: m
    for m in (
        Material("aluminium", 23e-6, (22e-6, 24e-6)),
        Material("carbon-fibre", 0.5e-6, (0.0, 1e-6)),
        Material("steel", 11.5e-6, (10.5e-6, 12.5e-6)),
    )
}
#: A link longer than this (its largest |d|, |a| or tip length, mm) is a carbon-fibre tube.
TUBE_MIN_MM: Final = 400.0
#: The reference temperature of a truth's lengths (degC).
TREF_C: Final = 20.0
CTE_MAX_PER_K: Final = 1e-3  # the core's bound (aacmm.errmodel.CTE_MAX_PER_K)


@dataclass(frozen=True)
class ThermalProfile:
    """Per link (one per joint; the tip is the last link's): its material name,
    true CTE (1/K, ``|cte| <= 1e-3``) and reference temperature (degC, -40..85).
    Raises ValueError for a malformed profile."""

    material: tuple[str, ...]
    cte_per_k: tuple[float, ...]
    tref_c: tuple[float, ...]

    def __post_init__(self) -> None:
        n = len(self.material)
        if not 1 <= n <= 7 or len(self.cte_per_k) != n or len(self.tref_c) != n:
            raise ValueError("a thermal profile needs one material, CTE and tref per link")
        for i, (m, a, t) in enumerate(zip(self.material, self.cte_per_k, self.tref_c, strict=True)):
            if not isinstance(m, str) or not m:
                raise ValueError(f"link {i + 1}: the material must be a name")
            if not (math.isfinite(a) and abs(a) <= CTE_MAX_PER_K):
                raise ValueError(f"link {i + 1}: cte must be finite, within +-{CTE_MAX_PER_K:g}/K")
            if not (math.isfinite(t) and -40.0 <= t <= 85.0):
                raise ValueError(f"link {i + 1}: tref must be within -40 .. 85 degC")
        object.__setattr__(self, "material", tuple(self.material))
        object.__setattr__(self, "cte_per_k", tuple(float(x) for x in self.cte_per_k))
        object.__setattr__(self, "tref_c", tuple(float(x) for x in self.tref_c))

    @property
    def links(self) -> int:
        """N, the number of links."""
        return len(self.material)


def _link_lengths_mm(params: Params | Arm) -> list[float]:
    arm = params.to_arm() if isinstance(params, Params) else params
    n = arm.n_joints
    out = [max(abs(arm.joints[i].d_mm), abs(arm.joints[i].a_mm)) for i in range(n)]
    out[-1] = max(out[-1], *(abs(v) for v in arm.tip_mm))
    return out


def default_materials(params: Params | Arm) -> tuple[str, ...]:
    """Each link's material: carbon-fibre for a link longer than
    :data:`TUBE_MIN_MM`, aluminium otherwise (module doc)."""
    return tuple(
        "carbon-fibre" if length > TUBE_MIN_MM else "aluminium"
        for length in _link_lengths_mm(params)
    )


def nominal_profile(materials: tuple[str, ...]) -> ThermalProfile:
    """Every link at its material's nominal CTE, reference 20 degC.

    Raises:
        ValueError: an unknown material.
    """
    return ThermalProfile(
        materials, tuple(_material(m).cte_per_k for m in materials), (TREF_C,) * len(materials)
    )


def random_profile(rng: np.random.Generator, materials: tuple[str, ...]) -> ThermalProfile:
    """Each link's CTE uniform in its material's range (one draw per link, in
    order), reference 20 degC.

    Raises:
        ValueError: an unknown material.
    """
    cte = []
    for m in materials:
        lo, hi = _material(m).cte_range_per_k
        cte.append(float(rng.uniform(lo, hi)))
    return ThermalProfile(materials, tuple(cte), (TREF_C,) * len(materials))


def _material(name: str) -> Material:
    try:
        return MATERIALS[name]
    except KeyError:
        known = ", ".join(MATERIALS)
        raise ValueError(f"unknown link material {name!r} (known: {known})") from None


def profile_from_table(table: dict[str, Any], n: int) -> ThermalProfile:
    """A truth file's ``[thermal]`` table: ``material``, ``cte_per_k`` (1/K) and
    ``tref_c`` (degC), ``n`` values each.

    Raises:
        ValueError: a malformed table (the message names the key).
    """
    material = table.get("material")
    if not (
        isinstance(material, list)
        and len(material) == n
        and all(isinstance(m, str) and m for m in material)
    ):
        raise ValueError(f"thermal.material must be a list of {n} names")
    values = {}
    for key in ("cte_per_k", "tref_c"):
        row = table.get(key)
        if not (
            isinstance(row, list)
            and len(row) == n
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in row)
        ):
            raise ValueError(f"thermal.{key} must be a list of {n} numbers")
        values[key] = tuple(float(v) for v in row)
    try:
        return ThermalProfile(tuple(material), values["cte_per_k"], values["tref_c"])
    except ValueError as exc:
        raise ValueError(f"thermal: {exc}") from None


def params_at(
    params: Params | Arm, profile: ThermalProfile | None, temp_c: Sequence[float]
) -> Params | Arm:
    """``params`` (a truth's, at its reference temperatures) with every length of link
    i scaled by ``1 + cte_i (T_i - tref_i)`` at the link temperatures ``temp_c`` (degC,
    one per link): ``d_i`` and ``a_i``, the tip (``l`` or the tip vector) with the
    last link. Without a profile the lengths are those of every temperature.

    Raises:
        ValueError: not one temperature per link, or one outside -40 .. 85 degC.
    """
    if profile is None:
        return params
    temps = [float(t) for t in temp_c]
    if len(temps) != profile.links:
        raise ValueError(f"need {profile.links} link temperatures, got {len(temps)}")
    if not all(math.isfinite(t) and -40.0 <= t <= 85.0 for t in temps):
        raise ValueError("link temperatures must be within -40 .. 85 degC")
    k = [
        1.0 + a * (t - r) for a, t, r in zip(profile.cte_per_k, temps, profile.tref_c, strict=True)
    ]
    if isinstance(params, Params):
        return Params(
            params.theta_offset_rad,
            params.alpha_rad,
            tuple(d * s for d, s in zip(params.d_mm, k, strict=True)),
            tuple(a * s for a, s in zip(params.a_mm, k, strict=True)),
            params.l_mm * k[-1],
        )
    joints = tuple(
        replace(j, d_mm=j.d_mm * s, a_mm=j.a_mm * s) for j, s in zip(params.joints, k, strict=True)
    )
    tip = (params.tip_mm[0] * k[-1], params.tip_mm[1] * k[-1], params.tip_mm[2] * k[-1])
    return replace(params, joints=joints, tip_mm=tip)


def true_points(
    truth: Truth[Any], theta_rad: npt.ArrayLike, temp_c: npt.ArrayLike | None = None
) -> npt.NDArray[np.float64]:
    """The true probe points (n, 3) in mm of ``truth`` at true joint angles
    ``theta_rad`` (n, N; as :meth:`~aacmm.simulation.truth.Truth.counts` takes
    them) and link temperatures ``temp_c`` (degC: None, the reference; one set
    (N,) for every pose; or one per pose (n, N)): every length of link i scaled
    by ``1 + cte_i (T_i - tref_i)`` of its thermal profile (the C core's error
    model, docs/kinematics.md); a truth without a profile is the same at every
    temperature.

    Raises:
        KinematicsError: a bad pose or a temperature outside -40 .. 85 degC.
    """
    model = truth.model()
    if truth.thermal is None or temp_c is None:
        out: npt.NDArray[np.float64] = model.points(theta_rad)
        return out
    em = ErrorModel(
        harmonics=((),) * truth.joints,
        cte_per_k=truth.thermal.cte_per_k,
        tref_c=truth.thermal.tref_c,
    )
    hot: npt.NDArray[np.float64] = points(model, em, theta_rad, temp_c)
    return hot
