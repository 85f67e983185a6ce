"""Probe (tip) calibration: the pivot calibration of an arm's stylus.

The tip enters the model through five parameters (theta6 offset, alpha6, d6,
a6, l), but the probe point depends only on the tip's position in the flange
frame (frame 5 turned by the joint-6 reading):

    t = Rz(theta6) (a6, -l sin alpha6, d6 + l cos alpha6)

three combinations of five. :func:`calibrate_probe` is :func:`calibrate` with
only these five free: the solve holds theta6 offset and alpha6 and estimates
d6, a6 and l, which with alpha6 = 90 deg and theta6 = 0 are the tip vector's
components (a6, -l, d6) themselves. The data are seats (the tip held in a cone
while the arm is articulated), so this is the classic pivot calibration with
the arm's own kinematics giving the flange poses.

Checks users of pivot calibration expect: too little orientation spread is an
error (:class:`SpreadError`): the tip component along an axis is only seen
through rotations about the other two, so the spread is measured as the RMS
rotation seen by the worst-determined tip direction (the smallest eigenvalue
of mean((R_k - R_mean)^T (R_k - R_mean)) over each seat's flange rotations);
and the RMS pivot error (distance of each point from its seat) is reported.

Any :class:`~aacmm.arm.Arm` (issue 26) works the same way: its tip
parameters are :func:`~aacmm.calibration.parameters.tip_columns` (the last
joint's theta offset, what its convention applies after the rotation, and the
tip l or tx, ty, tz), the tip vector the one of
:func:`~aacmm.calibration.parameters.tip_in_last_frame`, and the flange
rotations the tip-vector columns of the same arm with its tip as a vector.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from aacmm.arm import Arm
from aacmm.calibration.features import CalibrationError
from aacmm.calibration.observations import Cone, ObservationError, Observations
from aacmm.calibration.parameters import (
    ArmParams,
    param_names,
    tip_columns,
    tip_in_last_frame,
)
from aacmm.calibration.results import CalibrationResult, Progress
from aacmm.calibration.solve import calibrate
from aacmm.core import PARAM_NAMES, FloatArray, Model, Params

DEFAULT_MIN_SPREAD_DEG = 10.0
_COL_A6 = PARAM_NAMES.index("a6")
_COL_L = PARAM_NAMES.index("l")


class SpreadError(CalibrationError):
    """The seats were not probed with enough orientation change to find the tip."""


def tip_vector(params: ArmParams) -> FloatArray:
    """The tip position (3,) in the flange frame, mm (see the module doc)."""
    if isinstance(params, Arm):
        return tip_in_last_frame(params)[0]
    th, al = params.theta_offset_rad[5], params.alpha_rad[5]
    d6, a6, ll = params.d_mm[5], params.a_mm[5], params.l_mm
    u = np.array([a6, -ll * math.sin(al), d6 + ll * math.cos(al)])
    c, s = math.cos(th), math.sin(th)
    return np.array([c * u[0] - s * u[1], s * u[0] + c * u[1], u[2]])


def tip_jacobian(params: ArmParams) -> FloatArray:
    """d(tip vector)/d(theta6, alpha6, d6, a6, l), (3, 5); for an arm, with respect
    to its :func:`~aacmm.calibration.parameters.tip_columns`."""
    if isinstance(params, Arm):
        return tip_in_last_frame(params)[1]
    th, al = params.theta_offset_rad[5], params.alpha_rad[5]
    d6, a6, ll = params.d_mm[5], params.a_mm[5], params.l_mm
    ct, st, ca, sa = math.cos(th), math.sin(th), math.cos(al), math.sin(al)
    rz = np.array([[ct, -st, 0.0], [st, ct, 0.0], [0.0, 0.0, 1.0]])
    drz = np.array([[-st, -ct, 0.0], [ct, -st, 0.0], [0.0, 0.0, 0.0]])
    u = np.array([a6, -ll * sa, d6 + ll * ca])
    return np.column_stack(
        [
            drz @ u,
            rz @ np.array([0.0, -ll * ca, -ll * sa]),
            rz @ np.array([0.0, 0.0, 1.0]),
            rz @ np.array([1.0, 0.0, 0.0]),
            rz @ np.array([0.0, -sa, ca]),
        ]
    )


def flange_rotations(params: ArmParams, theta_rad: FloatArray) -> FloatArray:
    """Rotation matrices (n, 3, 3) of frame 6 in the base frame, from the core's Jacobian.

    dp/da6 is x6 and dp/dl is z6 (docs/kinematics.md), so no second
    kinematic model is needed. Frame 6 differs from the flange frame by a
    constant rotation, which leaves the spread measure unchanged. For an arm,
    the last frame's axes are dp/dtx, dp/dty, dp/dtz of the same arm with its
    tip as a vector.
    """
    if isinstance(params, Arm):
        as_vector = Arm(joints=params.joints, tip="xyz", tip_mm=params.tip_mm)
        names = as_vector.param_names
        _, jv = Model(as_vector).points_jacobians(theta_rad)
        cols = [names.index(n) for n in ("tx", "ty", "tz")]
        return np.stack([jv[:, :, c] for c in cols], axis=2)
    _, j = Model(params).points_jacobians(theta_rad)
    x = j[:, :, _COL_A6]
    z = j[:, :, _COL_L]
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=2)


def orientation_spread_rad(params: ArmParams, obs: Observations) -> float:
    """RMS rotation (rad) seen by the worst-determined tip direction, pooled over the seats."""
    m = np.zeros((3, 3))
    n = 0
    for c in obs.constraints:
        if not isinstance(c, Cone):
            continue
        r = flange_rotations(params, obs.theta_rad[c.poses])
        d = r - r.mean(axis=0)
        m += np.einsum("kab,kac->bc", d, d)
        n += r.shape[0]
    if n == 0:
        return 0.0
    return float(math.sqrt(max(np.linalg.eigvalsh(m / n)[0], 0.0)))


@dataclass(frozen=True)
class ProbeResult:
    """A probe calibration: the engine's result plus the pivot figures.

    ``tip_before``/``tip_after``: tip vectors (mm) in the flange frame;
    ``tip_cov`` (3, 3): covariance of ``tip_after`` (the reported one: scaled by
    chi^2/dof when the chi-square check refutes the model, which it does when
    the arm's own geometry, not the tip, leaves the seats open); ``spread_deg``: the
    orientation spread; ``pivot_rms_mm`` / ``pivot_max_mm``: distance of
    every point from its seat after (``_before``: with the start tip).
    """

    result: CalibrationResult[Any]
    tip_before: FloatArray
    tip_after: FloatArray
    tip_cov: FloatArray
    spread_deg: float
    pivot_rms_mm: float
    pivot_max_mm: float
    pivot_rms_before_mm: float
    elapsed_s: float


def _pivot(params: ArmParams, obs: Observations) -> tuple[float, float]:
    pts = Model(params).points(obs.theta_rad)
    d = []
    for c in obs.constraints:
        if isinstance(c, Cone):
            p = pts[c.poses]
            d.append(np.linalg.norm(p - p.mean(axis=0), axis=1))
    a = np.concatenate(d)
    return float(np.sqrt(np.mean(a**2))), float(a.max())


def calibrate_probe(
    obs: Observations,
    start: ArmParams | None = None,
    *,
    min_spread_deg: float = DEFAULT_MIN_SPREAD_DEG,
    reject: bool = False,
    progress: Callable[[Progress], None] | None = None,
) -> ProbeResult:
    """Calibrate the tip from seats probed with the arm articulated.

    Raises ObservationError if ``obs`` has no seat, SpreadError if the
    orientation spread is below ``min_spread_deg``, and what
    :func:`calibrate` raises.
    """
    t0 = time.perf_counter()
    p0: ArmParams = start or Params()
    if not any(isinstance(c, Cone) for c in obs.constraints):
        raise ObservationError(
            "a probe calibration needs seats (cone steps) probed from many articulations"
        )
    obs.validate()
    spread = math.degrees(orientation_spread_rad(p0, obs))
    if spread < min_spread_deg:
        raise SpreadError(
            f"too little orientation spread: the worst tip direction sees {spread:.1f} deg RMS "
            f"of rotation (need >= {min_spread_deg:g}); tilt the probe further in every "
            "direction while keeping the tip in the seat"
        )
    tip = tip_columns(p0)
    res = calibrate(obs, p0, free=tip, reject=reject, progress=progress)
    g = tip_jacobian(res.params)
    idx = [param_names(p0).index(n) for n in tip]
    cov = g @ res.scaled_covariance[np.ix_(idx, idx)] @ g.T
    before, _ = _pivot(p0, res.observations)
    rms, mx = _pivot(res.params, res.observations)
    return ProbeResult(
        res,
        tip_vector(p0),
        tip_vector(res.params),
        cov,
        spread,
        rms,
        mx,
        before,
        time.perf_counter() - t0,
    )
