"""The error model on the device (issue 27): the pty simulator's corrected points.

The paper's arm and a 7-axis arm, each with K = 2 encoder harmonics on every
joint, are sent to the simulated device (its single-precision build) as
parameter sets built with ``aacmm.protocol.errwire.with_error_model``; every
point the device computes (COMPUTE, MEASURE) must agree with the host's
double-precision model (``aacmm.errmodel.points`` of the set's own error
model) within the float path's class (1e-3 mm), and with a correction
computed here from its definition (libm cos and sin of k q, no recurrence)
through ``aacmm.core``. The structural Jacobian columns the device sends are
those of the host's extended Jacobian. Bad error models never reach the wire.
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterator

import numpy as np
import pytest
from aacmm import core
from aacmm.arm import Arm
from aacmm.client import Client, connect
from aacmm.errmodel import ErrorModel, points, points_jacobians
from aacmm.errors import DeviceError
from aacmm.protocol import (
    BuildFlags,
    ComputeRequest,
    ComputeResult,
    MsgType,
    ParamSet,
    SampleStatus,
)
from aacmm.protocol.errwire import error_model, with_error_model
from aacmm.protocol.status import Status
from simproc import Sim
from test_loopback_arms import arm7, encoders

FLOAT_PATH_BOUND_MM = 1e-3


def harmonics_k2(n: int, seed: int) -> ErrorModel:
    """K = 2 on every joint, coefficients up to 0.4 mrad (an eccentric encoder)."""
    rng = random.Random(seed)
    return ErrorModel(
        harmonics=tuple(
            tuple((rng.uniform(-4e-4, 4e-4), rng.uniform(-4e-4, 4e-4)) for _ in range(2))
            for _ in range(n)
        )
    )


def by_definition(arm: Arm, ps: ParamSet, theta: np.ndarray) -> np.ndarray:
    """The corrected point from the formula: q + sum_k c_k cos kq + s_k sin kq."""
    q = theta.copy()
    for i in range(arm.n_joints):
        for k, (c, s) in enumerate(zip(ps.harm_cos[i], ps.harm_sin[i], strict=True), start=1):
            q[i] += 1e-7 * (c * math.cos(k * theta[i]) + s * math.sin(k * theta[i]))
    return core.Model(arm).point(q)


@pytest.fixture(scope="module")
def sim() -> Iterator[Sim]:
    s = Sim("--serial", "pty", "--motion", "static", "--seed", "5")
    yield s
    assert s.stop() == 0, s.stderr_lines


@pytest.fixture
def client(sim: Sim) -> Iterator[Client]:
    with connect(sim.serial_url, timeout=2.0, retries=2) as c:
        yield c
        c.restore_defaults()


@pytest.mark.parametrize("make", [Arm.paper, arm7], ids=["paper", "7-axis"])
def test_device_corrected_points_agree_with_the_host_model(client: Client, make: object) -> None:
    arm = make()  # type: ignore[operator]
    enc = encoders(arm)
    ps = with_error_model(ParamSet.from_arm(arm, enc), harmonics_k2(arm.n_joints, 7))
    assert ps.harmonics == (2,) * arm.n_joints
    client.set_params(ps)
    assert client.get_params() == ps
    em = error_model(ps)  # what the device holds, exactly
    model = core.Model(arm)
    rng = random.Random(11)
    worst = 0.0
    moved = 0.0
    for i in range(24):
        counts = tuple(rng.randrange(c) for c in enc.counts_per_rev)
        r = client.compute(counts, jacobian=i % 4 == 0)
        assert r.status & SampleStatus.POINT_VALID
        theta = core.counts_to_angles(np.array([counts], dtype=np.int64), enc)
        want = points(model, em, theta)[0]
        got = np.array(r.point_mm)
        worst = max(worst, float(np.max(np.abs(got - want))))
        assert np.max(np.abs(want - by_definition(arm, ps, theta[0]))) < 1e-9
        moved = max(moved, float(np.max(np.abs(got - model.point(theta[0])))))
        if r.jacobian is not None:
            _, jac = points_jacobians(model, em, theta)
            structural = jac[0][:, : arm.n_params]  # the device's columns
            assert np.allclose(np.asarray(r.jacobian), structural, rtol=1e-4, atol=1e-3)
    assert worst < FLOAT_PATH_BOUND_MM
    assert moved > 0.05  # the correction matters far beyond the class


def test_error_models_the_wire_cannot_carry_are_refused_on_the_host() -> None:
    ps = ParamSet.from_arm(Arm.paper())
    big = ErrorModel(harmonics=(((4e-3, 0.0),),) + ((),) * 5)  # beyond +-3.2767 mrad
    with pytest.raises(ValueError, match="joint 1 c_1"):
        with_error_model(ps, big)
    with pytest.raises(ValueError, match="6-joint"):
        with_error_model(ps, ErrorModel.none(7))
    trefs = ErrorModel(harmonics=((),) * 6, cte_per_k=(2.3e-5,) * 6, tref_c=(20.0,) * 5 + (21.0,))
    with pytest.raises(ValueError, match="one reference temperature"):
        with_error_model(ps, trefs)
    with pytest.raises(ValueError, match="finite"):
        ErrorModel(harmonics=(((math.nan, 0.0),),) + ((),) * 5)
    with pytest.raises(ValueError, match="at most 4"):
        ErrorModel(harmonics=(((1e-5, 0.0),) * 5,) + ((),) * 5)
    # an error model that changes nothing: today's bytes
    assert with_error_model(ps, ErrorModel.none(6)) == ps


def test_thermal_block_round_trips_and_the_device_computes_at_the_link_temperatures(
    client: Client,
) -> None:
    """The thermal block (issue 27) on the wire, then on the simulator, which
    reads link temperatures (INFO TEMPERATURES): COMPUTE at the request's
    temperatures agrees with the host's double-precision model at them
    (``aacmm.errmodel.points`` with ``temp_c``) within the float path's class,
    and moves the point far beyond it; a simulator without sensors refuses the
    set (ERR_UNSUPPORTED) and keeps its own."""
    arm = Arm.paper()
    enc = encoders(arm)
    ps = ParamSet.from_arm(arm, enc)
    ctes = (2.3e-5, 2.2e-5, 1.2e-5, 2.4e-5, 5e-7, 2.3e-5)
    em = ErrorModel(harmonics=((),) * 6, cte_per_k=ctes, tref_c=(20.0,) * 6)
    wire = with_error_model(ps, em)
    assert wire.cte == (2300, 2200, 1200, 2400, 50, 2300) and wire.ref_temp == 2000
    back = error_model(wire)
    assert back.cte_per_k == pytest.approx(em.cte_per_k, rel=1e-12)
    assert back.tref_c == em.tref_c
    assert client.info().build_flags & BuildFlags.TEMPERATURES
    client.set_params(wire)
    assert client.get_params() == wire
    model = core.Model(arm)
    temps = (3150, 2875, -1020, 6025, 2000, 8500)  # 0.01 degC
    temp_c = np.array([t / 100.0 for t in temps])
    rng = random.Random(27)
    worst = 0.0
    moved = 0.0
    for _ in range(12):
        counts = tuple(rng.randrange(c) for c in enc.counts_per_rev)
        r = client.request(MsgType.COMPUTE_REQ, ComputeRequest(counts, temp=temps)).payload
        assert isinstance(r, ComputeResult) and r.temperatures
        assert r.status & SampleStatus.POINT_VALID
        theta = core.counts_to_angles(np.array([counts], dtype=np.int64), enc)
        want = points(model, back, theta, temp_c)[0]
        got = np.array(r.point_mm)
        worst = max(worst, float(np.max(np.abs(got - want))))
        moved = max(moved, float(np.max(np.abs(got - points(model, back, theta)[0]))))
    assert worst < FLOAT_PATH_BOUND_MM
    assert moved > 0.05
    s = Sim("--serial", "pty", "--no-temperature-sensors")
    try:
        with connect(s.serial_url, timeout=2.0, retries=2) as c:
            assert not c.info().build_flags & BuildFlags.TEMPERATURES
            with pytest.raises(DeviceError) as ei:
                c.set_params(wire)
            assert ei.value.status == Status.ERR_UNSUPPORTED
            assert not c.get_params().cte  # the set in use is unchanged
    finally:
        assert s.stop() == 0, s.stderr_lines
