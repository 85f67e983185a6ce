"""The arm model as data: :class:`ArmModel` and :class:`Encoder` (schema in docs/models.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Final

from aacmm.arm import Arm
from aacmm.core import EncoderConfig

#: The schema (name and version) of a model file: its ``format`` field.
MODEL_FORMAT: Final = "aacmm-model-1"
#: The shipped model every command uses unless told otherwise (the paper's arm).
DEFAULT_MODEL: Final = "gao2013"
#: How a joint's encoder reaches the device (the simulator's ``--encoder`` values).
ENCODER_INTERFACES: tuple[str, ...] = ("biss", "ssi", "ssi-gray", "counts")
#: Counts per revolution an encoder may have (``aacmm_arm_encoders_t``).
COUNTS_PER_REV_MIN: Final = 2
COUNTS_PER_REV_MAX: Final = 1 << 32
#: The plans a model without a ``[plans]`` table is calibrated and verified with
#: (the shipped plans sized for the paper's arm, docs/plans.md).
DEFAULT_CALIBRATION_PLAN: Final = "kinematic-calibration"
DEFAULT_VERIFICATION_PLAN: Final = "arm-verification"


@dataclass(frozen=True)
class Encoder:
    """One joint's encoder: resolution, zero, direction and interface.

    The joint reading in rad is ``direction * 2 pi * (counts - zero_offset_counts)
    / counts_per_rev`` (``aacmm/kinematics.h``, ``aacmm_counts_to_angles``).
    The default is the firmware's and the simulator's for the paper's arm:
    2^32 counts per revolution, zero 0, direction +1, BiSS-C frames. Raises
    ValueError for a value out of range.
    """

    counts_per_rev: int = COUNTS_PER_REV_MAX
    zero_offset_counts: int = 0
    direction: int = 1
    interface: str = "biss"

    def __post_init__(self) -> None:
        if not COUNTS_PER_REV_MIN <= self.counts_per_rev <= COUNTS_PER_REV_MAX:
            raise ValueError(f"counts_per_rev must be in 2 .. 2^32, got {self.counts_per_rev}")
        if not 0 <= self.zero_offset_counts < self.counts_per_rev:
            raise ValueError(
                f"zero_offset_counts must be in 0 .. counts_per_rev - 1 "
                f"({self.counts_per_rev - 1}), got {self.zero_offset_counts}"
            )
        if self.direction not in (1, -1):
            raise ValueError(f"direction must be +1 or -1, got {self.direction}")
        if self.interface not in ENCODER_INTERFACES:
            raise ValueError(
                f"interface must be one of {', '.join(ENCODER_INTERFACES)}, got {self.interface!r}"
            )

    @property
    def bits(self) -> int:
        """Position bits a frame needs for this resolution (1 .. 32)."""
        return max(1, (self.counts_per_rev - 1).bit_length())


@dataclass(frozen=True)
class ArmModel:
    """One arm model: the geometry (:attr:`arm`), its joints' limits and
    encoders, where its figures come from and which of them are assumed.

    ``joint_limits_rad[i]`` is (lowest, highest) reading of joint i + 1 in rad
    (the reading the model adds theta offset i + 1 to; finite limits span less
    than a turn and readings compare modulo 2 pi, :meth:`within_limits`);
    ``(-inf, inf)`` for a joint that turns without limit. ``assumed`` names the figures that are not
    published but assumed: parameter names as :attr:`aacmm.arm.Arm.param_names`
    (``d3``, ``beta3``, ``l``, ``tx`` ..), ``convention<j>``, ``limits<j>`` and
    ``encoder<j>`` (joints counted from 1). ``calibration_plan`` and
    ``verification_plan`` name the plans that fit the arm (its ``[plans]`` table:
    a shipped plan's name or a plan file; default :data:`DEFAULT_CALIBRATION_PLAN`
    and :data:`DEFAULT_VERIFICATION_PLAN`). ``file`` is where the model was read from (None
    for text). Construct with :func:`aacmm.models.load_model`; the constructor
    only checks that the per-joint tuples have N entries (ValueError).
    """

    name: str
    description: str
    source: str
    arm: Arm
    joint_limits_rad: tuple[tuple[float, float], ...]
    encoders: tuple[Encoder, ...]
    assumed: frozenset[str] = frozenset()
    notes: str = ""
    file: str | None = None
    calibration_plan: str = DEFAULT_CALIBRATION_PLAN
    verification_plan: str = DEFAULT_VERIFICATION_PLAN

    def __post_init__(self) -> None:
        n = self.arm.n_joints
        if len(self.joint_limits_rad) != n or len(self.encoders) != n:
            raise ValueError(
                f"an arm model of {n} joints needs {n} joint limits and {n} encoders, got "
                f"{len(self.joint_limits_rad)} and {len(self.encoders)}"
            )

    @property
    def n_joints(self) -> int:
        """N, the joint count."""
        return self.arm.n_joints

    @property
    def n_params(self) -> int:
        """P, the parameters (Jacobian columns)."""
        return self.arm.n_params

    @property
    def reach_mm(self) -> float:
        """Sum of every |d|, |a| and |tip component| (mm): the arm's largest reach,
        the figure the fixed-point path's limit (8000 mm) and accuracy scale with."""
        js = self.arm.joints
        return float(
            sum(abs(j.d_mm) + abs(j.a_mm) for j in js) + sum(abs(t) for t in self.arm.tip_mm)
        )

    def encoder_config(self) -> EncoderConfig:
        """The encoders as the core's :class:`aacmm.core.EncoderConfig`."""
        return EncoderConfig(
            tuple(e.counts_per_rev for e in self.encoders),
            tuple(e.zero_offset_counts for e in self.encoders),
            tuple(e.direction for e in self.encoders),
        )

    def sampling_ranges_rad(self) -> tuple[tuple[float, float], ...]:
        """N pairs (lowest, highest) in rad to draw random poses from: each joint's
        finite limits, [-pi, pi) for a joint without limits. Every pose drawn in
        them is :meth:`within_limits` (what ``aacmm mc``, ``uncertainty`` and
        ``tolerance`` draw for an arm model other than the paper's)."""
        return tuple(
            (-math.pi, math.pi) if math.isinf(lo) else (float(lo), float(hi))
            for lo, hi in self.joint_limits_rad
        )

    def within_limits(self, theta_rad: Any) -> bool:
        """True if every reading of one pose (N values, rad) is inside its joint's limits.

        A reading is an angle of one turn (an absolute encoder's): it is taken
        modulo 2 pi into [lowest, lowest + 2 pi) before it is compared with the
        highest limit. Raises ValueError for a pose of another joint count.
        """
        th = [float(t) for t in theta_rad]
        if len(th) != self.n_joints:
            raise ValueError(f"a pose of this arm has {self.n_joints} readings, got {len(th)}")
        for t, (lo, hi) in zip(th, self.joint_limits_rad, strict=True):
            if math.isinf(lo):
                continue
            if not math.isfinite(t) or lo + (t - lo) % (2.0 * math.pi) > hi:
                return False
        return True

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready description: ``name``, ``joints`` (N), ``n_params``, every
        parameter (``parameters``: name, value, unit, assumed, in Jacobian column
        order), per joint the convention, limits (``limits_rad`` exact,
        ``limits_deg`` rounded to 1e-9 deg; None for no limit) and encoder, the
        tip, the source, the assumed figures and the plans that fit the arm
        (``plans``: ``calibration``, ``verification``)."""
        names, units = self.arm.param_names, self.arm.param_units
        values = self.arm.to_vector()
        params = [
            {"name": p, "value": float(v), "unit": u, "assumed": p in self.assumed}
            for p, v, u in zip(names, values, units, strict=True)
        ]
        joints = []
        for i, (j, (lo, hi), e) in enumerate(
            zip(self.arm.joints, self.joint_limits_rad, self.encoders, strict=True)
        ):
            joints.append(
                {
                    "joint": i + 1,
                    "convention": j.convention,
                    "convention_assumed": f"convention{i + 1}" in self.assumed,
                    "beta": j.beta_rad is not None,
                    "limits_rad": None if math.isinf(lo) else [lo, hi],
                    "limits_deg": None
                    if math.isinf(lo)
                    else [round(math.degrees(lo), 9), round(math.degrees(hi), 9)],
                    "limits_assumed": f"limits{i + 1}" in self.assumed,
                    "encoder": {
                        "counts_per_rev": e.counts_per_rev,
                        "zero_offset_counts": e.zero_offset_counts,
                        "direction": e.direction,
                        "interface": e.interface,
                        "assumed": f"encoder{i + 1}" in self.assumed,
                    },
                }
            )
        return {
            "format": MODEL_FORMAT,
            "name": self.name,
            "description": self.description,
            "source": self.source,
            "notes": self.notes,
            "joints": self.n_joints,
            "n_params": self.n_params,
            "tip": {"kind": self.arm.tip, "vector_mm": list(self.arm.tip_mm)},
            "reach_mm": self.reach_mm,
            "parameters": params,
            "joint": joints,
            "assumed": sorted(self.assumed),
            "plans": {"calibration": self.calibration_plan, "verification": self.verification_plan},
            "file": self.file,
        }
