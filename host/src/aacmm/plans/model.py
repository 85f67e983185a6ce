"""The data model of a measurement plan (what :func:`aacmm.plans.load_plan` returns).

Every class is a frozen dataclass; lengths are mm, angles deg where named,
directions unit vectors in the arm's base frame. Uncertainties are the
*expanded* uncertainties stated on a calibration certificate, with the
artefact's coverage factor ``k`` (default 2); :meth:`Artefact.standard_uncertainty`
divides by it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

Vec3 = tuple[float, float, float]

#: Schema identifier a plan file must declare (``format = "aacmm-plan-1"``).
PLAN_FORMAT = "aacmm-plan-1"
PROCEDURES: tuple[str, ...] = ("cone", "sphere", "length", "articulation", "plane", "points")
ARTEFACT_TYPES: tuple[str, ...] = ("cone", "sphere", "ballbar", "gauge", "plane", "part")
#: Which artefact types each procedure can be run on.
PROCEDURE_ARTEFACTS: dict[str, tuple[str, ...]] = {
    "cone": ("cone",),
    "sphere": ("sphere",),
    "length": ("ballbar", "gauge"),
    "articulation": ("cone", "sphere"),
    "plane": ("plane",),
    "points": ARTEFACT_TYPES,
}
DECISION_RULES: tuple[str, ...] = ("simple", "iso14253-1")
#: Largest length, coordinate or diameter a plan may give (mm): the device's own
#: limit on a length (10 m), far beyond any arm's reach.
MAX_PLAN_MM = 10_000.0
#: Largest probe ball accepted, in a plan and by ``aacmm fit`` (mm).
MAX_PROBE_DIAMETER_MM = 100.0
#: Temperatures a plan may record for its verification (deg C): beyond any
#: arm's operating range, a typo (10^6 deg C) rather than a measurement.
TEMPERATURE_RANGE_C = (-20.0, 60.0)
#: A plan's stability band (``[verification] temperature_band_c``), degC.
TEMPERATURE_BAND_MAX_C = 20.0
ENDS: tuple[str, ...] = ("A", "B")


@dataclass(frozen=True)
class Probe:
    """The probe used for the whole plan: its ball diameter (0 = a point probe)."""

    ball_diameter_mm: float = 0.0

    @property
    def ball_radius_mm(self) -> float:
        return self.ball_diameter_mm / 2.0


@dataclass(frozen=True, kw_only=True)
class Artefact:
    """What every artefact has. ``location_mm`` is the nominal location in the arm's
    base frame (the simulator places the artefact there); analysis may use it only
    when ``location_reference`` is true (a calibrated reference, e.g. measured by a
    laser tracker, with ``location_uncertainty_mm``)."""

    id: str
    type: str
    description: str = ""
    location_mm: Vec3 | None = None
    location_reference: bool = False
    location_uncertainty_mm: float | None = None
    coverage_factor: float = 2.0

    def standard_uncertainty(self, expanded_mm: float | None) -> float | None:
        """An expanded uncertainty of this artefact divided by its coverage factor."""
        return None if expanded_mm is None else expanded_mm / self.coverage_factor


@dataclass(frozen=True, kw_only=True)
class ConeSeat(Artefact):
    """A conical (kinematic) seat. ``location_mm`` is where the probe ball centre sits
    when seated (for a point probe: the apex)."""


@dataclass(frozen=True, kw_only=True)
class Sphere(Artefact):
    """A reference sphere. ``location_mm`` is its centre; ``pole`` points away from
    its stem (the probing arrangements are laid out around it)."""

    diameter_mm: float
    diameter_uncertainty_mm: float | None = None
    form_mm: float | None = None
    pole: Vec3 = (0.0, 0.0, 1.0)

    @property
    def radius_mm(self) -> float:
        return self.diameter_mm / 2.0


@dataclass(frozen=True, kw_only=True)
class LengthStandard(Artefact):
    """A calibrated length: a ball bar (``type = "ballbar"``) or a gauge (``"gauge"``),
    between the centres of two seats (``ends = "cone"``: one point per end) or of two
    spheres (``ends = "sphere"``: several points per end, ``end_diameter_mm``). Its
    positions are given by the steps that use it."""

    length_mm: float
    length_uncertainty_mm: float | None = None
    ends: str = "cone"
    end_diameter_mm: float | None = None


@dataclass(frozen=True, kw_only=True)
class Plane(Artefact):
    """A flat surface: ``location_mm`` a point on it (the middle of the probed area),
    ``normal`` pointing out of the material, probed over ``size_mm`` (width, height)."""

    normal: Vec3 = (0.0, 0.0, 1.0)
    size_mm: tuple[float, float] = (100.0, 100.0)
    flatness_mm: float | None = None


@dataclass(frozen=True, kw_only=True)
class Part(Artefact):
    """Any object probed with free points (no geometry known to the plan)."""


@dataclass(frozen=True)
class LengthPosition:
    """One placement of a length standard: its centre and the direction from end A to B."""

    centre_mm: Vec3
    direction: Vec3
    length_mm: float

    @property
    def end_a_mm(self) -> Vec3:
        return _along(self.centre_mm, self.direction, -self.length_mm / 2.0)

    @property
    def end_b_mm(self) -> Vec3:
        return _along(self.centre_mm, self.direction, self.length_mm / 2.0)

    def end_mm(self, end: str) -> Vec3:
        return self.end_a_mm if end == "A" else self.end_b_mm


def _along(p: Vec3, d: Vec3, s: float) -> Vec3:
    return (p[0] + s * d[0], p[1] + s * d[1], p[2] + s * d[2])


@dataclass(frozen=True)
class Target:
    """Where the probe ball centre goes for one point, from the nominal geometry.

    ``tip_mm``: the ball centre (offset from the surface by the ball radius);
    ``normal``: the outward surface normal at the contact (None in a seat);
    ``feature_mm``: the centre of the feature probed (sphere, seat, bar end).
    """

    tip_mm: Vec3
    normal: Vec3 | None
    feature_mm: Vec3


class PointLabel(Protocol):
    """What analysis reads of a measured point's labels: a :class:`Slot`, or a
    session's captured point (:class:`aacmm.records.CapturedPoint`)."""

    @property
    def step_index(self) -> int: ...
    @property
    def point_index(self) -> int: ...
    @property
    def position_index(self) -> int | None: ...
    @property
    def end(self) -> str | None: ...
    @property
    def articulation_index(self) -> int | None: ...


@dataclass(frozen=True)
class Slot:
    """One point the plan asks for, in plan order. Indices count from 0.

    ``point_index`` numbers the points of the step; ``position_index`` the
    placements of a length standard; ``end`` is "A" or "B" on a length;
    ``articulation_index`` the arm articulation (cone: every point; articulation
    steps: the group of ``points_per_articulation`` points). ``target`` is None
    when the artefact has no nominal location. ``text`` is the operator's prompt.
    """

    index: int
    step_index: int
    step_id: str
    procedure: str
    artefact: str | None
    point_index: int
    position_index: int | None
    end: str | None
    articulation_index: int | None
    target: Target | None
    text: str


@dataclass(frozen=True, kw_only=True)
class Step:
    """One step of the plan: an artefact, a procedure and its point layout."""

    index: int
    id: str
    procedure: str
    artefact: str | None
    preset: str | None = None
    note: str = ""
    points: int
    articulations: int | None = None
    points_per_articulation: int | None = None
    positions: tuple[LengthPosition, ...] | None = None
    position_count: int | None = None
    points_per_end: int | None = None
    max_polar_deg: float | None = None
    targets_mm: tuple[Vec3, ...] | None = None


@dataclass(frozen=True)
class EUniMpe:
    """MPE of the length measurement error, ISO 10360 form: min(A + L/K, B),
    with A and B in mm and L/K in um for L in mm (K = 50: 20 um per metre)."""

    a_mm: float
    k: float = math.inf
    b_mm: float | None = None

    def at(self, length_mm: float) -> float:
        """The MPE (mm) for a length ``length_mm``."""
        v = self.a_mm + (length_mm / self.k) / 1000.0
        return v if self.b_mm is None else min(v, self.b_mm)


@dataclass(frozen=True)
class Mpe:
    """Maximum permissible errors (mm) the verification compares with; all optional."""

    p_size_mm: float | None = None
    p_form_mm: float | None = None
    l_dia_mm: float | None = None
    e_uni: EUniMpe | None = None
    effective_diameter_mm: float | None = None
    spat_2sigma_mm: float | None = None
    spat_range_mm: float | None = None
    volumetric_mm: float | None = None

    def any(self) -> bool:
        return any(getattr(self, f) is not None for f in self.__dataclass_fields__)


@dataclass(frozen=True)
class Verification:
    """How results are judged: ``decision_rule`` "simple" (result <= MPE) or
    "iso14253-1" (conformance zone = MPE reduced by the expanded uncertainty);
    ``temperature_c``: the temperature of the test; ``temperature_band_c``: the
    stability band the links' temperature must stay within during the session
    (the span of every temperature stated, and each one's distance from
    ``temperature_c`` when the plan gives it; degC, e.g. 3: an arm maker's
    "within 3 degC for 5 minutes before measuring")."""

    decision_rule: str = "simple"
    temperature_c: float | None = None
    temperature_band_c: float | None = None

    def band_problem(self, temps_c: Sequence[float]) -> str | None:
        """Why the link temperatures ``temps_c`` (degC, every one stated for the
        session) break the stability band, or None (within it, or no band)."""
        band = self.temperature_band_c
        if band is None or not temps_c:
            return None
        lo, hi = min(temps_c), max(temps_c)
        if hi - lo > band:
            return (
                f"the links' temperature spans {lo:g} .. {hi:g} C, more than the plan's "
                f"{band:g} C stability band"
            )
        ref = self.temperature_c
        if ref is not None:
            far = max(temps_c, key=lambda t: abs(t - ref))
            if abs(far - ref) > band:
                return (
                    f"the links' temperature {far:g} C is {abs(far - ref):g} C from the plan's "
                    f"{ref:g} C, outside its {band:g} C stability band"
                )
        return None


@dataclass(frozen=True)
class Plan:
    """A loaded, validated plan. :attr:`slots` lists every point in plan order."""

    name: str
    source: str
    sha256: str
    title: str
    description: str
    probe: Probe
    artefacts: dict[str, Artefact]
    steps: tuple[Step, ...]
    slots: tuple[Slot, ...]
    mpe: Mpe = field(default_factory=Mpe)
    verification: Verification = field(default_factory=Verification)
    path: Path | None = None

    @property
    def format(self) -> str:
        return PLAN_FORMAT

    def step(self, key: int | str) -> Step:
        """A step by index or id. Raises KeyError."""
        if isinstance(key, int):
            return self.steps[key]
        for s in self.steps:
            if s.id == key:
                return s
        raise KeyError(key)

    def artefact_of(self, step: Step) -> Artefact | None:
        return None if step.artefact is None else self.artefacts[step.artefact]

    def step_slots(self, step: int | str) -> tuple[Slot, ...]:
        """The slots of one step."""
        i = self.step(step).index
        return tuple(s for s in self.slots if s.step_index == i)

    def summary(self) -> dict[str, Any]:
        """Steps, artefacts and point counts, as JSON-ready data."""
        return {
            "name": self.name,
            "title": self.title,
            "sha256": self.sha256,
            "points": len(self.slots),
            "steps": [
                {
                    "index": s.index,
                    "id": s.id,
                    "procedure": s.procedure,
                    "artefact": s.artefact,
                    "points": s.points,
                }
                for s in self.steps
            ],
        }
