"""Random poses for the Monte Carlo study: joint distributions and reproducible per-chunk draws.

Poses are drawn in chunks of :data:`CHUNK`, each from its own random stream
(``SeedSequence(seed, spawn_key=(run, chunk))``), so the poses depend on the
seed only, never on the number of threads. Used by :mod:`aacmm.analysis.mc`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from aacmm.core import JOINT_ANGLE_MAX_RAD, JOINTS, FloatArray

#: Poses per random stream and per C call: the unit of work of a thread.
CHUNK = 16384


@dataclass(frozen=True)
class JointDistribution:
    """Distribution of one joint angle (rad).

    ``kind`` "uniform": ``a`` = low, ``b`` = high, drawn in [low, high).
    ``kind`` "normal": ``a`` = mean, ``b`` = standard deviation.
    Raises ValueError for an unknown kind, non-finite values, low >= high,
    a negative deviation, or a range the core cannot take (|angle| > 1024 rad,
    for the normal case within 10 standard deviations).
    """

    kind: Literal["uniform", "normal"] = "uniform"
    a: float = -math.pi
    b: float = math.pi

    def __post_init__(self) -> None:
        if self.kind not in ("uniform", "normal"):
            raise ValueError(f"unknown joint distribution {self.kind!r} (uniform or normal)")
        if not (math.isfinite(self.a) and math.isfinite(self.b)):
            raise ValueError("joint distribution bounds must be finite")
        if self.kind == "uniform":
            if not self.a < self.b:
                raise ValueError(f"uniform joint range needs low < high, got [{self.a}, {self.b})")
            if max(abs(self.a), abs(self.b)) > JOINT_ANGLE_MAX_RAD:
                raise ValueError(f"joint range beyond +-{JOINT_ANGLE_MAX_RAD} rad")
        else:
            if self.b < 0:
                raise ValueError(f"normal joint standard deviation must be >= 0, got {self.b}")
            if abs(self.a) + 10.0 * self.b > JOINT_ANGLE_MAX_RAD:
                raise ValueError(
                    f"normal joint distribution reaches beyond +-{JOINT_ANGLE_MAX_RAD} rad"
                )

    @classmethod
    def uniform(cls, low: float, high: float) -> JointDistribution:
        """Uniform in [low, high) rad."""
        return cls("uniform", float(low), float(high))

    @classmethod
    def normal(cls, mean: float, sd: float) -> JointDistribution:
        """Normal with mean and standard deviation in rad."""
        return cls("normal", float(mean), float(sd))

    def describe(self) -> str:
        """Human-readable form in degrees."""
        if self.kind == "uniform":
            return f"uniform[{math.degrees(self.a):g}, {math.degrees(self.b):g}) deg"
        return f"normal({math.degrees(self.a):g}, {math.degrees(self.b):g}) deg"


DEFAULT_JOINTS: tuple[JointDistribution, ...] = (JointDistribution(),) * JOINTS


def joint_distributions(
    joints: Sequence[JointDistribution] | None, count: int = JOINTS
) -> tuple[JointDistribution, ...]:
    """``count`` joint distributions (six: the paper's arm), checked (``None``: all
    uniform in [-pi, pi)); ValueError if not."""
    if joints is None:
        return DEFAULT_JOINTS if count == JOINTS else (JointDistribution(),) * count
    out = tuple(joints)
    if len(out) != count or not all(isinstance(j, JointDistribution) for j in out):
        raise ValueError(f"need {count} JointDistribution values, got {len(out)}")
    return out


def limit_distributions(
    ranges_rad: Sequence[tuple[float, float]],
) -> tuple[JointDistribution, ...]:
    """One uniform distribution per joint in [lowest, highest) rad: random poses within
    an arm's joint limits (an arm model's ``sampling_ranges_rad()``); ValueError if a
    range is not finite or low >= high."""
    return tuple(JointDistribution.uniform(lo, hi) for lo, hi in ranges_rad)


def seed_entropy(seed: int | None) -> int:
    """The seed as entropy (``None``: a fresh one); ValueError unless a non-negative integer."""
    if seed is None:
        e = np.random.SeedSequence().entropy
        assert isinstance(e, int)
        return e
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


#: A chunk of poses as drawn: (poses, None, None), or for all-uniform joints
#: (unit deviates, scale, offset) with poses = unit * scale + offset.
DrawnChunk = tuple[FloatArray, FloatArray | None, FloatArray | None]


def draw_deviates(
    entropy: int, run: int, chunk: int, n: int, joints: Sequence[JointDistribution]
) -> DrawnChunk:
    """One chunk as drawn, all-uniform joints left as unit deviates (see :data:`DrawnChunk`)."""
    rng = np.random.Generator(
        np.random.PCG64(np.random.SeedSequence(entropy, spawn_key=(run, chunk)))
    )
    if all(j.kind == "uniform" for j in joints):  # fast path: deviates, scaled later
        u = np.empty((n, len(joints)), dtype=np.float64)
        rng.random(out=u)
        return u, np.array([j.b - j.a for j in joints]), np.array([j.a for j in joints])
    out = np.empty((n, len(joints)), dtype=np.float64)
    uni = [i for i, j in enumerate(joints) if j.kind == "uniform"]
    nor = [i for i, j in enumerate(joints) if j.kind == "normal"]
    if uni:
        lo = np.array([joints[i].a for i in uni])
        w = np.array([joints[i].b - joints[i].a for i in uni])
        u = rng.random((n, len(uni)))
        u *= w
        u += lo
        out[:, uni] = u
    if nor:
        mu = np.array([joints[i].a for i in nor])
        sd = np.array([joints[i].b for i in nor])
        out[:, nor] = mu + sd * rng.standard_normal((n, len(nor)))
    return out, None, None


def draw_chunk(
    entropy: int, run: int, chunk: int, n: int, joints: Sequence[JointDistribution]
) -> FloatArray:
    """The poses (n, N) of one chunk (N = ``len(joints)``): a pure function of its arguments."""
    th, scale, offset = draw_deviates(entropy, run, chunk, n, joints)
    if scale is not None and offset is not None:
        th *= scale
        th += offset
    return th


def draw_poses(
    n: int,
    joints: Sequence[JointDistribution] | None = None,
    seed: int = 0,
    run: int = 0,
    count: int = JOINTS,
) -> FloatArray:
    """The n poses (n, N) that a Monte Carlo run with this seed uses (rad); N =
    ``count`` joints (six: the paper's arm).

    Raises ValueError for n < 0 or a bad seed.
    """
    if n < 0:
        raise ValueError(f"number of poses must be >= 0, got {n}")
    js = joint_distributions(joints, count)
    e = seed_entropy(seed)
    parts = [draw_chunk(e, run, k, min(CHUNK, n - k * CHUNK), js) for k in range(-(-n // CHUNK))]
    return np.concatenate(parts) if parts else np.empty((0, count))
