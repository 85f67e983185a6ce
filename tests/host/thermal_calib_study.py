"""Link CTEs calibrated with the arm from sessions at two temperatures (issue 27).

The arm is thermal_study's aluminium truth (``aluminium_truth(seed)``: a
random :class:`aacmm.simulation.truth.Truth`, every link's true CTE uniform
in 22e-6 .. 24e-6 /K, lengths true at 20 degC). Two kinematic-calibration
sessions are made without the device as thermal_study makes them (the tip on
the slot's target plus probing noise, the encoders reading the warm or cold
true arm's angles), one with every link at 10 degC and one at 30 degC, each
with its own targets' probing noise, articulations and encoder noise. The
calibration reads only the counts, the plan and the stated temperatures
(``Observations.temp_c``): ``calibrate(obs, start)`` with the default
``thermal="auto"`` estimates the arm and the link CTEs (reference 20 degC),
the start being the nominal arm with the data sheet's CTE (23e-6 /K on every
link): a CTE the data do not measure (link 1's: a1 is 0.3 mm and d1
unobservable) is held at it.

Verification: thermal_study's path (arm-verification plan, ISO 10360-12
E_Uni, one set of targets, probing noise and articulations at 20 and 28 degC,
the 28 degC articulations those of the warm true arm on the same targets).
The points of the calibrated set are computed with
:func:`aacmm.errmodel.points` and the calibrated CTEs at the known link
temperature: at 20 degC (the isothermal figure) and at 28 degC; the
data-sheet compensation (23e-6 /K on every link) of the same calibrated arm
at 28 degC is the comparison.

``python tests/host/thermal_calib_study.py [SEEDS]`` (``PYTHONPATH=tests/host``)
prints the figures of docs/calibration.md ("Temperature").
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from aacmm.calibration import CalibrationResult, calibrate
from aacmm.calibration.observations import Observations, combine
from aacmm.calibration.parameters import CalibParams
from aacmm.calibration.sessions import observations_from_plan
from aacmm.core import Model, Params
from aacmm.errmodel import ErrorModel
from aacmm.errmodel import points as em_points
from aacmm.plans import load_plan
from aacmm.simulation.truth import Truth
from aacmm.verification.report import evaluate
from gate_study import SIGMA_MM
from thermal_study import T_REF_C, T_WARM_C, aluminium_truth, compensation, sessions

CAL_TEMPS_C = (10.0, 30.0)


def observations(truth: Truth, seed: int, temps_c: tuple[float, ...]) -> Observations:
    """One kinematic-calibration session per temperature (its own noise and
    articulations: seeds ``seed + 100 k``), each pose stating its link temperature."""
    plan = load_plan("kinematic-calibration")
    parts = []
    for k, t in enumerate(temps_c):
        s = sessions(plan, truth, seed + 100 * k, (t,))[t]
        obs, _, _ = observations_from_plan(plan, s.angles(), SIGMA_MM, labels=plan.slots)
        parts.append(replace(obs, temp_c=np.full(obs.n_poses, t)))
    return combine(parts)


@dataclass(frozen=True)
class Outcome:
    """One arm: the calibration, |E_Uni| (mm) of each case, the true CTEs."""

    seed: int
    result: CalibrationResult[Any]  # its params a CalibParams
    true_cte_per_k: tuple[float, ...]
    e_uni: dict[str, float]


CASES = ("20 degC", "28 degC, calibrated CTEs", "28 degC, data-sheet CTE")


def run(seed: int, temps_c: tuple[float, ...] = CAL_TEMPS_C) -> Outcome:
    """Calibrate ``aluminium_truth(seed)`` from sessions at ``temps_c`` and verify it."""
    truth = aluminium_truth(seed)
    assert truth.thermal is not None
    start = CalibParams(Params(), compensation())  # the data sheet's CTEs as the start
    res: CalibrationResult[Any] = calibrate(observations(truth, 1000 + seed, temps_c), start)
    assert isinstance(res.params, CalibParams), res.thermal
    plan = load_plan("arm-verification")
    s = sessions(plan, truth, 2000 + seed, (T_REF_C, T_WARM_C))
    model = Model(res.params.arm)
    e = res.params.errors
    cal = ErrorModel(((),) * e.joints, e.cte_per_k, e.tref_c)
    warm = np.full(e.joints, T_WARM_C)
    pts = {
        CASES[0]: em_points(model, cal, s[T_REF_C].angles(), np.full(e.joints, T_REF_C)),
        CASES[1]: em_points(model, cal, s[T_WARM_C].angles(), warm),
        CASES[2]: em_points(model, compensation(), s[T_WARM_C].angles(), warm),
    }
    e_uni = {k: abs(evaluate(plan, plan.slots, p).result("e_uni").value_mm) for k, p in pts.items()}
    return Outcome(seed, res, truth.thermal.cte_per_k, e_uni)


def ctes(res: CalibrationResult[Any]) -> tuple[np.ndarray, np.ndarray]:
    """The calibrated link CTEs (N,) and their reported standard uncertainties (1/K)."""
    assert isinstance(res.params, CalibParams)
    names = res.params.param_names
    idx = [names.index(f"cte{i}") for i in range(1, res.params.errors.joints + 1)]
    return res.params.to_vector()[idx], res.scaled_std[idx]


def table(outcomes: list[Outcome]) -> str:
    """Per arm: true and calibrated CTEs (1e-6/K), |E_Uni| of each case."""
    lines = [
        "| arm (seed) | true CTEs (1e-6/K) | calibrated CTEs (+- 1 sigma) | |E_Uni| 20 degC | "
        "28 degC, calibrated CTEs | / 20 degC | 28 degC, data-sheet CTE | / 20 degC |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for o in outcomes:
        v, sd = ctes(o.result)
        true = " ".join(f"{a * 1e6:.1f}" for a in o.true_cte_per_k)
        cal = " ".join(f"{a * 1e6:.1f}({s * 1e6:.1f})" for a, s in zip(v, sd, strict=True))
        e = [o.e_uni[c] * 1e3 for c in CASES]
        lines.append(
            f"| {o.seed} | {true} | {cal} | {e[0]:.1f} um | {e[1]:.1f} um | {e[1] / e[0]:.2f} | "
            f"{e[2]:.1f} um | {e[2] / e[0]:.2f} |"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    import os

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    seeds = [int(a) for a in sys.argv[1:]] or list(range(1, 21))
    t0 = time.perf_counter()
    results = [run(s) for s in seeds]
    sys.stdout.write(table(results) + "\n")
    sys.stdout.write(f"{len(seeds)} arms, {time.perf_counter() - t0:.1f} s\n")
