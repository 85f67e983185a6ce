"""The arm parameters a calibration works on: the paper's :class:`~aacmm.core.Params`
or any :class:`~aacmm.arm.Arm` (issue 26), behind one small set of functions.

A calibration keeps the type it was started with: a :class:`~aacmm.core.Params`
start gives :class:`~aacmm.core.Params` results (the paper's 25 columns, its
code path unchanged), an :class:`~aacmm.arm.Arm` start gives arms of the same
shape. P, the parameter names and units and the column order are the arm's
(docs/kinematics.md: thetas, alphas, ds, as, betas, tip).

A calibration of the encoder angle harmonics as well (issue 27) works on a
:class:`CalibParams`: the arm's parameters and an
:class:`~aacmm.errmodel.ErrorModel`, the vector the arm's P values followed by
the E harmonic coefficients ``c<j>_<k>``, ``s<j>_<k>`` (rad; joint ``j`` and
harmonic ``k`` from 1, :attr:`aacmm.errmodel.ErrorModel.param_names`), the
columns of :func:`aacmm.errmodel.points_jacobians`. With link expansion
coefficients estimated too (an error model with ``cte_columns``), the vector
ends with one ``cte<i>`` per link (1/K, at the error model's reference
temperatures). The functions here take it
as they take an arm; :func:`arm_part` and :func:`error_model` split it.

Main names: :data:`ArmParams`, :class:`CalibParams`, :data:`AnyParams`,
:func:`arm_of`, :func:`arm_part`, :func:`error_model`, :func:`param_names`,
:func:`param_units`, :func:`n_joints`, :func:`with_vector`, :func:`validate`,
:func:`tip_columns`, :func:`hayati_held`.

Errors: :func:`validate` raises :class:`~aacmm.core.KinematicsError` (a
ValueError) for values the core rejects; :func:`with_vector` ValueError for
the wrong length.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import overload

import numpy as np
import numpy.typing as npt

from aacmm.arm import Arm
from aacmm.core import PARAM_NAMES, PARAM_UNITS, FloatArray, Model, Params
from aacmm.errmodel import ErrorModel

__all__ = [
    "AnyParams",
    "ArmParams",
    "CalibParams",
    "arm_of",
    "arm_part",
    "error_model",
    "hayati_held",
    "n_joints",
    "param_names",
    "param_units",
    "tip_columns",
    "tip_in_last_frame",
    "validate",
    "with_vector",
]

#: The parameters of one arm: the paper's 25-parameter form or a general arm.
ArmParams = Params | Arm


@dataclass(frozen=True)
class CalibParams:
    """An arm's parameters and its encoder angle harmonics, calibrated together.

    ``arm``: the paper's :class:`~aacmm.core.Params` or an :class:`~aacmm.arm.Arm`;
    ``errors``: its :class:`~aacmm.errmodel.ErrorModel`. The vector is the
    arm's P values, then the E coefficients (``errors.param_names`` order: the
    harmonics, then with ``cte_columns`` the N link CTEs). Raises ValueError
    for an error model of another joint count.
    """

    arm: ArmParams
    errors: ErrorModel

    def __post_init__(self) -> None:
        if self.errors.joints != n_joints(self.arm):
            raise ValueError(
                f"the error model has {self.errors.joints} joints, the arm {n_joints(self.arm)}"
            )

    @property
    def harmonics(self) -> tuple[int, ...]:
        """K per joint (N,)."""
        return tuple(len(h) for h in self.errors.harmonics)

    @property
    def param_names(self) -> tuple[str, ...]:
        return (*param_names(self.arm), *self.errors.param_names)

    def to_vector(self) -> FloatArray:
        """The P + E values: the arm's, then ``c<j>_<k>``, ``s<j>_<k>`` joint after joint
        (then ``cte<i>`` per link with CTE columns)."""
        coeffs = [v for h in self.errors.harmonics for pair in h for v in pair]
        if self.errors.cte_columns:
            coeffs += list(self.errors.cte_per_k)
        return np.concatenate([self.arm.to_vector(), np.asarray(coeffs, dtype=np.float64)])

    def with_vector(self, v: npt.ArrayLike) -> CalibParams:
        """The same shape with values ``v`` (P + E). Raises ValueError for the wrong
        length or coefficients the error model refuses (their sum beyond 0.1 rad)."""
        x = np.asarray(v, dtype=np.float64).reshape(-1)
        p = len(param_names(self.arm))
        if x.size != p + self.errors.n_cols:
            raise ValueError(f"expected {p + self.errors.n_cols} values, got {x.size}")
        it = iter(x[p:].tolist())
        hs = tuple(tuple((next(it), next(it)) for _ in h) for h in self.errors.harmonics)
        e = self.errors
        cte = tuple(next(it) for _ in range(e.joints)) if e.cte_columns else e.cte_per_k
        em = ErrorModel(hs, cte, e.tref_c, e.cte_columns)
        return CalibParams(with_vector(self.arm, x[:p]), em)


#: What a calibration works on: an arm, or an arm and its encoder harmonics.
AnyParams = Params | Arm | CalibParams


def arm_part(p: AnyParams) -> ArmParams:
    """The arm's own parameters (``p`` itself unless a :class:`CalibParams`)."""
    return p.arm if isinstance(p, CalibParams) else p


def error_model(p: AnyParams) -> ErrorModel | None:
    """The error model of a :class:`CalibParams`, else None."""
    return p.errors if isinstance(p, CalibParams) else None


def arm_of(p: AnyParams) -> Arm:
    """``p`` as an :class:`~aacmm.arm.Arm` (a :class:`Params` by :meth:`Params.to_arm`)."""
    a = arm_part(p)
    return a.to_arm() if isinstance(a, Params) else a


def param_names(p: AnyParams) -> tuple[str, ...]:
    """The P (+ E) parameter names in Jacobian column order."""
    if isinstance(p, CalibParams):
        return p.param_names
    return PARAM_NAMES if isinstance(p, Params) else p.param_names


def param_units(p: AnyParams) -> tuple[str, ...]:
    """The unit (``rad`` or ``mm``) of each parameter, in column order."""
    if isinstance(p, CalibParams):
        e = p.errors
        cte = ("1/K",) * e.joints if e.cte_columns else ()
        return (*param_units(p.arm), *("rad",) * (e.n_cols - len(cte)), *cte)
    return PARAM_UNITS if isinstance(p, Params) else p.param_units


def n_joints(p: AnyParams) -> int:
    """N, the arm's joint count (the width of its joint readings)."""
    a = arm_part(p)
    return len(a.d_mm) if isinstance(a, Params) else a.n_joints


@overload
def with_vector(p: Params, v: npt.ArrayLike) -> Params: ...
@overload
def with_vector(p: Arm, v: npt.ArrayLike) -> Arm: ...
@overload
def with_vector(p: CalibParams, v: npt.ArrayLike) -> CalibParams: ...
@overload
def with_vector(p: ArmParams, v: npt.ArrayLike) -> ArmParams: ...
@overload
def with_vector(p: AnyParams, v: npt.ArrayLike) -> AnyParams: ...
def with_vector(p: AnyParams, v: npt.ArrayLike) -> AnyParams:
    """The same kind of parameters (and for an arm, the same shape) with values ``v``.

    Raises ValueError unless ``v`` has P (+ E) values.
    """
    if isinstance(p, Params):
        return Params.from_vector(v)
    return p.with_vector(v)


def validate(p: AnyParams) -> None:
    """Check the values with the core's own validator (raises KinematicsError)."""
    a = arm_part(p)
    if isinstance(a, Params):
        a.validate()
    else:
        Model(a)


def tip_columns(p: AnyParams) -> tuple[str, ...]:
    """The parameters that place the probe tip relative to the last joint's rotation.

    The probe point depends on them only through the tip's position in the
    frame turned by the last joint's reading: the last joint's theta offset,
    the parameters its convention applies after the rotation (standard: alpha,
    d, a; modified: d) and the tip (l, or tx, ty, tz). For the paper's arm
    theta6, alpha6, d6, a6, l.
    """
    arm = arm_of(p)
    n = arm.n_joints
    last = arm.joints[-1]
    after = ("alpha", "d", "a") if last.convention == "standard" else ("d",)
    tip = ("tx", "ty", "tz") if arm.tip == "xyz" else ("l",)
    names = (f"theta{n}", *(f"{g}{n}" for g in after), *tip)
    order = param_names(p)
    return tuple(sorted(names, key=order.index))


def hayati_held(p: AnyParams) -> tuple[str, ...]:
    """The ``d`` of every joint that declares a beta: Hayati's beta replaces it.

    Where a joint's axis is (nearly) parallel to the previous one, the shift
    of the common normal along the two axes is a free choice of the model
    (``d`` of the previous joint against ``d`` of this one); declaring a beta
    says the model uses the tilt about y instead, so this joint's ``d`` stays
    at its start value (Hayati 1983). Empty for the paper's arm.
    """
    a = arm_part(p)
    if isinstance(a, Params):
        return ()
    return tuple(f"d{j + 1}" for j in a.beta_joints)


def _rot(axis: int, angle: complex) -> npt.NDArray[np.complex128]:
    c, s = np.cos(angle), np.sin(angle)
    m = np.eye(4, dtype=np.complex128)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def _shift(axis: int, length: complex) -> npt.NDArray[np.complex128]:
    m = np.eye(4, dtype=np.complex128)
    m[axis, 3] = length
    return m


def _tip_point(arm: Arm, values: dict[str, complex]) -> npt.NDArray[np.complex128]:
    """The tip in the frame turned by the last joint's reading (complex for the step)."""
    n = arm.n_joints
    last = arm.joints[-1]
    if arm.tip == "xyz":
        t = np.array([values["tx"], values["ty"], values["tz"], 1.0], dtype=np.complex128)
    else:
        t = np.array([0.0, 0.0, values["l"], 1.0], dtype=np.complex128)
    m = _rot(2, values[f"theta{n}"]) @ _shift(2, values[f"d{n}"])
    if last.convention == "standard":
        m = m @ _shift(0, values[f"a{n}"]) @ _rot(0, values[f"alpha{n}"])
    out: npt.NDArray[np.complex128] = (m @ t)[:3]
    return out


def tip_in_last_frame(p: ArmParams) -> tuple[FloatArray, FloatArray]:
    """The tip (3,) in the frame turned by the last joint's reading, mm, and its
    derivatives (3, k) with respect to :func:`tip_columns` (complex step: exact
    to rounding).

    Standard last joint: Rz(theta_N) Tz(d_N) Tx(a_N) Rx(alpha_N) t; modified:
    Rz(theta_N) Tz(d_N) t (alpha_N and a_N come before its rotation), ``t`` the
    tip vector ((0, 0, l) for a tip on z). Only this vector reaches the probe
    point, so k - rank of the derivatives are the tip's unobservable directions.
    """
    arm = arm_of(p)
    cols = tip_columns(p)
    names = param_names(p)
    v = arm.to_vector()
    base = {n: complex(v[names.index(n)]) for n in cols}
    w = _tip_point(arm, base).real
    h = 1e-30
    grad = np.empty((3, len(cols)))
    for i, n in enumerate(cols):
        step = dict(base)
        step[n] = base[n] + 1j * h
        grad[:, i] = _tip_point(arm, step).imag / h
    return np.asarray(w, dtype=np.float64), grad
