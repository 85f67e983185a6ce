"""The figures of docs/calibration.md, recomputed.

Run: ``.venv/bin/python bench/calibration_figures.py``.

Synthetic data from the tests' generator (tests/host/calib_synth.py: exact
inverse kinematics on a truth arm perturbed by +-0.5 mm / +-0.05 deg);
prints one JSON object per figure. ``--runs N`` sets the number of seeded
runs of the statistical study (default 200, about a minute on one core).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "host"))

import numpy as np
from aacmm.calibration import Problem, analyse, calibrate, predicted_covariance
from aacmm.core import PARAM_NAMES, Model, Params
from benchjson import emit
from calib_synth import bar_poses, synthetic
from test_calibration import SIGMA, combos, observations, seeded_study


def spectra() -> None:
    s = synthetic(1)
    for name, obs in (
        ("cones+lengths", observations(s)),
        ("cones", observations(s, lengths=False)),
    ):
        res = calibrate(obs)
        idn = res.identifiability
        start = Problem(obs).evaluate(Params())
        emit(
            figure="identifiability",
            data=name,
            rank=idn.rank,
            singular_values=[float(f"{v:.3g}") for v in idn.singular_values],
            null=[d.kind for d in idn.null],
            held=list(res.held),
            condition_number=round(idn.condition_number, 2),
            o1=float(f"{idn.o1:.3g}"),
            noise_amplification=float(f"{idn.noise_amplification:.3g}"),
            rank_at_start_without_residual_tolerance=analyse(start, kappa=0.0).rank,
            spurious_at_start=float(f"{analyse(start, kappa=0.0).singular_values[idn.rank]:.3g}"),
            rank_at_start_residual_tolerance=analyse(start).rank,
        )


def predicted() -> None:
    s = synthetic(17)
    obs = observations(s)
    cov, idn = predicted_covariance(obs, s.truth)
    sd = np.sqrt(np.diag(cov))
    lengths = list(range(12, 25))
    rng = np.random.default_rng(3)
    qa, qb, _ = bar_poses(Model(s.truth), rng, 200)
    m = Model(s.truth)
    pa, ja = m.points_jacobians(qa)
    pb, jb = m.points_jacobians(qb)
    u = (pa - pb) / np.linalg.norm(pa - pb, axis=1, keepdims=True)
    g = np.einsum("ka,kac->kc", u, ja - jb)
    ul = np.sqrt(np.einsum("kc,cd,kd->k", g, cov, g))
    emit(
        figure="predicted precision",
        data="3 cones x 25 + 30 lengths 0.5-1 m, 5 um",
        rank=idn.rank,
        worst_length_parameter_sd_um=round(float(sd[lengths].max()) * 1e3, 2),
        worst_length_parameter=PARAM_NAMES[lengths[int(np.argmax(sd[lengths]))]],
        worst_angle_sd_arcsec=round(float(sd[:12].max()) / (math.pi / 648000), 2),
        length_error_sd_um_mean=round(float(ul.mean()) * 1e3, 2),
        length_error_sd_um_max=round(float(ul.max()) * 1e3, 2),
    )


def exact() -> None:
    for strategy in ("fix", "min-norm"):
        s = synthetic(3)
        res = calibrate(observations(s), strategy=strategy)
        emit(
            figure="noise-free recovery",
            strategy=strategy,
            max_error_identifiable=float(
                f"{np.abs(combos(res.params) - combos(s.truth)).max():.2g}"
            ),
        )


def study(runs: int) -> None:
    st = seeded_study(runs)
    pooled = float(np.sqrt(np.mean(st.noisy_errors_mm**2)))
    emit(
        figure="seeded study",
        runs=runs,
        within_3_sigma_min=round(float(st.within_3_sigma.min()), 3),
        within_3_sigma_mean=round(float(st.within_3_sigma.mean()), 4),
        held_out_rms_vs_truth_um_median=round(float(np.median(st.rms_vs_truth_mm)) * 1e3, 2),
        held_out_rms_vs_truth_um_max=round(float(st.rms_vs_truth_mm.max()) * 1e3, 2),
        noisy_held_out_rms_um=round(pooled * 1e3, 2),
        noise_floor_um=round(math.sqrt(2) * SIGMA * 1e3, 2),
        chi2_ratio_median=round(float(np.median(st.chi2_ratio)), 3),
    )


def eccentricity() -> None:
    e, phi, joint = 40e-6, 0.7, 2
    for seed in (7, 8, 9):
        s = synthetic(seed, noise_mm=SIGMA)

        def reading(q: np.ndarray) -> np.ndarray:
            r = q.copy()
            for _ in range(4):
                r[:, joint] = q[:, joint] - e * np.sin(r[:, joint] + phi)
            return r

        s.cone_q = [reading(q) for q in s.cone_q]
        s.length_qa, s.length_qb = reading(s.length_qa), reading(s.length_qb)
        chi = calibrate(observations(s)).chi_square
        emit(
            figure="unmodelled eccentricity",
            seed=seed,
            joint=joint + 1,
            amplitude_urad=e * 1e6,
            verdict=chi.verdict,
            chi2_ratio=round(chi.ratio, 2),
            p_value=float(f"{chi.p_value:.2g}"),
            suspects=[(x.name, round(x.amplitude * 1e6, 1)) for x in chi.suspects],
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=200)
    args = ap.parse_args()
    spectra()
    predicted()
    exact()
    eccentricity()
    study(args.runs)


if __name__ == "__main__":
    main()
