"""Benchmarks of the calibration engine; one JSON object per line on stdout.

* calibration.solve: :func:`aacmm.calibration.calibrate` end to end
  (identifiability at start and solution, Levenberg-Marquardt, covariance,
  chi-square check, outlier test) on 1,000 and 100,000 observations (probed
  points): seats of 20-25 articulations and two-ended ball-bar positions on a
  perturbed Table 1 arm with 5 um probing noise, BLAS on one thread (one core).
* calibration.probe: the probe (tip) calibration from 50 points in 2 seats.

Data come from the tests' synthetic generator (tests/host/calib_synth.py:
exact inverse kinematics on a known truth); generating them is not timed.
``cpu`` is the process CPU time, ``wall`` the elapsed time (best of the repeats).
"""

from __future__ import annotations

import os
import sys
from functools import partial
from pathlib import Path

# one core, as the targets say (before numpy loads OpenBLAS)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "host"))

import numpy as np
from aacmm.calibration import Cone, LengthSet, Observations, calibrate
from aacmm.calibration.probe import calibrate_probe
from aacmm.core import Params
from benchjson import best_of, emit
from calib_synth import Synthetic, synthetic

SIGMA = 0.005


def observations(s: Synthetic) -> Observations:
    th = list(s.cone_q)
    cons: list[Cone | LengthSet] = []
    off = 0
    for i, q in enumerate(s.cone_q):
        cons.append(Cone(f"cone{i}", np.arange(off, off + len(q))))
        off += len(q)
    n = len(s.lengths_mm)
    if n:
        th += [s.length_qa, s.length_qb]
        for k in range(n):
            cons.append(
                LengthSet(
                    f"bar{k}",
                    float(s.lengths_mm[k]),
                    (np.array([off + k]),),
                    (np.array([off + n + k]),),
                )
            )
    q = np.vstack(th)
    return Observations(q, np.full(q.shape[0], SIGMA), tuple(cons))


def main() -> None:
    for cones, per_cone, lengths, repeats, target in (
        (40, 20, 100, 5, 1.0),
        (3200, 25, 10_000, 1, 30.0),
    ):
        s = synthetic(1, n_cones=cones, per_cone=per_cone, n_lengths=lengths, noise_mm=SIGMA)
        obs = observations(s)
        wall, cpu, r = best_of(partial(calibrate, obs), repeats, warm_up=True)
        emit(
            bench="calibration.solve",
            observations=obs.n_poses,
            residual_rows=int(r.after.r.size),
            seats=cones,
            lengths=lengths,
            rank=int(r.identifiability.rank),
            evaluations=len(r.history),
            wall_s=round(wall, 4),
            cpu_s=round(cpu, 4),
            target_s=target,
            blas_threads=os.environ.get("OPENBLAS_NUM_THREADS"),
        )
    # an arm known but for its tip: the start is the truth with the nominal tip
    s = synthetic(2, n_cones=2, per_cone=25, n_lengths=0, noise_mm=SIGMA)
    obs = observations(s)
    v = s.truth.to_vector()
    v[[5, 11, 17, 23, 24]] = Params().to_vector()[[5, 11, 17, 23, 24]]
    start = Params.from_vector(v)
    wall, cpu, pr = best_of(lambda: calibrate_probe(obs, start), 7, warm_up=True)
    emit(
        bench="calibration.probe",
        observations=obs.n_poses,
        pivot_rms_um=round(pr.pivot_rms_mm * 1e3, 2),
        wall_s=round(wall, 4),
        cpu_s=round(cpu, 4),
        target_s=0.1,
    )


if __name__ == "__main__":
    main()
