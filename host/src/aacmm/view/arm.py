"""The arm as the view draws it: every joint's frame from a parameter set.

The C core gives the probe point and its Jacobian, not the frames between;
to draw links and joints the view chains the standard Denavit-Hartenberg
transforms itself with numpy (docs/kinematics.md, paper Eq. 1-3):

    T_{i-1,i} = Rot(z, theta_i) Trans(0, 0, d_i) Trans(a_i, 0, 0) Rot(x, alpha_i)

joint i turning about z_{i-1} through the origin of frame i-1, the tip at
T_0n (0, 0, l). The chain takes as many joints as the parameter set has (the
arm of the paper has six; arms of 4-7 joints differ only in the lengths of
the per-joint sequences), so the drawing never assumes six.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class ArmPose:
    """One posture of the arm, base frame, mm.

    ``joints_mm[i]`` is where joint i+1's axis passes through (the origin of
    frame i), ``axes[i]`` that axis (unit); ``path_mm`` the polyline the links
    follow (base, each offset ``d`` along the axis, then ``a`` along x, ...,
    the flange, the tip); ``tip_mm`` the probe tip.
    """

    joints_mm: FloatArray
    axes: FloatArray
    path_mm: FloatArray
    tip_mm: FloatArray


def dh_chain(
    theta_rad: Sequence[float] | FloatArray,
    theta_offset_rad: Sequence[float],
    alpha_rad: Sequence[float],
    d_mm: Sequence[float],
    a_mm: Sequence[float],
    l_mm: float,
) -> ArmPose:
    """The frames of an n-joint standard-DH chain at joint readings ``theta_rad``.

    Every sequence has one value per joint (``theta_rad`` the readings without
    offsets, as :func:`aacmm.core.counts_to_angles` gives them). Raises
    ValueError if their lengths differ or there is no joint.
    """
    n = len(theta_offset_rad)
    if n == 0 or not (len(theta_rad) == len(alpha_rad) == len(d_mm) == len(a_mm) == n):
        raise ValueError("joint readings and DH parameters need one value per joint each")
    t = np.eye(4)
    joints = np.empty((n, 3))
    axes = np.empty((n, 3))
    path = [np.zeros(3)]
    for i in range(n):
        joints[i] = t[:3, 3]
        axes[i] = t[:3, 2]
        th = float(theta_rad[i]) + float(theta_offset_rad[i])
        al, d, a = float(alpha_rad[i]), float(d_mm[i]), float(a_mm[i])
        ct, st, ca, sa = math.cos(th), math.sin(th), math.cos(al), math.sin(al)
        step = np.array(
            [
                [ct, -st * ca, st * sa, a * ct],
                [st, ct * ca, -ct * sa, a * st],
                [0.0, sa, ca, d],
                [0.0, 0.0, 0.0, 1.0],
            ]
        )
        path.append(t[:3, 3] + d * t[:3, 2])  # along the joint axis first
        t = t @ step
        path.append(t[:3, 3].copy())
    tip = t[:3, 3] + float(l_mm) * t[:3, 2]
    path.append(tip)
    pts = np.array(path)
    # Zero-length pieces (a = 0 or d = 0) draw nothing; leave them out.
    keep = np.ones(len(pts), dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9
    return ArmPose(joints, axes, pts[keep], tip)


def arm_pose(params: object, theta_rad: Sequence[float] | FloatArray) -> ArmPose:
    """:func:`dh_chain` for an :class:`aacmm.core.Params` (or anything with its fields)."""
    return dh_chain(
        theta_rad,
        params.theta_offset_rad,  # type: ignore[attr-defined]
        params.alpha_rad,  # type: ignore[attr-defined]
        params.d_mm,  # type: ignore[attr-defined]
        params.a_mm,  # type: ignore[attr-defined]
        params.l_mm,  # type: ignore[attr-defined]
    )
