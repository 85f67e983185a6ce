"""The simulated arm at link temperatures (issue 27, item 2): ``params_at``, the
operator's poses solved on the warm true arm, and the control channel's ``temps``.

Independent references: the true point at temperatures from the core's thermal
error model (:func:`aacmm.simulation.thermal.true_points`, the C core scaling the
lengths itself) against the plain model of the arm ``params_at`` scaled here in
Python; the operator's probed points against ``true_points`` at the angles it
chose; the ``temps`` line as docs/simulator.md writes it.
"""

from __future__ import annotations

import socket
from dataclasses import replace

import numpy as np
import pytest
from aacmm.core import Model
from aacmm.models import load_model
from aacmm.simulation.control import ControlChannel
from aacmm.simulation.operator import FAST, Operator, RecordingChannel
from aacmm.simulation.thermal import (
    default_materials,
    params_at,
    random_profile,
    true_points,
)
from aacmm.simulation.truth import model_truth, random_truth


def _poses(rng: np.random.Generator, n: int, joints: int) -> np.ndarray:
    return rng.uniform(-np.pi, np.pi, (n, joints))


@pytest.mark.parametrize("temps", [(28.0,) * 6, (35.0, 10.0, 20.0, 28.0, -5.0, 60.0)])
def test_params_at_is_the_core_thermal_model(temps: tuple[float, ...]) -> None:
    truth = random_truth(4, thermal=True)
    q = _poses(np.random.default_rng(1), 200, 6)
    warm = Model(params_at(truth.params, truth.thermal, temps)).points(q)
    np.testing.assert_allclose(warm, true_points(truth, q, np.array(temps)), atol=1e-9)
    assert np.abs(warm - Model(truth.params).points(q)).max() > 0.01  # the lengths moved


def test_params_at_any_arm() -> None:
    model = load_model("commercial7")
    base = model_truth(3, model)
    profile = random_profile(np.random.default_rng(2), default_materials(base.params))
    truth = replace(base, thermal=profile)
    temps = tuple(20.0 + 3.0 * i for i in range(7))
    q = _poses(np.random.default_rng(5), 100, 7)
    warm = Model(params_at(truth.params, truth.thermal, temps)).points(q)
    np.testing.assert_allclose(warm, true_points(truth, q, np.array(temps)), atol=1e-9)
    # without a profile the arm is the same at every temperature
    assert params_at(base.params, None, temps) is base.params
    with pytest.raises(ValueError, match="need 7 link temperatures"):
        params_at(truth.params, truth.thermal, (28.0,) * 6)
    with pytest.raises(ValueError, match=r"-40 \.\. 85"):
        params_at(truth.params, truth.thermal, (90.0,) * 7)


def test_operator_probes_on_the_warm_arm() -> None:
    """The operator at 28 degC puts the warm true tip on its targets: true_points at the
    angles of each press (the core's scaling) is the probed point within 1e-9 mm, and
    the cold arm at the same angles misses it by the links' growth."""
    truth = random_truth(7, thermal=True)
    temps = (28.0,) * 6
    op = Operator(RecordingChannel(), truth, np.random.default_rng(3), FAST, temperatures_c=temps)
    rng = np.random.default_rng(8)
    home = op.arm.tip(op.theta)
    for k in range(12):
        target = home + rng.uniform(-150.0, 150.0, 3)
        theta, err = op.reach(target, op.theta)
        assert err < 1e-9
        op.probe(target, theta, f"p{k}")
    theta = np.array([p.theta_rad for p in op.presses])
    probed = np.array([p.probed_mm for p in op.presses])
    hot = true_points(truth, theta, np.array(temps))
    assert np.abs(hot - probed).max() < 1e-9
    cold = true_points(truth, theta)
    assert np.linalg.norm(cold - probed, axis=1).min() > 0.01


def test_control_temps_line() -> None:
    ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
    chan = ControlChannel(ours)
    try:
        chan.set_temperatures([28.0] * 6)
        chan.set_temperatures([20.0, 21.5, None, 22.25, 23.0, 24.0, 25.125])
        chan.set_temperatures([19.5])
        chan.set_temperatures([21.0, 22.0, 23.0, 24.0, 25.0])  # a 5-axis arm: six values
        theirs.settimeout(2.0)
        data = b""
        while data.count(b"\n") < 4:
            data += theirs.recv(4096)
        assert data.decode().splitlines() == [
            "temps 28.00 28.00 28.00 28.00 28.00 28.00",
            "temps 20.00 21.50 - 22.25 23.00 24.00 25.12",
            "temps 19.50",
            "temps 21.00 22.00 23.00 24.00 25.00 21.00",
        ]
        for bad in ([], [90.0], [float("nan")], [20.0] * 8):
            with pytest.raises(ValueError):
                chan.set_temperatures(bad)
    finally:
        chan.close()
        theirs.close()


def test_operator_follows_a_temperature_profile() -> None:
    """``aacmm sim --temperature 20:30:2`` (every link 20 -> 30 degC over 2 minutes): at
    every probe the operator rescales the true arm to the profile's temperature then
    (a clock the test sets) and tells the device; each probed point is the warm truth's
    at that temperature (true_points) within 1e-9 mm."""
    from aacmm.commands.simtruth import temperature_profile

    profile = temperature_profile("20:30:2", 6)
    want = [20.0, 20.0, 25.0, 30.0, 30.0]
    assert [profile(s) for s in (-5.0, 0.0, 60.0, 120.0, 600.0)] == [[t] * 6 for t in want]
    truth = random_truth(9, thermal=True)
    now = [0.0]
    chan = RecordingChannel()
    op = Operator(
        chan,
        truth,
        np.random.default_rng(4),
        FAST,
        temperatures_c=[20.0] * 6,
        temperatures_at=profile,
        clock=lambda: now[0],
    )
    home = op.arm.tip(op.theta)
    at = []
    for k, t_s in enumerate((0.0, 30.0, 60.0, 90.0, 120.0, 150.0)):
        now[0] = t_s
        target = home + np.array([40.0 * k, -20.0 * k, 10.0 * k])
        theta, _ = op.reach(target, op.theta)
        op.probe(target, theta, f"p{k}")
        at.append(profile(t_s)[0])
    assert [p.extra["temperatures_c"] for p in op.presses] == [[t] * 6 for t in at]
    assert chan.temperatures == [(t,) * 6 for t in (22.5, 25.0, 27.5, 30.0)]  # changes only
    for p, t in zip(op.presses, at, strict=True):
        hot = true_points(truth, p.theta_rad[None, :], np.full(6, t))[0]
        assert np.linalg.norm(hot - p.probed_mm) < 1e-9


def test_a_temperature_profile_per_link() -> None:
    """``--temperature 18,19,20,21,22,23:28:2``: each link from its own start to the
    common end; the operator's probed points are the warm truth's at each link's
    temperature then. Bad profiles: one line, exit 2 (UsageError)."""
    from aacmm.commands.exitcodes import UsageError
    from aacmm.commands.simtruth import temperature_profile

    profile = temperature_profile("18,19,20,21,22,23:28:2", 6)
    assert profile(0.0) == [18.0, 19.0, 20.0, 21.0, 22.0, 23.0]
    np.testing.assert_allclose(profile(60.0), [23.0, 23.5, 24.0, 24.5, 25.0, 25.5])
    assert profile(500.0) == [28.0] * 6
    down = temperature_profile("30:20,21,22,23,24,25:1", 6)
    np.testing.assert_allclose(down(30.0), [25.0, 25.5, 26.0, 26.5, 27.0, 27.5])
    assert temperature_profile("18,28:20:1") is not None  # count checked with the arm
    for bad, why in (
        ("18,19:28:2", "give one temperature for every link or 6"),
        ("18:28,29,30:2", "give one temperature for every link or 6"),
        ("18,x,20,21,22,23:28:2", "must be a number within -40 .. 85"),
        ("18:90:2", "must be a number within -40 .. 85"),
        ("18:28:0", "MINUTES must be in"),
        ("18:28", "a profile is START:END:MINUTES"),
    ):
        with pytest.raises(UsageError, match=why):
            temperature_profile(bad, 6)
    with pytest.raises(UsageError, match="START and END give 2 and 3"):
        temperature_profile("18,19:20,21,22:1")
    truth = random_truth(9, thermal=True)
    now = [0.0]
    op = Operator(
        RecordingChannel(),
        truth,
        np.random.default_rng(4),
        FAST,
        temperatures_c=profile(0.0),
        temperatures_at=profile,
        clock=lambda: now[0],
    )
    home = op.arm.tip(op.theta)
    for k, t_s in enumerate((0.0, 60.0, 120.0)):
        now[0] = t_s
        target = home + np.array([30.0 * k, -10.0 * k, 20.0 * k])
        theta, _ = op.reach(target, op.theta)
        op.probe(target, theta, f"p{k}")
        temps = profile(t_s)
        p = op.presses[-1]
        np.testing.assert_allclose(np.asarray(p.extra["temperatures_c"], dtype=float), temps)
        hot = true_points(truth, p.theta_rad[None, :], np.array(temps))[0]
        assert np.linalg.norm(hot - p.probed_mm) < 1e-9
