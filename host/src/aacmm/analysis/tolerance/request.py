"""The tolerance-allocation request: target, cost model, workspace, encoders, calibration.

The dataclasses :func:`aacmm.analysis.tolerance.spec.parse_spec` builds from
a spec file, each checking its own values (ValueError), and
:class:`SpecError`. Angles are in rad and lengths in mm here, as everywhere
in aacmm; a parameter's tolerance ``t`` is in its ``unit`` (``scale`` rad or
mm per unit). Public through :mod:`aacmm.analysis.tolerance`.

Any arm (issue 26): the nominal arm is the paper's (:class:`aacmm.core.Params`,
the default) or any :class:`aacmm.arm.Arm` (an arm model's); the costs list
its P parameters (:attr:`ToleranceSpec.param_names`), the workspace poses and
the encoders its N joints (:attr:`Workspace.joints`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Literal

import numpy as np

from aacmm.arm import JOINTS_MAX, Arm
from aacmm.core import JOINTS, PARAM_NAMES, FloatArray, Params
from aacmm.uncertainty.spec import (
    ANGLE_UNITS,
    DISTRIBUTIONS,
    LENGTH_UNITS,
    TOLERANCE_FACTOR,
    is_param_name,
)

if TYPE_CHECKING:
    from aacmm.simulation.ik import JointLimits

ARCSEC_RAD = ANGLE_UNITS["arcsec"]
DEFAULT_RANDOM_POSES = 200
DEFAULT_MIN_LENGTH_MM = 100.0
MAX_POSES = 20_000


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
        if not is_param_name(self.name):
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
    count). ``joints`` lists the joints (1..N) it fits (default: 1..6, the
    paper's arm; :meth:`for_joints` the same entry for every joint of an arm).
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
        if not self.joints or any(j not in range(1, JOINTS_MAX + 1) for j in self.joints):
            raise ValueError(f"joints must be a non-empty list of 1..{JOINTS_MAX}")
        if self.distribution not in DISTRIBUTIONS or self.distribution == "normal":
            raise ValueError("distribution must be uniform, triangular or arcsine")

    def for_joints(self, joints: int) -> Encoder:
        """The same entry, fitting joints 1..``joints`` (an arm's every joint)."""
        return replace(self, joints=tuple(range(1, joints + 1)))

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
    """The poses the target applies to (rad, (n, N)): given, from a log, random.

    ``joints``: N, the arm's joints (six: the paper's arm); ``joint_range_rad``
    (N, 2), default every joint in [-pi, pi).
    """

    given: FloatArray = field(default_factory=lambda: np.empty((0, JOINTS)))
    logged: FloatArray = field(default_factory=lambda: np.empty((0, JOINTS)))
    random: int = DEFAULT_RANDOM_POSES
    seed: int = 1
    joint_range_rad: FloatArray | None = None
    log_path: str | None = None
    joints: int = JOINTS

    def __post_init__(self) -> None:
        n = self.joints
        for name in ("given", "logged"):
            a = np.asarray(getattr(self, name), dtype=np.float64)
            a = np.empty((0, n)) if a.size == 0 else a
            if a.ndim != 2 or a.shape[1] != n:
                raise ValueError(f"{name} poses need {n} joint angles each (the arm's joints)")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{name} poses must be finite")
            object.__setattr__(self, name, a)
        r = np.asarray(
            np.tile([-math.pi, math.pi], (n, 1))
            if self.joint_range_rad is None
            else self.joint_range_rad,
            dtype=np.float64,
        )
        if r.shape != (n, 2) or not np.all(np.isfinite(r)) or np.any(r[:, 1] <= r[:, 0]):
            raise ValueError(f"joint ranges need {n} pairs [low, high] with low < high")
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

    @property
    def ranges_rad(self) -> FloatArray:
        """The joint ranges (N, 2) in rad (set by the constructor)."""
        assert self.joint_range_rad is not None
        return self.joint_range_rad

    def poses(self) -> FloatArray:
        """All poses (n, N) in rad: given, then logged, then random (seeded)."""
        rng = np.random.default_rng(self.seed)
        lo, hi = self.ranges_rad[:, 0], self.ranges_rad[:, 1]
        rand = lo + (hi - lo) * rng.random((self.random, self.joints))
        return np.concatenate([self.given, self.logged, rand])

    def describe(self) -> str:
        parts = []
        if self.given.shape[0]:
            parts.append(f"{self.given.shape[0]} given")
        if self.logged.shape[0]:
            parts.append(f"{self.logged.shape[0]} from {self.log_path}")
        if self.random:
            rng = self.ranges_rad
            full = np.allclose(rng, np.tile([-math.pi, math.pi], (self.joints, 1)))
            how = (
                "joints uniform in [-180, 180) deg"
                if full
                else "joints uniform in "
                + ", ".join(f"[{lo:g}, {hi:g})" for lo, hi in np.degrees(rng))
                + " deg"
            )
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
    """A whole allocation request (see docs/tolerance.md).

    ``params``: the nominal arm, the paper's (:class:`Params`, default) or any
    :class:`aacmm.arm.Arm`; ``model``: its arm model's name for reports (None:
    the paper's arm, or an arm made in code); ``joint_limits_rad``: the arm's
    joint limits (N pairs, ``(-inf, inf)`` for none; an arm model's), where the
    simulated operator of a calibrated allocation (``calibration``) keeps the
    arm: needed for an arm other than the paper's (None: the paper's arm's,
    :data:`aacmm.simulation.ik.ARM_LIMITS`).
    """

    costs: tuple[ParamCost, ...]
    target: Target = field(default_factory=Target)
    workspace: Workspace = field(default_factory=Workspace)
    encoders: tuple[Encoder, ...] = ()
    params: Params | Arm = field(default_factory=Params)
    residual_u_mm: float = 0.0
    angle_unit: str = "arcsec"
    length_unit: str = "um"
    calibration: CalibrationDesign | None = None
    source: str = "<spec>"
    model: str | None = None
    joint_limits_rad: tuple[tuple[float, float], ...] | None = None

    def __post_init__(self) -> None:
        names = self.param_names
        if tuple(c.name for c in self.costs) != names:
            raise ValueError(
                f"costs must list the arm's {len(names)} parameters in column order "
                f"({names[0]} .. {names[-1]})"
            )
        if not (math.isfinite(self.residual_u_mm) and self.residual_u_mm >= 0):
            raise ValueError(f"residual u must be >= 0, got {self.residual_u_mm}")
        n = self.joints
        if self.workspace.joints != n:
            raise ValueError(
                f"the workspace has poses of {self.workspace.joints} joints, the arm {n}"
            )
        if self.encoders:
            for e in self.encoders:
                if max(e.joints) > n:
                    raise ValueError(
                        f"encoder {e.name!r} fits joint {max(e.joints)}: the arm has {n} joints"
                    )
            for j in range(1, n + 1):
                if not any(j in e.joints for e in self.encoders):
                    raise ValueError(f"no encoder in the catalogue fits joint {j}")
        if self.joint_limits_rad is not None and len(self.joint_limits_rad) != n:
            raise ValueError(f"{len(self.joint_limits_rad)} joint limits for an arm of {n} joints")
        if (
            self.calibration is not None
            and not isinstance(self.params, Params)
            and self.joint_limits_rad is None
        ):
            raise ValueError(
                "[calibration]: a calibrated allocation of an arm other than the paper's "
                "needs its joint limits (an arm model's: --model)"
            )

    def operator_limits(self) -> JointLimits | None:
        """The simulated operator's joint limits for a calibration plan: the arm's
        (``joint_limits_rad``), or None (the paper's arm's default)."""
        from aacmm.simulation.ik import JointLimits

        if self.joint_limits_rad is None:
            return None
        return JointLimits.from_ranges(self.joint_limits_rad)

    @property
    def arm(self) -> Arm:
        """The nominal arm as an :class:`aacmm.arm.Arm`."""
        return self.params.to_arm() if isinstance(self.params, Params) else self.params

    @property
    def param_names(self) -> tuple[str, ...]:
        """The arm's P parameter names in column order (paper: :data:`PARAM_NAMES`)."""
        return PARAM_NAMES if isinstance(self.params, Params) else self.params.param_names

    @property
    def joints(self) -> int:
        """N, the arm's joints."""
        return JOINTS if isinstance(self.params, Params) else self.params.n_joints

    @property
    def length_scale(self) -> float:
        """mm per ``length_unit``."""
        return LENGTH_UNITS[self.length_unit]
