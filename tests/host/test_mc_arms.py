"""aacmm.analysis.mc for arms other than the paper's (issue 26).

The coefficients of a 5-axis modified-DH arm with a beta and a 7-axis arm
against the mean |J| computed here from the numpy product-rule oracle of
tests/host/test_core_arm.py on the same poses (draw_poses); the paper's arm
given as an Arm gives the Params run's result bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from aacmm.analysis import mc, mc_poses
from aacmm.arm import Arm, Joint
from test_core_arm import oracle

pytestmark = pytest.mark.timeout(120)
D = math.radians


def five_axis() -> Arm:
    return Arm(
        joints=(
            Joint("modified", 0.0, 0.0, 210.0, 0.0),
            Joint("modified", 0.0, D(90.0), 0.0, 24.0),
            Joint("modified", 0.0, 0.0, 0.0, 260.0, D(0.02)),
            Joint("modified", 0.0, D(-90.0), 230.0, 0.0),
            Joint("modified", 0.0, D(90.0), 0.0, 0.0),
        ),
        tip="xyz",
        tip_mm=(110.0, 0.0, 0.0),
    )


def seven_axis() -> Arm:
    d = (300.0, 65.5, 650.0, 65.5, 600.0, 0.0, 100.0)
    return Arm(
        joints=tuple(Joint("standard", 0.0, D(90.0) if i < 6 else 0.0, x) for i, x in enumerate(d)),
        tip="xyz",
        tip_mm=(40.0, 0.0, 90.0),
    )


@pytest.mark.parametrize("make", [five_axis, seven_axis])
def test_coefficients_of_a_general_arm_against_the_oracle(make: object) -> None:
    assert callable(make)
    arm: Arm = make()
    n = 2000
    r = mc.error_transfer_coefficients(n, seed=11, params=arm, threads=2)
    assert r.param_names == arm.param_names
    assert r.mean_abs.shape == (3, arm.n_params) and len(r.joints) == arm.n_joints
    theta = mc_poses.draw_poses(n, seed=11, count=arm.n_joints)
    assert theta.shape == (n, arm.n_joints)
    jac = np.array([oracle(arm, q)[1] for q in theta])
    ref = np.abs(jac).mean(axis=0)
    assert np.allclose(r.mean_abs, ref, rtol=1e-9, atol=1e-9)
    ref_sd = np.abs(jac).std(axis=0, ddof=1)
    assert np.allclose(r.std_abs, ref_sd, rtol=1e-6, atol=1e-9)
    # the length columns (d, a, tip) move the point by unit vectors
    assert r.unit_norm_max_dev < 1e-12
    # the same poses given as a log
    logged = mc.coefficients_over_poses(theta, arm, threads=1)
    assert np.allclose(logged.mean_abs, r.mean_abs, rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="Table 2"):
        r.table2()
    with pytest.raises(ValueError, match=f"need {arm.n_joints} JointDistribution"):
        mc.error_transfer_coefficients(10, joints=(mc_poses.JointDistribution(),) * 6, params=arm)
    with pytest.raises(ValueError, match=rf"\(n, {arm.n_joints}\)"):
        mc.coefficients_over_poses(np.zeros((3, 6)), arm)


def test_the_paper_arm_as_an_arm_is_the_params_run() -> None:
    a = mc.error_transfer_coefficients(20_000, seed=2013, threads=2)
    b = mc.error_transfer_coefficients(20_000, seed=2013, params=Arm.paper(), threads=2)
    assert np.array_equal(a.mean_abs, b.mean_abs) and np.array_equal(a.sem, b.sem)
    assert np.array_equal(a.table2(), b.table2())
