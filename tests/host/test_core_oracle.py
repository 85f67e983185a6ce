"""An independent numpy implementation of the arm model, used as the oracle.

The C core builds the Jacobian geometrically (cross products of the joint
axes with lever arms, one pass down the chain). This oracle does it the
other way: the paper's Eq. 2-3 as a product of 4x4 homogeneous matrices, and
each Jacobian column as the same product with one factor replaced by its
derivative with respect to that parameter. Shared by test_core, test_mc and
test_uncertainty; its own tests check it against central differences.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pytest
from aacmm.core import Params

F = npt.NDArray[np.float64]


def _dh(theta: F, alpha: float, d: float, a: float) -> tuple[F, ...]:
    """T_{i-1,i} (n,4,4) of Eq. 2 and its derivatives by theta, alpha, d, a."""
    n = theta.shape[0]
    c, s = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    t = np.zeros((n, 4, 4))
    t[:, 0, 0], t[:, 0, 1], t[:, 0, 2], t[:, 0, 3] = c, -s * ca, s * sa, a * c
    t[:, 1, 0], t[:, 1, 1], t[:, 1, 2], t[:, 1, 3] = s, c * ca, -c * sa, a * s
    t[:, 2, 1], t[:, 2, 2], t[:, 2, 3] = sa, ca, d
    t[:, 3, 3] = 1.0
    dt = np.zeros((n, 4, 4))  # d/dtheta
    dt[:, 0, 0], dt[:, 0, 1], dt[:, 0, 2], dt[:, 0, 3] = -s, -c * ca, c * sa, -a * s
    dt[:, 1, 0], dt[:, 1, 1], dt[:, 1, 2], dt[:, 1, 3] = c, -s * ca, s * sa, a * c
    dal = np.zeros((n, 4, 4))  # d/dalpha
    dal[:, 0, 1], dal[:, 0, 2] = s * sa, s * ca
    dal[:, 1, 1], dal[:, 1, 2] = -c * sa, -c * ca
    dal[:, 2, 1], dal[:, 2, 2] = ca, -sa
    dd = np.zeros((n, 4, 4))
    dd[:, 2, 3] = 1.0
    da = np.zeros((n, 4, 4))
    da[:, 0, 3], da[:, 1, 3] = c, s
    return t, dt, dal, dd, da


def numpy_point_jacobian(params: Params, theta: npt.ArrayLike) -> tuple[F, F]:
    """Points (n,3) and Jacobians (n,3,25) by matrix products (Eq. 2-3, 10)."""
    th = np.asarray(theta, dtype=np.float64).reshape(-1, 6)
    n = th.shape[0]
    mats = [
        _dh(
            th[:, i] + params.theta_offset_rad[i],
            params.alpha_rad[i],
            params.d_mm[i],
            params.a_mm[i],
        )
        for i in range(6)
    ]
    tool = np.array([0.0, 0.0, params.l_mm, 1.0])
    # prefix[i] = T_0..T_{i-1}, suffix[i] = T_{i+1}..T_6 applied to the tool point
    prefix = [np.broadcast_to(np.eye(4), (n, 4, 4))]
    for i in range(6):
        prefix.append(prefix[-1] @ mats[i][0])
    suffix = [np.broadcast_to(tool, (n, 4))] * 7
    for i in range(5, -1, -1):
        suffix[i] = np.einsum("nij,nj->ni", mats[i][0], suffix[i + 1])
    p = suffix[0][:, :3]
    jac = np.zeros((n, 3, 25))
    for i in range(6):
        for k, col in ((1, i), (2, 6 + i), (3, 12 + i), (4, 18 + i)):
            v = np.einsum("nij,nj->ni", mats[i][k], suffix[i + 1])
            jac[:, :, col] = np.einsum("nij,nj->ni", prefix[i], v)[:, :3]
    jac[:, :, 24] = np.einsum("nij,j->ni", prefix[6], np.array([0.0, 0.0, 1.0, 0.0]))[:, :3]
    return p, jac


def random_params(rng: np.random.Generator) -> Params:
    """A general arm near the paper's (non-zero a, offsets, twists not 90 deg)."""
    base = Params()
    return Params(
        theta_offset_rad=tuple(rng.uniform(-0.3, 0.3, 6)),
        alpha_rad=tuple(np.array(base.alpha_rad) + rng.uniform(-0.2, 0.2, 6)),
        d_mm=tuple(np.array(base.d_mm) + rng.uniform(-20, 20, 6)),
        a_mm=tuple(rng.uniform(-30, 30, 6)),
        l_mm=base.l_mm + float(rng.uniform(-10, 10)),
    )


@pytest.mark.timeout(30)
def test_oracle_matches_central_differences() -> None:
    rng = np.random.default_rng(7)
    prm = random_params(rng)
    th = rng.uniform(-np.pi, np.pi, (20, 6))
    _, jac = numpy_point_jacobian(prm, th)
    v = prm.to_vector()
    h = 1e-6
    for k in range(25):
        e = np.zeros(25)
        e[k] = h
        pp, _ = numpy_point_jacobian(Params.from_vector(v + e), th)
        pm, _ = numpy_point_jacobian(Params.from_vector(v - e), th)
        fd = (pp - pm) / (2 * h)
        assert np.allclose(fd, jac[:, :, k], rtol=1e-6, atol=1e-6), k


@pytest.mark.timeout(30)
def test_oracle_paper_pose_by_hand() -> None:
    # all joints at 0, alpha = 90 deg: each factor of Eq. 2 written out by hand
    p, _ = numpy_point_jacobian(Params(), np.zeros((1, 6)))
    t = np.eye(4)
    for d in Params().d_mm:
        t = t @ np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, d], [0, 0, 0, 1]], dtype=float)
    assert np.allclose(p[0], (t @ np.array([0, 0, 183.5, 1.0]))[:3])
