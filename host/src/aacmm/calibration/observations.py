"""What a calibration is fitted to: probed poses and the constraints between them.

An :class:`Observations` holds a table of poses (joint readings in rad, the
probing standard uncertainty of each, and a label: the plan step and the point
index it came from) and a list of constraints on them:

* :class:`Cone` -- point constraint: every pose of the group puts the tip on
  one unknown point (a kinematic seat probed from many articulations);
* :class:`LengthSet` -- a calibrated length (ball bar, gauge) measured at one
  or more positions; each position has an end A and an end B, each the mean
  of one or more poses;
* :class:`ReferencePoints` -- poses whose tip coordinates are known from
  another instrument (laser tracker, CMM), with an unknown 6-DOF registration
  of the arm's base (or a base frame known to coincide with the instrument's);
* :class:`Sphere` -- tip centres at a known (or fitted) radius from an unknown
  centre;
* :class:`Plane` -- tip centres on an unknown plane.

Every unknown of a constraint (a seat, a sphere centre, a registration) is a
nuisance parameter: the solver eliminates it exactly, so only the arm's
parameters remain (25 for the paper's arm) (see :mod:`aacmm.calibration.problem`).

Errors: :class:`ObservationError` (a ValueError) names the constraint and
what is wrong (too few poses, NaN, an index out of range, ...).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from aacmm.arm import JOINTS_MAX, JOINTS_MIN
from aacmm.core import FloatArray
from aacmm.errmodel import TEMP_MAX_C, TEMP_MIN_C
from aacmm.errors import AacmmError

IntArray = npt.NDArray[np.intp]


class ObservationError(AacmmError, ValueError):
    """The observations cannot be analysed (bad values, too few poses, bad indices)."""


def _indices(name: str, values: npt.ArrayLike) -> IntArray:
    a = np.asarray(values)
    if a.ndim != 1:
        raise ObservationError(f"{name}: pose indices must be a flat list")
    if a.size and not np.issubdtype(a.dtype, np.integer):
        raise ObservationError(f"{name}: pose indices must be integers")
    return a.astype(np.intp)


def _finite_positive(name: str, what: str, v: float, allow_zero: bool = True) -> float:
    f = float(v)
    if math.isnan(f) or f < 0 or (f == 0 and not allow_zero):
        raise ObservationError(f"{name}: {what} must be {'>= 0' if allow_zero else '> 0'}, got {v}")
    return f


@dataclass(frozen=True)
class _PoseGroup:
    """A named group of poses (base of the single-group constraints)."""

    name: str
    poses: IntArray
    MIN_POSES: ClassVar[int] = 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", _indices(self.name, self.poses))

    @property
    def min_poses(self) -> int:
        return self.MIN_POSES


@dataclass(frozen=True)
class Cone(_PoseGroup):
    """All ``poses`` put the tip on one unknown point (3 nuisance unknowns)."""

    MIN_POSES: ClassVar[int] = 2


@dataclass(frozen=True)
class LengthSet:
    """One calibrated length measured at ``len(ends_a)`` positions.

    ``ends_a[i]`` and ``ends_b[i]`` are the poses probed at the two ends of
    position ``i``. With seats at the ends (``end_radius_mm`` None) an end is
    located by the mean of its poses' tip points; with balls at the ends it
    is the centre of the ball the tip centres lie on (radius
    ``end_radius_mm``: ball radius plus probe radius, at least 4 points an
    end). ``u_length_mm`` is the standard uncertainty of the calibrated value,
    common to all positions (0: exact; otherwise the true length is a nuisance
    unknown with that prior).
    """

    name: str
    length_mm: float
    ends_a: tuple[IntArray, ...]
    ends_b: tuple[IntArray, ...]
    u_length_mm: float = 0.0
    end_radius_mm: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.length_mm) and self.length_mm > 0):
            raise ObservationError(
                f"{self.name}: length must be finite and > 0, got {self.length_mm}"
            )
        if len(self.ends_a) != len(self.ends_b):
            raise ObservationError(f"{self.name}: every position needs an end A and an end B")
        a = tuple(_indices(self.name, e) for e in self.ends_a)
        b = tuple(_indices(self.name, e) for e in self.ends_b)
        for i, (ea, eb) in enumerate(zip(a, b, strict=True)):
            if ea.size == 0 or eb.size == 0:
                raise ObservationError(f"{self.name}: position {i + 1} has an end without points")
        object.__setattr__(self, "ends_a", a)
        object.__setattr__(self, "ends_b", b)
        u = _finite_positive(self.name, "the length uncertainty", self.u_length_mm)
        if math.isinf(u):
            raise ObservationError(f"{self.name}: the length uncertainty must be finite")
        object.__setattr__(self, "u_length_mm", u)
        if self.end_radius_mm is not None:
            r = float(self.end_radius_mm)
            if not (math.isfinite(r) and r > 0):
                raise ObservationError(f"{self.name}: the end ball radius must be > 0, got {r}")
            for i, (ea, eb) in enumerate(zip(a, b, strict=True)):
                if min(ea.size, eb.size) < 4:
                    raise ObservationError(
                        f"{self.name}: position {i + 1}: a ball end needs at least 4 points"
                    )

    @property
    def ball_ends(self) -> bool:
        """The ends are balls (probed on their surface), not seats."""
        return self.end_radius_mm is not None

    @property
    def poses(self) -> IntArray:
        return np.concatenate([*self.ends_a, *self.ends_b]) if self.ends_a else np.empty(0, np.intp)


@dataclass(frozen=True)
class ReferencePoints:
    """Poses whose tip coordinates ``xyz_mm`` (n, 3) are known in an instrument frame.

    ``u_mm``: standard uncertainty per axis of the known coordinates.
    ``base_known``: the coordinates are in the arm's base frame (no
    registration); otherwise a rigid 6-DOF registration is estimated (6
    nuisance unknowns, at least 3 points).
    """

    name: str
    poses: IntArray
    xyz_mm: FloatArray
    u_mm: float = 0.0
    base_known: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", _indices(self.name, self.poses))
        x = np.asarray(self.xyz_mm, dtype=np.float64)
        if x.shape != (self.poses.size, 3):
            raise ObservationError(
                f"{self.name}: {self.poses.size} poses need {self.poses.size} x 3 coordinates, "
                f"got shape {x.shape}"
            )
        if not np.all(np.isfinite(x)):
            raise ObservationError(f"{self.name}: reference coordinates must be finite")
        object.__setattr__(self, "xyz_mm", x)
        u = _finite_positive(self.name, "the reference uncertainty", self.u_mm)
        object.__setattr__(self, "u_mm", u)

    @property
    def min_poses(self) -> int:
        return 1 if self.base_known else 3


@dataclass(frozen=True)
class Sphere:
    """Tip centres at ``radius_mm`` from an unknown centre.

    ``radius_mm`` is the radius of the tip-centre sphere (sphere radius plus
    the probe ball's for outside probing); ``u_radius_mm`` its standard
    uncertainty (0: exact; ``inf`` or ``radius_mm=None``: fitted freely).
    """

    name: str
    poses: IntArray
    radius_mm: float | None = None
    u_radius_mm: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", _indices(self.name, self.poses))
        if self.radius_mm is not None and not (
            math.isfinite(self.radius_mm) and self.radius_mm > 0
        ):
            raise ObservationError(
                f"{self.name}: radius must be finite and > 0, got {self.radius_mm}"
            )
        u = _finite_positive(self.name, "the radius uncertainty", self.u_radius_mm)
        object.__setattr__(self, "u_radius_mm", u)

    @property
    def free_radius(self) -> bool:
        return self.radius_mm is None or math.isinf(self.u_radius_mm)

    @property
    def min_poses(self) -> int:
        return 5 if self.free_radius else 4


@dataclass(frozen=True)
class Plane(_PoseGroup):
    """Tip centres on one unknown plane (normal and offset: 3 nuisance unknowns)."""

    MIN_POSES: ClassVar[int] = 4


Constraint = Cone | LengthSet | ReferencePoints | Sphere | Plane


@dataclass(frozen=True)
class Observations:
    """Poses and constraints for a calibration.

    ``theta_rad`` (n, N): joint readings (the model adds the theta offsets), N
    the arm's joints (6 for the paper's arm; 4..7).
    ``sigma_mm`` (n,): probing standard uncertainty per axis of each pose's
    tip point. ``step`` and ``index`` (n,): where each pose came from (plan
    step number and point index within the step), for reports and outliers.
    ``step_names``: a name per step number (optional).
    ``temp_c``: the links' temperatures at each pose, degC (issue 27): (n, N), one
    per link (the device's readings), or (n,) or one value, every link at it (the
    operator's stated temperature of the pose's capture run); kept as (n, N). None:
    not stated (the error model's reference temperatures).
    """

    theta_rad: FloatArray
    sigma_mm: FloatArray
    constraints: tuple[Constraint, ...]
    step: IntArray = field(default_factory=lambda: np.empty(0, np.intp))
    index: IntArray = field(default_factory=lambda: np.empty(0, np.intp))
    step_names: tuple[str, ...] = ()
    temp_c: FloatArray | None = None

    def __post_init__(self) -> None:
        th = np.ascontiguousarray(self.theta_rad, dtype=np.float64)
        if th.ndim != 2 or not JOINTS_MIN <= th.shape[1] <= JOINTS_MAX:
            raise ObservationError(
                f"joint readings must have shape (n, N), N = {JOINTS_MIN}..{JOINTS_MAX} joints, "
                f"got {th.shape}"
            )
        n = th.shape[0]
        object.__setattr__(self, "theta_rad", th)
        object.__setattr__(self, "sigma_mm", _per_pose(self.sigma_mm, n, "sigma_mm", "value"))
        step = np.asarray(self.step, dtype=np.intp) if len(self.step) else np.zeros(n, np.intp)
        index = np.asarray(self.index, dtype=np.intp) if len(self.index) else np.arange(n)
        if step.shape != (n,) or index.shape != (n,):
            raise ObservationError("step and index need one value per pose")
        object.__setattr__(self, "step", step)
        object.__setattr__(self, "index", index)
        object.__setattr__(self, "constraints", tuple(self.constraints))
        if self.temp_c is not None:
            object.__setattr__(self, "temp_c", _link_temps(self.temp_c, n, th.shape[1]))

    @property
    def n_poses(self) -> int:
        return int(self.theta_rad.shape[0])

    @property
    def n_joints(self) -> int:
        """N, the joint readings per pose."""
        return int(self.theta_rad.shape[1])

    def label(self, pose: int) -> str:
        """``step 3 (cone-A) point 7`` for a pose index (numbers from 1, as people count;
        :attr:`step` and :attr:`index` count from 0)."""
        s = int(self.step[pose])
        name = f" ({self.step_names[s]})" if 0 <= s < len(self.step_names) else ""
        return f"step {s + 1}{name} point {int(self.index[pose]) + 1}"

    def validate(self) -> None:
        """Check everything a solve relies on; raise :class:`ObservationError` if not.

        Finite joint readings (|q| <= 1024 rad) and uncertainties (> 0) for
        every pose a constraint uses, indices in range, enough poses per
        constraint, at least one constraint.
        """
        if not self.constraints:
            raise ObservationError("no observations: nothing to calibrate against")
        n = self.n_poses
        used = np.zeros(n, dtype=bool)
        for c in self.constraints:
            idx = c.poses
            if idx.size and (idx.min() < 0 or idx.max() >= n):
                raise ObservationError(f"{c.name}: pose index out of range 0..{n - 1}")
            if isinstance(c, LengthSet):
                if not c.ends_a:
                    raise ObservationError(f"{c.name}: no positions measured")
            elif idx.size < c.min_poses:
                kind = type(c).__name__.lower()
                raise ObservationError(
                    f"{c.name}: a {kind} needs at least {c.min_poses} points, got {idx.size}"
                )
            used[idx] = True
        bad = used & ~np.all(np.isfinite(self.theta_rad), axis=1)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ObservationError(f"{self.label(i)}: joint reading is not a finite number")
        big = used & (np.abs(np.nan_to_num(self.theta_rad)).max(axis=1) > 1024.0)
        if big.any():
            i = int(np.flatnonzero(big)[0])
            raise ObservationError(f"{self.label(i)}: joint reading beyond +-1024 rad")
        sig = self.sigma_mm
        bad = used & ~(np.isfinite(sig) & (sig > 0))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ObservationError(
                f"{self.label(i)}: probing uncertainty must be finite and > 0, got {sig[i]}"
            )
        if self.temp_c is not None:
            t = self.temp_c
            good = np.isfinite(t) & (t >= TEMP_MIN_C) & (t <= TEMP_MAX_C)
            bad = used & ~good.all(axis=1)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                j = int(np.flatnonzero(~good[i])[0])
                raise ObservationError(
                    f"{self.label(i)}: link temperature must be within {TEMP_MIN_C:g} .. "
                    f"{TEMP_MAX_C:g} degC, got {t[i, j]} (link {j + 1})"
                )

    def temperature_span(self) -> float | None:
        """Highest less lowest link temperature (degC) of the poses a constraint
        uses; None without temperatures."""
        if self.temp_c is None:
            return None
        used = np.zeros(self.n_poses, dtype=bool)
        for c in self.constraints:
            used[c.poses] = True
        t = self.temp_c[used]
        return float(t.max() - t.min()) if t.size else 0.0

    def without_poses(self, drop: Sequence[int] | IntArray) -> Observations:
        """The same observations with some poses left out of every constraint.

        Constraints left with too few poses are dropped (a length position
        loses the end that lost its points).
        """
        gone = np.zeros(self.n_poses, dtype=bool)
        gone[np.asarray(drop, dtype=np.intp)] = True
        kept: list[Constraint] = []
        for c in self.constraints:
            if isinstance(c, LengthSet):
                pa, pb = [], []
                for ea, eb in zip(c.ends_a, c.ends_b, strict=True):
                    ka, kb = ea[~gone[ea]], eb[~gone[eb]]
                    if ka.size and kb.size:
                        pa.append(ka)
                        pb.append(kb)
                if pa:
                    kept.append(replace(c, ends_a=tuple(pa), ends_b=tuple(pb)))
                continue
            keep = ~gone[c.poses]
            if keep.sum() < c.min_poses:
                continue
            if isinstance(c, ReferencePoints):
                kept.append(replace(c, poses=c.poses[keep], xyz_mm=c.xyz_mm[keep]))
            else:
                kept.append(replace(c, poses=c.poses[keep]))
        return replace(self, constraints=tuple(kept))

    def subset(self, constraints: Sequence[Constraint]) -> Observations:
        """The same pose table with only ``constraints``."""
        return replace(self, constraints=tuple(constraints))


def combine(parts: Sequence[Observations]) -> Observations:
    """Several observation sets as one (poses appended, indices shifted).

    Step numbers are kept per part but offset so that they stay distinct.
    """
    if not parts:
        raise ObservationError("no observations to combine")
    stated = [p.temp_c is not None for p in parts]
    if any(stated) and not all(stated):
        raise ObservationError("link temperatures are stated for some observations, not all")
    thetas, sigmas, steps, idx, names = [], [], [], [], []
    cons: list[Constraint] = []
    off = 0
    step_off = 0
    for part in parts:
        thetas.append(part.theta_rad)
        sigmas.append(part.sigma_mm)
        steps.append(part.step + step_off)
        idx.append(part.index)
        nsteps = max(len(part.step_names), int(part.step.max()) + 1 if part.n_poses else 0)
        names += list(part.step_names) + [""] * (nsteps - len(part.step_names))
        for c in part.constraints:
            cons.append(_shift(c, off))
        off += part.n_poses
        step_off += nsteps
    return Observations(
        np.concatenate(thetas),
        np.concatenate(sigmas),
        tuple(cons),
        np.concatenate(steps),
        np.concatenate(idx),
        tuple(names),
        np.concatenate([p.temp_c for p in parts if p.temp_c is not None]) if all(stated) else None,
    )


def _shift(c: Constraint, off: int) -> Constraint:
    if isinstance(c, LengthSet):
        return replace(
            c,
            ends_a=tuple(e + off for e in c.ends_a),
            ends_b=tuple(e + off for e in c.ends_b),
        )
    return replace(c, poses=c.poses + off)


def _link_temps(value: Any, n: int, joints: int) -> FloatArray:
    """Link temperatures (n, N) from one value, one per pose (n,) or one per link of
    each pose (n, N) (ObservationError for another shape)."""
    v = np.array(value, dtype=np.float64)
    if v.ndim < 2:
        v = _per_pose(v, n, "temp_c", "link temperature")[:, None].repeat(joints, axis=1)
    if v.shape != (n, joints):
        raise ObservationError(
            f"temp_c needs a link temperature per pose ({n},) or per link of each pose "
            f"({n}, {joints}), got shape {v.shape}"
        )
    out: FloatArray = np.ascontiguousarray(v)
    return out


def _per_pose(value: Any, n: int, name: str, what: str) -> FloatArray:
    """A value per pose (n,) from one for every pose or one each (ObservationError)."""
    v = np.array(value, dtype=np.float64)
    v = np.full(n, float(v)) if v.ndim == 0 else v
    if v.shape != (n,):
        raise ObservationError(f"{name} needs one {what} per pose ({n}), got shape {v.shape}")
    out: FloatArray = v
    return out
