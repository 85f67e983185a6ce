"""Host double-precision reference for checking the device's kinematics.

Uses the C core through ``aacmm.core`` (cffi) when it is importable, else an
independent numpy implementation of the DH chain (docs/kinematics.md):

    T_{i-1,i} = Rot(z, theta_i) Trans(0, 0, d_i) Trans(a_i, 0, 0) Rot(x, alpha_i)
    p = T_01 ... T_56 (0, 0, l, 1)^T,   theta_i = reading angle + theta_offset_i

with the Jacobian (columns theta1..6, alpha1..6, d1..6, a1..6, l) by central
differences in the fallback.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from aacmm.protocol import ParamSet

FloatArray = npt.NDArray[np.float64]


def counts_to_angles(p: ParamSet, counts: Sequence[int]) -> FloatArray:
    """Joint readings in rad (without theta offsets), as ``aacmm_encoder_to_angles_f64``."""
    out = np.empty(6)
    for i in range(6):
        cpr = p.counts_per_rev[i]
        delta = (counts[i] - p.zero_offset_counts[i]) % cpr
        s = delta if 2 * delta < cpr else delta - cpr
        out[i] = p.direction[i] * s * (2.0 * math.pi / cpr)
    return out


def _vector(p: ParamSet) -> FloatArray:
    return np.array([*p.theta_offset_rad, *p.alpha_rad, *p.d_mm, *p.a_mm, p.l_mm])


def numpy_point(v: FloatArray, theta: FloatArray) -> FloatArray:
    """Probe point for parameter vector ``v`` (25, Jacobian order) and readings ``theta``."""
    t = np.eye(4)
    for i in range(6):
        th, al, d, a = theta[i] + v[i], v[6 + i], v[12 + i], v[18 + i]
        ct, st, ca, sa = math.cos(th), math.sin(th), math.cos(al), math.sin(al)
        t = t @ np.array(
            [
                [ct, -st * ca, st * sa, a * ct],
                [st, ct * ca, -ct * sa, a * st],
                [0.0, sa, ca, d],
                [0.0, 0.0, 0.0, 1.0],
            ]
        )
    out: FloatArray = (t @ np.array([0.0, 0.0, v[24], 1.0]))[:3]
    return out


def numpy_point_jacobian(p: ParamSet, counts: Sequence[int]) -> tuple[FloatArray, FloatArray]:
    theta = counts_to_angles(p, counts)
    v = _vector(p)
    point = numpy_point(v, theta)
    jac = np.empty((3, 25))
    for k in range(25):
        h = 1e-6 * max(1.0, abs(v[k]))
        vp, vm = v.copy(), v.copy()
        vp[k] += h
        vm[k] -= h
        jac[:, k] = (numpy_point(vp, theta) - numpy_point(vm, theta)) / (2 * h)
    return point, jac


def core_point_jacobian(p: ParamSet, counts: Sequence[int]) -> tuple[FloatArray, FloatArray]:
    from aacmm import core

    params, enc = p.to_core()
    theta = core.counts_to_angles(np.array([counts], dtype=np.int64), enc)[0]
    point, jac = core.Model(params).point_jacobian(theta)
    return point, jac


def have_core() -> bool:
    try:
        from aacmm import core  # noqa: F401
    except Exception:
        return False
    return True


def point_jacobian(p: ParamSet, counts: Sequence[int]) -> tuple[FloatArray, FloatArray]:
    """Reference point (3,) in mm and Jacobian (3, 25) for a parameter set and readings."""
    if have_core():
        return core_point_jacobian(p, counts)
    return numpy_point_jacobian(p, counts)
