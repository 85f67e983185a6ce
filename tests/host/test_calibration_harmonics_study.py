"""Issue 27, Done when 2: 200 seeded one-head truths on the shipped plan.

tests/host/harmonics_study.py generates each run's data in-process from a
random simulator truth (one-head encoders: harmonics 1 and 2 of 10-30 arcsec
on every joint) and its twin with ideal encoders, calibrates the arm with
``harmonics=2`` (the full model) and alone (DH only), and judges each
calibration as ``aacmm demo --check`` does (RMS length error over the reach,
noise-free readings, against the truth: :mod:`aacmm.simulation.truthcheck`).

How "within 1.5x of what the same calibration reaches on a truth without
harmonics, in the same run" is read: per run, the full model's RMS on the
one-head truth divided by the full model's RMS on the ideal-encoder twin
(same poses, same probing noise, same calibration settings); the criterion
holds for the worst of the 200 runs, not only for the median. That ratio is
what the encoders' harmonics cost once the model describes them. What
estimating the 24 coefficients costs in precision is another figure: the
full model on the one-head truth against the arm alone on the ideal twin
(median 2.5x, 95th percentile 6.0x, worst 8.8x on this plan, driven by joint
4's harmonics: docs/calibration.md, "200 one-head truths on the shipped plan");
it is asserted only as a regression bound (median at most 3x). DH only stays
at least 5x above the ideal twin's full-model RMS (and the full model's) in
every run.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from aacmm.calibration import calibrate
from aacmm.calibration.sessions import observations_from_plan
from aacmm.core import EncoderConfig, counts_to_angles
from aacmm.plans import load_plan
from aacmm.simulation.encgrade import encoder_grade
from aacmm.simulation.truth import random_truth
from aacmm.simulation.truthcheck import length_errors, reach_lengths
from harmonics_study import (
    COMBOS,
    GRADE,
    PLAN,
    Study,
    choreographies,
    ideal,
    measured_points,
    sample_angles,
    study,
    summary,
)

pytestmark = pytest.mark.timeout(600)
RUNS = 200


@pytest.fixture(scope="module")
def st() -> Study:
    return study(RUNS)


def test_the_grade_is_the_issues() -> None:
    # one-head: harmonics 1 and 2 of 10-30 arcsec each, on every joint
    assert encoder_grade(GRADE).amplitude_arcsec == ((10.0, 30.0), (10.0, 30.0))
    t = random_truth(7, grade=GRADE)
    amps = [t.errors.eccentricity_arcsec, *t.errors.harmonic_arcsec]
    assert t.errors.harmonic_orders == (2,) and len(amps) == 2
    assert all(10.0 <= a <= 30.0 for row in amps for a in row)
    twin = ideal(t)
    assert max(twin.errors.eccentricity_arcsec) == 0.0 and twin.errors.harmonic_orders == ()
    assert twin.params == t.params and twin.errors.probing_sigma_um == 2.0
    assert np.all(twin.reading_error_rad(np.linspace(0, 6, 60)[:, None] * np.ones(6)) == 0.0)


def test_full_model_within_1_5x_of_the_ideal_twin(st: Study) -> None:
    ratio = st.ratio("full", "base")
    assert ratio.max() <= 1.5, (np.median(ratio), ratio.max())
    # DH only: at least 5x above what the full model reaches without harmonics
    dh = st.ratio("dh", "base")
    assert dh.min() >= 5.0, dh.min()
    assert st.ratio("dh", "full").min() >= 5.0  # and above the full model itself
    # the precision the 24 coefficients cost against the arm alone on the ideal twin
    cost = st.ratio("full", "base_dh")
    assert np.median(cost) <= 3.0, np.median(cost)
    print(json.dumps({k: v for k, v in summary(st).items() if k != "per_run"}, indent=1))


def test_identifiable_combinations_within_3_sigma(st: Study) -> None:
    # the identifiable space: rank 45 of 49 (theta1, d1 and the tip's split held)
    assert {r.rank for r in st.runs} == {45}
    assert {r.held for r in st.runs} == {("theta1", "theta6", "alpha6", "d1")}
    frac = st.within_3_sigma()
    assert len(frac) == len(COMBOS) == 45
    assert frac.min() >= 0.97, dict(zip(COMBOS, frac, strict=True))


def test_chi_square_full_consistent_dh_flagged(st: Study) -> None:
    full, dh = st.verdicts("full"), st.verdicts("dh")
    ok = full.get("consistent", 0) + full.get("overstated", 0)
    assert ok >= 0.99 * RUNS - 2, full  # alpha = 0.001: almost never a false alarm
    assert dh == {"incomplete": RUNS}, dh


def test_the_criterion_fails_when_the_model_lacks_an_order() -> None:
    # the ratio is no formality: K = 1 leaves the second harmonic (10-30 arcsec) in the data
    plan = load_plan(PLAN)
    starts = choreographies(plan, 1)
    for seed in range(3):
        truth = random_truth(seed, grade=GRADE)
        clean = ideal(truth)
        q = sample_angles(plan, truth, np.random.default_rng(seed), starts)
        rms = {}
        for name, t, k in (("k1", truth, 1), ("base", clean, 2)):
            r = counts_to_angles(t.counts(q).astype(np.uint64), EncoderConfig())
            obs, _, _ = observations_from_plan(plan, r, truth.errors.probing_sigma_um * 1e-3)
            res = calibrate(obs, harmonics=k)
            check = reach_lengths(t, 500)
            rms[name] = length_errors(check, measured_points(res.params, check.counts)).rms_mm
            if name == "k1":
                assert res.chi_square.verdict == "incomplete"
        assert rms["k1"] >= 5 * rms["base"], rms
