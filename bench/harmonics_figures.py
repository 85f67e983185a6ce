"""The figures of docs/calibration.md, "Encoder angle harmonics", recomputed.

Run: ``.venv/bin/python bench/harmonics_figures.py [--seeds N]``.

Synthetic data from the tests' generator (tests/host/calib_synth.py: 3 seats
x 25 points and 30 ball-bar lengths, 5 um probing noise, a truth arm
perturbed by +-0.5 mm / +-0.05 deg) measured through one-read-head-like
encoder errors: harmonics 1 and 2 of 10 to 30 arcsec on every joint
(tests/host/test_calibration_harmonics.py makes the readings). Per seed: the
RMS point error against the truth over 2,000 poses in the data's joint ranges
(after the base motion the data cannot see) of the arm alone on the same
data without harmonics (the baseline), of the arm alone (DH only), of
``harmonics=2`` and of ``harmonics="auto"``; the chi-square verdicts; the time
of each solve. One JSON object per line.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "host"))

import numpy as np
from aacmm.calibration import calibrate
from aacmm.calibration.parameters import CalibParams
from aacmm.errmodel import ErrorModel
from benchjson import emit
from calib_synth import random_poses, synthetic
from test_calibration import SIGMA, observations
from test_calibration_harmonics import head_errors, readings, rms_vs_truth, with_readings


def study(seeds: int) -> None:
    ratios_full, ratios_dh, ratios_auto = [], [], []
    for seed in range(seeds):
        em = head_errors(np.random.default_rng(500 + seed))
        clean = synthetic(2000 + seed, noise_mm=SIGMA)
        s = with_readings(synthetic(2000 + seed, noise_mm=SIGMA), em)
        obs = observations(s)
        t = {}
        t0 = time.perf_counter()
        base = calibrate(observations(clean))
        t["dh_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        full = calibrate(obs, harmonics=2)
        t["k2_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        auto = calibrate(obs, harmonics="auto")
        t["auto_s"] = time.perf_counter() - t0
        dh = calibrate(obs)
        q = random_poses(np.random.default_rng(9), 2000, (0.3, 1.4), (0.6, 1.8))
        r = readings(em, q)
        b = rms_vs_truth(base.params, clean.truth, ErrorModel.none(6), q)
        f = rms_vs_truth(full.params, s.truth, em, r)
        a = rms_vs_truth(auto.params, s.truth, em, r)
        d = rms_vs_truth(dh.params, s.truth, em, r)
        ratios_full.append(f / b)
        ratios_auto.append(a / b)
        ratios_dh.append(d / b)
        ks = auto.params.harmonics if isinstance(auto.params, CalibParams) else (0,) * 6
        emit(
            figure="harmonics_seed",
            seed=seed,
            rms_um={"baseline": b * 1e3, "k2": f * 1e3, "auto": a * 1e3, "dh_only": d * 1e3},
            auto_k=list(ks),
            chi2_ratio={
                "baseline": base.chi_square.ratio,
                "k2": full.chi_square.ratio,
                "auto": auto.chi_square.ratio,
                "dh_only": dh.chi_square.ratio,
            },
            verdict={
                "baseline": base.chi_square.verdict,
                "k2": full.chi_square.verdict,
                "auto": auto.chi_square.verdict,
                "dh_only": dh.chi_square.verdict,
            },
            **t,
        )
    emit(
        figure="harmonics_summary",
        seeds=seeds,
        k2_over_baseline={"median": float(np.median(ratios_full)), "max": max(ratios_full)},
        auto_over_baseline={"median": float(np.median(ratios_auto)), "max": max(ratios_auto)},
        dh_only_over_baseline={"median": float(np.median(ratios_dh)), "min": min(ratios_dh)},
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=10)
    study(ap.parse_args().seeds)


if __name__ == "__main__":
    main()
