"""The arm as the view draws it: every joint's frame, for any serial arm.

The C core gives the probe point and its Jacobian, not the frames between;
to draw links and joints the view chains the joint transforms itself, as
firmware/include/aacmm/kinematics.h defines them (docs/kinematics.md):

    standard DH (the paper's Eq. 1-3): A_i = [Ry(beta_i)] Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)
    modified DH:                       A_i = Rx(alpha_i) Tx(a_i) [Ry(beta_i)] Rz(theta_i) Tz(d_i)

the tip at T_0N (tip vector), for an :class:`aacmm.arm.Arm` of 4 to 7
joints (or the paper's :class:`aacmm.core.Params`, drawn as its arm). The
chain is plain Python floats, not numpy: a frame of 4 to 7 small matrix
products is several times cheaper so, and the live view makes 40 a second.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aacmm.arm import Arm, Joint

FloatArray = npt.NDArray[np.float64]
_Mat = list[list[float]]  # 3 x 4: rotation | translation (the last row is 0 0 0 1)


@dataclass(frozen=True)
class ArmPose:
    """One posture of the arm, base frame, mm.

    ``joints_mm[i]`` is where joint i+1's axis passes through (the origin of
    the frame it turns in), ``axes[i]`` that axis (unit); ``path_mm`` the
    polyline the links follow (base, each offset along the axis and across
    to the next, the flange, the tip); ``tip_mm`` the probe tip.
    """

    joints_mm: FloatArray
    axes: FloatArray
    path_mm: FloatArray
    tip_mm: FloatArray


def _mul(m: _Mat, n: _Mat) -> _Mat:
    """m @ n for 3x4 rigid transforms."""
    return [
        [
            m[r][0] * n[0][0] + m[r][1] * n[1][0] + m[r][2] * n[2][0],
            m[r][0] * n[0][1] + m[r][1] * n[1][1] + m[r][2] * n[2][1],
            m[r][0] * n[0][2] + m[r][1] * n[1][2] + m[r][2] * n[2][2],
            m[r][0] * n[0][3] + m[r][1] * n[1][3] + m[r][2] * n[2][3] + m[r][3],
        ]
        for r in range(3)
    ]


def _rz_tz(theta: float, d: float) -> _Mat:
    c, s = math.cos(theta), math.sin(theta)
    return [[c, -s, 0.0, 0.0], [s, c, 0.0, 0.0], [0.0, 0.0, 1.0, d]]


def _tx_rx(a: float, alpha: float) -> _Mat:
    c, s = math.cos(alpha), math.sin(alpha)
    return [[1.0, 0.0, 0.0, a], [0.0, c, -s, 0.0], [0.0, s, c, 0.0]]


def _ry(beta: float) -> _Mat:
    c, s = math.cos(beta), math.sin(beta)
    return [[c, 0.0, s, 0.0], [0.0, 1.0, 0.0, 0.0], [-s, 0.0, c, 0.0]]


def _origin(t: _Mat) -> list[float]:
    return [t[0][3], t[1][3], t[2][3]]


def _z(t: _Mat) -> list[float]:
    return [t[0][2], t[1][2], t[2][2]]


def chain(arm: Arm, theta_rad: Sequence[float] | FloatArray) -> ArmPose:
    """The frames of ``arm`` at joint readings ``theta_rad`` (rad, without the
    theta offsets, as :func:`aacmm.core.counts_to_angles` gives them).

    Raises ValueError unless there is one reading per joint.
    """
    joints: tuple[Joint, ...] = arm.joints
    if len(theta_rad) != len(joints):
        raise ValueError(f"the arm has {len(joints)} joints, got {len(theta_rad)} readings")
    t: _Mat = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]]
    origins: list[list[float]] = []
    axes: list[list[float]] = []
    path = [[0.0, 0.0, 0.0]]
    for j, q in zip(joints, theta_rad, strict=True):
        if j.convention == "modified":
            t = _mul(t, _tx_rx(j.a_mm, j.alpha_rad))
            path.append(_origin(t))
        if j.beta_rad is not None:
            t = _mul(t, _ry(j.beta_rad))
        origins.append(_origin(t))
        axes.append(_z(t))
        t = _mul(t, _rz_tz(float(q) + j.theta_offset_rad, j.d_mm))
        path.append(_origin(t))  # along the joint axis first
        if j.convention == "standard":
            t = _mul(t, _tx_rx(j.a_mm, j.alpha_rad))
            path.append(_origin(t))
    x, y, z = arm.tip_mm
    tip = [t[r][0] * x + t[r][1] * y + t[r][2] * z + t[r][3] for r in range(3)]
    path.append(tip)
    pts = np.array(path)
    # Zero-length pieces (a = 0 or d = 0) draw nothing; leave them out.
    keep = np.ones(len(pts), dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9
    return ArmPose(np.array(origins), np.array(axes), pts[keep], np.array(tip))


def arm_pose(params: Any, theta_rad: Sequence[float] | FloatArray) -> ArmPose:
    """:func:`chain` for an :class:`aacmm.arm.Arm` or an :class:`aacmm.core.Params`
    (anything with ``to_arm()``: the paper's arm in its 25-parameter form)."""
    arm = params if isinstance(params, Arm) else params.to_arm()
    return chain(arm, theta_rad)
