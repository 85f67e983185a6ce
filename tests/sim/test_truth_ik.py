"""The truth model, its file, the random truth, the inverse kinematics and the
articulation spread (aacmm.simulation: truth, ik, articulation).

Independent references: the core's own encoder conversion
(``aacmm.core.counts_to_angles``) for the encoder model; the core's forward
model for every IK result (the IK only ever uses Jacobian columns); the
ranges stated in docs/simulator.md for the random perturbation.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from aacmm.core import EncoderConfig, Model, Params, counts_to_angles
from aacmm.records.paramfile import load_param_file
from aacmm.simulation.articulation import (
    Approach,
    candidates,
    joint_spread_deg,
    most_different,
)
from aacmm.simulation.encgrade import GRADES
from aacmm.simulation.ik import ARM_LIMITS, Arm, solve, wrap
from aacmm.simulation.perturb import RANDOM_SIZES
from aacmm.simulation.truth import (
    ARCSEC_RAD,
    ErrorSources,
    Truth,
    TruthError,
    load_truth,
    nominal_truth,
    random_truth,
)
from aacmm.simulation.truthspec import parse_truth

pytestmark = pytest.mark.timeout(120)
AACMM = Path(sys.executable).with_name("aacmm")


# ---------------------------------------------------------------- truth


def test_random_truth_sizes_and_reproducibility() -> None:
    a, b, c = random_truth(7), random_truth(7), random_truth(8)
    assert a == b and a != c
    nominal = Params().to_vector()
    delta = a.params.to_vector() - nominal
    ang = math.radians(RANDOM_SIZES.angle_deg)
    assert np.all(np.abs(delta[:12]) <= ang) and np.abs(delta[:12]).max() > 0.5 * ang
    assert np.all(np.abs(delta[12:]) <= RANDOM_SIZES.length_mm)
    assert np.abs(delta[12:]).max() > 0.5 * RANDOM_SIZES.length_mm
    lo, hi = GRADES["two-head"].amplitude_arcsec[0]
    assert all(lo <= x <= hi for x in a.errors.eccentricity_arcsec)
    sigma = RANDOM_SIZES.encoder_noise_arcsec * ARCSEC_RAD * 2**32 / (2 * math.pi)
    assert a.errors.encoder_noise_counts == pytest.approx((sigma,) * 6)
    assert a.errors.probing_sigma_um == RANDOM_SIZES.probing_sigma_um
    assert a.origin["kind"] == "random" and a.origin["seed"] == 7


def test_truth_file_round_trip_and_params_set_reads_it(tmp_path: Path) -> None:
    t = random_truth(3)
    path = tmp_path / "truth.toml"
    path.write_text(t.dumps())
    back = load_truth(path)
    assert back == t  # origin is not compared; everything else exactly
    assert back.origin["kind"] == "random" and back.origin["path"] == str(path)
    # `aacmm params set` reads the eight parameter keys of a truth file
    ps = load_param_file(path)
    assert ps.d_mm == t.params.d_mm and ps.counts_per_rev == t.encoders.counts_per_rev
    r = subprocess.run([str(AACMM), "params", "set", str(path), "--check"], capture_output=True)
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda d: d["eccentricity"].update(amplitude_arcsec=[1, 2, 3]), "amplitude_arcsec"),
        (lambda d: d["probing"].update(sigma_um=-1.0), "sigma_um"),
        (lambda d: d["probing"].update(bogus=1), "probing.bogus"),
        (lambda d: d.update(format="aacmm-truth-9"), "format"),
        (lambda d: d.pop("d_mm"), "missing d_mm"),
        (lambda d: d.update(extra_key=1), "extra_key"),
        (lambda d: d.update(encoder_noise=3), "encoder_noise must be a table"),
    ],
)
def test_bad_truth_files_name_the_key(tmp_path: Path, edit: object, needle: str) -> None:
    import tomli_w

    data = nominal_truth().to_mapping()
    edit(data)  # type: ignore[operator]
    path = tmp_path / "bad.toml"
    path.write_text(tomli_w.dumps(data))
    with pytest.raises(TruthError, match=needle) as info:
        load_truth(path)
    assert str(path) in str(info.value)


def test_parse_truth_specs(tmp_path: Path) -> None:
    assert parse_truth("nominal") == nominal_truth()
    assert parse_truth("nominal", cpr=1 << 20).encoders.counts_per_rev == (1 << 20,) * 6
    assert parse_truth("random:5") == random_truth(5)
    for bad in ("random:", "random:x", "random:-1", str(tmp_path / "none.toml")):
        with pytest.raises(TruthError):
            parse_truth(bad)


def test_encoder_model_matches_the_core() -> None:
    """counts -> core angles gives back theta + eccentricity, to the quantum."""
    rng = np.random.default_rng(1)
    enc = EncoderConfig((1 << 32, 1 << 20, 3600000, 1 << 32, 1 << 32, 1 << 24),
                        (0, 12345, 17, 1 << 31, 5, 99), (1, -1, 1, -1, 1, 1))  # fmt: skip
    errors = ErrorSources(
        eccentricity_arcsec=(2.0, 0.0, 1.0, 5.0, 0.5, 3.0),
        eccentricity_phase_rad=(0.1, 0.0, 2.0, -1.0, 3.0, 0.5),
    )
    t = Truth(encoders=enc, errors=errors)
    theta = rng.uniform(-math.pi * 0.999, math.pi * 0.999, (500, 6))
    counts = t.counts(theta)
    got = counts_to_angles(counts, enc)
    quantum = 2 * math.pi / np.asarray(enc.counts_per_rev)
    want = theta + t.reading_error_rad(theta)
    assert np.all(np.abs(wrap(got - want)) <= 0.5 * quantum * (1 + 1e-9))
    # the eccentricity is really there: a perfect encoder differs by up to its amplitude
    ecc = np.abs(wrap(got - theta)).max(axis=0)
    amp = np.asarray(errors.eccentricity_arcsec) * ARCSEC_RAD
    assert np.all(ecc <= amp + quantum) and ecc[0] > 0.9 * amp[0]
    # noise: Gaussian counts of the stated sigma
    noisy = Truth(errors=ErrorSources(encoder_noise_counts=(1000.0,) * 6))
    n = noisy.counts(np.zeros((4000, 6)), np.random.default_rng(2)).astype(np.float64)
    signed = np.where(n >= 2**31, n - 2**32, n)
    assert signed.std() == pytest.approx(1000.0, rel=0.05)


def test_probing_noise_is_isotropic_gaussian() -> None:
    t = Truth(errors=ErrorSources(probing_sigma_um=5.0))
    rng = np.random.default_rng(3)
    d = np.array([t.probing_offset_mm(rng) for _ in range(4000)])
    assert d.std(axis=0) == pytest.approx([0.005] * 3, rel=0.06)
    assert np.abs(d.mean(axis=0)).max() < 0.0005
    assert np.all(nominal_truth().probing_offset_mm(rng) == 0)


# ---------------------------------------------------------------- inverse kinematics


def test_ik_puts_the_true_tip_within_a_nanometre() -> None:
    """Random targets in the working volume, random truths: |tip - target| <= 1e-6 mm
    on the core's forward model at the unquantised angles (the IK's own claim: 1e-9)."""
    rng = np.random.default_rng(11)
    worst = 0.0
    solved = 0
    for k in range(40):
        truth = random_truth(k)
        arm = Arm(truth.params)
        model = Model(truth.params)  # an independent evaluation of the result
        r, az, z = rng.uniform(500, 1300), rng.uniform(-math.pi, math.pi), rng.uniform(-400, 600)
        target = np.array([r * math.cos(az), r * math.sin(az), z])
        sol = solve(arm, target, ARM_LIMITS.sample(rng))
        if not sol.converged:
            continue
        solved += 1
        err = float(np.linalg.norm(model.point(sol.theta) - target))
        worst = max(worst, err)
        assert sol.error_mm == pytest.approx(err, abs=1e-12)
    assert solved >= 36
    assert worst <= 1e-6


def test_ik_stylus_goal_and_limits() -> None:
    arm = Arm(Params())
    rng = np.random.default_rng(4)
    target = np.array([800.0, 100.0, -100.0])
    approach = Approach((0.0, 0.0, 1.0), 40.0)
    for _ in range(10):
        want = approach.draw(rng)
        assert approach.tilt_deg(want) <= 40.0 + 1e-9
        sol = solve(arm, target, ARM_LIMITS.sample(rng), stylus=want)
        if sol.converged and sol.within_limits:
            assert math.degrees(sol.stylus_error_rad) < 1.0
            assert ARM_LIMITS.contains(sol.theta)


def test_articulations_spread() -> None:
    """25 articulations at one seat: every joint spread widely (the SPAT practice)."""
    arm = Arm(random_truth(1).params)
    rng = np.random.default_rng(5)
    target = (650.0, -350.0, -250.0)
    approach = Approach((0.0, 0.0, 1.0), 50.0)
    cands = candidates(arm, target, approach, 50, rng)
    assert len(cands) >= 45
    chosen = [cands[i] for i in most_different([s.theta for s in cands], 25)]
    spread = joint_spread_deg([s.theta for s in chosen])
    assert np.all(spread[[0, 2, 4]] > 180.0)  # the rolls all the way round
    assert np.all(spread[[1, 3, 5]] > 90.0)  # the hinges over much of their range
    for s in chosen:
        assert np.linalg.norm(arm.tip(s.theta) - target) <= 1e-9
        assert approach.tilt_deg(arm.stylus(s.theta)) <= 50.5
    # farthest-point selection spreads more than the first 25 found
    first = joint_spread_deg([s.theta for s in cands[:25]])
    assert spread.sum() >= first.sum()
    assert joint_spread_deg(np.zeros((1, 6))).tolist() == [0.0] * 6


def test_plan_poses_is_a_pure_function_on_target() -> None:
    from aacmm.plans import load_plan
    from aacmm.simulation.scenario import plan_poses

    plan = load_plan("iso10360-12")
    params = random_truth(5).params
    a = plan_poses(plan, params, seed=2)
    assert a.shape == (len(plan.slots), 6)
    assert np.array_equal(a, plan_poses(plan, params, seed=2))
    assert not np.array_equal(a, plan_poses(plan, params, seed=3))
    tips = Model(params).points(a)
    targets = np.array([s.target.tip_mm for s in plan.slots if s.target is not None])
    assert np.abs(tips - targets).max() <= 1e-9
    assert all(ARM_LIMITS.contains(q) for q in a)
