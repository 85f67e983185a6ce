"""A general serial arm (issue 26): N revolute joints, 4 <= N <= 7, each in
standard or modified Denavit-Hartenberg convention, with an optional Hayati
beta, and a probe tip on z (the paper's ``l``) or a tip vector.

Pure Python: the description, its checks, and the parameter vector in the
Jacobian column order of ``firmware/include/aacmm/kinematics.h`` (all thetas,
all alphas, all d, all a, the declared betas in joint order, then the tip).
:class:`aacmm.core.Model` computes with it; ``aacmm.core.Params`` is the
paper's arm in its 25-parameter form (``Params().to_arm()`` is
:meth:`Arm.paper`).

Main names:

* :class:`Joint` -- one joint: convention, theta offset, alpha, d, a, beta.
* :class:`Arm` -- the joints and the tip; :meth:`Arm.paper`,
  :attr:`Arm.param_names`, :meth:`Arm.to_vector`, :meth:`Arm.with_vector`.

Errors: a malformed arm (joint count, convention, beta on joint 1, tip kind,
a non-finite or out-of-range value) raises :class:`ValueError` naming the
field, at construction.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

__all__ = [
    "CONVENTIONS",
    "JOINTS_MAX",
    "JOINTS_MIN",
    "PARAMS_MAX",
    "TIPS",
    "Arm",
    "Joint",
]

#: Joint conventions, in ``aacmm_dh_convention_t`` order.
CONVENTIONS: tuple[str, ...] = ("standard", "modified")
#: Tip kinds: ``"z"`` is (0, 0, l) in the last frame (one parameter),
#: ``"xyz"`` a tip vector (three).
TIPS: tuple[str, ...] = ("z", "xyz")
JOINTS_MIN = 4
JOINTS_MAX = 7
#: Parameters (Jacobian columns) of the largest arm: 4 * 7 + 6 + 3.
PARAMS_MAX = 4 * JOINTS_MAX + (JOINTS_MAX - 1) + 3

_LENGTH_MAX_MM = 10000.0
_ANGLE_MAX_RAD = 2.0 * math.pi
_PAPER_D_MM = (300.0, 65.5, 792.7, 65.5, 883.2, 0.0)
_PAPER_L_MM = 183.5


def _value(name: str, x: float, limit: float) -> float:
    v = float(x)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    if abs(v) > limit:
        raise ValueError(f"{name} must be within +-{limit:g}, got {v}")
    return v


@dataclass(frozen=True)
class Joint:
    """One revolute joint (mm, rad).

    ``convention``: ``"standard"`` (Rz(theta) Tz(d) Tx(a) Rx(alpha), the
    paper's Eq. 1) or ``"modified"`` (Rx(alpha) Tx(a) Rz(theta) Tz(d)).
    ``beta_rad``: Hayati's rotation about y where this joint's axis is
    (nearly) parallel to the previous one, or ``None`` for none; Ry(beta) is
    applied immediately before this joint's Rz(theta) (kinematics.h says
    where that is in each convention). Raises ValueError for an unknown
    convention or a value out of range (|angle| <= 2 pi, |length| <= 10000).
    """

    convention: str = "standard"
    theta_offset_rad: float = 0.0
    alpha_rad: float = 0.0
    d_mm: float = 0.0
    a_mm: float = 0.0
    beta_rad: float | None = None

    def __post_init__(self) -> None:
        if self.convention not in CONVENTIONS:
            raise ValueError(
                f"joint convention must be one of {', '.join(CONVENTIONS)}, got {self.convention!r}"
            )
        for name, limit in (
            ("theta_offset_rad", _ANGLE_MAX_RAD),
            ("alpha_rad", _ANGLE_MAX_RAD),
            ("d_mm", _LENGTH_MAX_MM),
            ("a_mm", _LENGTH_MAX_MM),
        ):
            object.__setattr__(self, name, _value(name, getattr(self, name), limit))
        if self.beta_rad is not None:
            object.__setattr__(self, "beta_rad", _value("beta_rad", self.beta_rad, _ANGLE_MAX_RAD))


def _paper_joints() -> tuple[Joint, ...]:
    return tuple(Joint(alpha_rad=math.pi / 2.0, d_mm=d) for d in _PAPER_D_MM)


@dataclass(frozen=True)
class Arm:
    """An arm: its joints (4 to 7) and its probe tip; the default is the paper's.

    ``tip`` is ``"z"`` (the tip at (0, 0, ``tip_mm[2]``) in the last frame: the
    paper's l, one parameter; ``tip_mm[0:2]`` must be 0) or ``"xyz"`` (three
    parameters). Raises ValueError for a joint count outside 4..7, a beta on
    joint 1, an unknown tip kind, or a tip value out of range.
    """

    joints: tuple[Joint, ...] = field(default_factory=_paper_joints)
    tip: str = "z"
    tip_mm: tuple[float, float, float] = (0.0, 0.0, _PAPER_L_MM)

    def __post_init__(self) -> None:
        joints = tuple(self.joints)
        if not all(isinstance(j, Joint) for j in joints):
            raise ValueError("an arm's joints must be Joint objects")
        if not JOINTS_MIN <= len(joints) <= JOINTS_MAX:
            raise ValueError(f"an arm has {JOINTS_MIN} to {JOINTS_MAX} joints, got {len(joints)}")
        if joints[0].beta_rad is not None:
            raise ValueError("joint 1 cannot have a beta (it has no previous axis)")
        object.__setattr__(self, "joints", joints)
        if self.tip not in TIPS:
            raise ValueError(f"tip must be one of {', '.join(TIPS)}, got {self.tip!r}")
        tip = tuple(float(t) for t in self.tip_mm)
        if len(tip) != 3:
            raise ValueError(f"tip_mm needs 3 values, got {len(tip)}")
        tip = tuple(_value(f"tip_mm[{i}]", t, _LENGTH_MAX_MM) for i, t in enumerate(tip))
        if self.tip == "z" and (tip[0] != 0.0 or tip[1] != 0.0):
            raise ValueError("a tip of kind 'z' has tip_mm[0] = tip_mm[1] = 0")
        object.__setattr__(self, "tip_mm", tip)

    @classmethod
    def paper(cls) -> Arm:
        """The paper's Table 1 (same as ``Arm()`` and ``aacmm.core.Params().to_arm()``)."""
        return cls()

    @property
    def n_joints(self) -> int:
        """N, the number of joints."""
        return len(self.joints)

    @property
    def beta_joints(self) -> tuple[int, ...]:
        """The joints (0-based) that declare a beta, in joint order."""
        return tuple(i for i, j in enumerate(self.joints) if j.beta_rad is not None)

    @property
    def n_params(self) -> int:
        """P = 4 N + (declared betas) + (1 or 3 tip parameters)."""
        return 4 * self.n_joints + len(self.beta_joints) + (3 if self.tip == "xyz" else 1)

    @property
    def is_paper_shape(self) -> bool:
        """True for 6 standard joints without beta and a tip l (any values)."""
        return (
            self.n_joints == 6
            and self.tip == "z"
            and all(j.convention == "standard" and j.beta_rad is None for j in self.joints)
        )

    @property
    def param_names(self) -> tuple[str, ...]:
        """The P parameter names in Jacobian column order, joints counted from 1:
        ``theta1 .. thetaN, alpha1 .., d1 .., a1 .., beta<j> .., l`` (or
        ``tx, ty, tz``). For the paper's arm, :data:`aacmm.core.PARAM_NAMES`."""
        n = range(1, self.n_joints + 1)
        tip = ("tx", "ty", "tz") if self.tip == "xyz" else ("l",)
        return (
            *(f"theta{i}" for i in n),
            *(f"alpha{i}" for i in n),
            *(f"d{i}" for i in n),
            *(f"a{i}" for i in n),
            *(f"beta{i + 1}" for i in self.beta_joints),
            *tip,
        )

    @property
    def param_units(self) -> tuple[str, ...]:
        """Unit of each parameter (and of its Jacobian column: mm per unit)."""
        n, b = self.n_joints, len(self.beta_joints)
        return (
            ("rad",) * (2 * n)
            + ("mm",) * (2 * n)
            + ("rad",) * b
            + ("mm",) * (self.n_params - 4 * n - b)
        )

    def to_vector(self) -> npt.NDArray[np.float64]:
        """The P parameters in Jacobian column order (see :attr:`param_names`)."""
        js = self.joints
        tip = self.tip_mm if self.tip == "xyz" else self.tip_mm[2:]
        values = [
            *(j.theta_offset_rad for j in js),
            *(j.alpha_rad for j in js),
            *(j.d_mm for j in js),
            *(j.a_mm for j in js),
            *(float(js[i].beta_rad or 0.0) for i in self.beta_joints),
            *tip,
        ]
        return np.array(values, dtype=np.float64)

    def with_vector(self, v: npt.ArrayLike) -> Arm:
        """The same arm (shape) with the parameter values ``v`` (P values, column order).

        Raises ValueError for the wrong length or a value out of range.
        """
        a = np.asarray(v, dtype=np.float64).reshape(-1)
        if a.size != self.n_params:
            raise ValueError(f"this arm has {self.n_params} parameters, got {a.size}")
        f = [float(x) for x in a]
        n = self.n_joints
        betas = iter(f[4 * n : 4 * n + len(self.beta_joints)])
        joints = tuple(
            Joint(
                convention=j.convention,
                theta_offset_rad=f[i],
                alpha_rad=f[n + i],
                d_mm=f[2 * n + i],
                a_mm=f[3 * n + i],
                beta_rad=next(betas) if j.beta_rad is not None else None,
            )
            for i, j in enumerate(self.joints)
        )
        rest = f[4 * n + len(self.beta_joints) :]
        tip = (rest[0], rest[1], rest[2]) if self.tip == "xyz" else (0.0, 0.0, rest[0])
        return Arm(joints=joints, tip=self.tip, tip_mm=tip)

    @classmethod
    def from_sequences(
        cls,
        conventions: Sequence[str],
        theta_offset_rad: Sequence[float],
        alpha_rad: Sequence[float],
        d_mm: Sequence[float],
        a_mm: Sequence[float],
        beta_rad: Sequence[float | None] | None = None,
        tip: str = "z",
        tip_mm: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> Arm:
        """An arm from per-joint sequences of equal length (beta: ``None`` for none).

        Raises ValueError if the lengths differ or a value is invalid.
        """
        n = len(conventions)
        betas = list(beta_rad) if beta_rad is not None else [None] * n
        for name, seq in (
            ("theta_offset_rad", theta_offset_rad),
            ("alpha_rad", alpha_rad),
            ("d_mm", d_mm),
            ("a_mm", a_mm),
            ("beta_rad", betas),
        ):
            if len(seq) != n:
                raise ValueError(f"{name} needs {n} values (one per joint), got {len(seq)}")
        joints = tuple(
            Joint(c, t, al, d, a, b)
            for c, t, al, d, a, b in zip(
                conventions, theta_offset_rad, alpha_rad, d_mm, a_mm, betas, strict=True
            )
        )
        t3 = tuple(float(x) for x in tip_mm)
        if len(t3) != 3:
            raise ValueError(f"tip_mm needs 3 values, got {len(t3)}")
        return cls(joints=joints, tip=tip, tip_mm=(t3[0], t3[1], t3[2]))
