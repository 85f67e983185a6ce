"""The arm parameters a calibration works on: the paper's :class:`~aacmm.core.Params`
or any :class:`~aacmm.arm.Arm` (issue 26), behind one small set of functions.

A calibration keeps the type it was started with: a :class:`~aacmm.core.Params`
start gives :class:`~aacmm.core.Params` results (the paper's 25 columns, its
code path unchanged), an :class:`~aacmm.arm.Arm` start gives arms of the same
shape. P, the parameter names and units and the column order are the arm's
(docs/kinematics.md: thetas, alphas, ds, as, betas, tip).

Main names: :data:`ArmParams`, :func:`arm_of`, :func:`param_names`,
:func:`param_units`, :func:`n_joints`, :func:`with_vector`, :func:`validate`,
:func:`tip_columns`, :func:`hayati_held`.

Errors: :func:`validate` raises :class:`~aacmm.core.KinematicsError` (a
ValueError) for values the core rejects; :func:`with_vector` ValueError for
the wrong length.
"""

from __future__ import annotations

from typing import overload

import numpy as np
import numpy.typing as npt

from aacmm.arm import Arm
from aacmm.core import PARAM_NAMES, PARAM_UNITS, FloatArray, Model, Params

__all__ = [
    "ArmParams",
    "arm_of",
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


def arm_of(p: ArmParams) -> Arm:
    """``p`` as an :class:`~aacmm.arm.Arm` (a :class:`Params` by :meth:`Params.to_arm`)."""
    return p.to_arm() if isinstance(p, Params) else p


def param_names(p: ArmParams) -> tuple[str, ...]:
    """The P parameter names in Jacobian column order."""
    return PARAM_NAMES if isinstance(p, Params) else p.param_names


def param_units(p: ArmParams) -> tuple[str, ...]:
    """The unit (``rad`` or ``mm``) of each parameter, in column order."""
    return PARAM_UNITS if isinstance(p, Params) else p.param_units


def n_joints(p: ArmParams) -> int:
    """N, the arm's joint count (the width of its joint readings)."""
    return len(p.d_mm) if isinstance(p, Params) else p.n_joints


@overload
def with_vector(p: Params, v: npt.ArrayLike) -> Params: ...
@overload
def with_vector(p: Arm, v: npt.ArrayLike) -> Arm: ...
@overload
def with_vector(p: ArmParams, v: npt.ArrayLike) -> ArmParams: ...
def with_vector(p: ArmParams, v: npt.ArrayLike) -> ArmParams:
    """The same kind of parameters (and for an arm, the same shape) with values ``v``.

    Raises ValueError unless ``v`` has P values.
    """
    if isinstance(p, Params):
        return Params.from_vector(v)
    return p.with_vector(v)


def validate(p: ArmParams) -> None:
    """Check the values with the core's own validator (raises KinematicsError)."""
    if isinstance(p, Params):
        p.validate()
    else:
        Model(p)


def tip_columns(p: ArmParams) -> tuple[str, ...]:
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


def hayati_held(p: ArmParams) -> tuple[str, ...]:
    """The ``d`` of every joint that declares a beta: Hayati's beta replaces it.

    Where a joint's axis is (nearly) parallel to the previous one, the shift
    of the common normal along the two axes is a free choice of the model
    (``d`` of the previous joint against ``d`` of this one); declaring a beta
    says the model uses the tilt about y instead, so this joint's ``d`` stays
    at its start value (Hayati 1983). Empty for the paper's arm.
    """
    if isinstance(p, Params):
        return ()
    return tuple(f"d{j + 1}" for j in p.beta_joints)


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
