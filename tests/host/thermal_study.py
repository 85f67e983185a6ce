"""An aluminium arm calibrated at 20 degC and verified at 28 degC (issue 27, thermal).

The arm is a random :class:`aacmm.simulation.truth.Truth` (true geometry,
eccentric encoders, encoder and probing noise) with an all-aluminium thermal
profile: every link's true CTE drawn uniformly in 22e-6 .. 24e-6 /K
(:func:`aacmm.simulation.thermal.random_profile`), lengths true at 20 degC.
Sessions are made without the device as in tests/host/gate_study.py: the
probe tip put on the slot's target plus probing noise by the *true* geometry,
the encoders reading those angles (``Truth.counts``).

1. Calibration at 20 degC: the kinematic-calibration plan, ``calibrate`` from
   the session's observations (the counts and the plan only).
2. Verification (the arm-verification plan, ISO 10360-12 E_Uni), one set of
   targets, probing noise and articulations for every case:

   - **20 degC** (isothermal): the truth at its reference temperature;
   - **28 degC**: every link of the truth 8 K warmer, its lengths
     ``L (1 + cte_i (28 - 20))``; the articulation of each point is the
     20 degC one moved by Newton steps until the warm arm's tip is on the same
     target (so the only difference is the temperature). The points are
     computed with the calibrated set, **uncompensated** (the plain model) and
     **compensated** (:func:`aacmm.errmodel.points` with the nominal
     aluminium CTE 23e-6 /K on every link, reference 20 degC, at the known
     link temperature 28 degC: the truth's own CTEs are not used).

The artefacts: the ball bars are taken as not expanding (a carbon-fibre or
Invar bar, the usual practice, whose calibrated length is corrected to the
test temperature with its own CTE: the residual of that correction, a few
tenths of a micrometre per metre for 8 K, is not modelled). The seats and
spheres stay where they are; only the arm warms.

Independent of the library under test: the warm truth is the truth's
parameters with their lengths scaled here (checked in the test against
:func:`aacmm.simulation.thermal.true_points`, the C core's thermal model).

``python tests/host/thermal_study.py [SEEDS]`` prints the figures of
docs/calibration.md ("Temperature").
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, replace

import numpy as np
from aacmm.core import Model, Params, counts_to_angles
from aacmm.errmodel import ErrorModel
from aacmm.errmodel import points as em_points
from aacmm.plans import Plan, load_plan
from aacmm.simulation.thermal import ThermalProfile, params_at, random_profile
from aacmm.simulation.truth import Truth, random_truth
from aacmm.verification.report import Report, evaluate
from calib_synth import random_poses, reach, solve_ik
from gate_study import SIGMA_MM, record

T_REF_C = 20.0
T_WARM_C = 28.0
NOMINAL_CTE_PER_K = 23e-6  # aluminium, as a data sheet gives it (aacmm.simulation.thermal)
CASES = ("20 degC", "28 degC uncompensated", "28 degC compensated")
#: a control the test adds: compensated with the truth's own CTEs (what a thermal
#: calibration of the CTEs would give at best; not a compensation aacmm can make)
ORACLE = "28 degC, the true CTEs"


def aluminium_truth(seed: int) -> Truth:
    """``random_truth(seed)`` with an all-aluminium thermal profile (drawn from its own
    generator, so the arm is the same as ``random_truth(seed)``)."""
    truth = random_truth(seed)
    rng = np.random.default_rng(50_000 + seed)
    return replace(truth, thermal=random_profile(rng, ("aluminium",) * truth.joints))


def warm_params(params: Params, profile: ThermalProfile, temp_c: float) -> Params:
    """``params`` with every length of link i scaled by ``1 + cte_i (T - tref_i)``
    (``d_i``, ``a_i``; the tip ``l`` belongs to the last link), every link at
    ``temp_c``: the simulator's :func:`~aacmm.simulation.thermal.params_at`
    (test_thermal_verify checks it against the C core's thermal model)."""
    out = params_at(params, profile, (temp_c,) * profile.links)
    assert isinstance(out, Params)
    return out


@dataclass(frozen=True)
class Readings:
    """The joint readings (counts) of one session of a plan."""

    plan: Plan
    counts: np.ndarray  # (n, 6)

    def angles(self) -> np.ndarray:
        return counts_to_angles(self.counts.astype(np.uint64), record(Params()).encoders)


def sessions(
    plan: Plan, truth: Truth, seed: int, temps_c: tuple[float, ...]
) -> dict[float, Readings]:
    """The plan probed by ``truth`` at each link temperature in ``temps_c`` (every
    link at it): the same targets, probing noise, articulations and encoder noise."""
    rng = np.random.default_rng(seed)
    slots = plan.slots
    targets = np.array([s.target.tip_mm for s in slots if s.target is not None], dtype=float)
    assert targets.shape[0] == len(slots), "every slot needs a nominal target"
    targets = targets + rng.normal(0.0, truth.errors.probing_sigma_um * 1e-3, targets.shape)
    start = random_poses(rng, len(slots), (0.3, 1.4), (0.6, 1.8))
    q_ref = reach(Model(truth.params), targets, start, rng, 0.5, tries=20)
    noise_seed = int(rng.integers(1 << 62))
    out = {}
    for t in temps_c:
        q = q_ref
        if t != T_REF_C:
            assert truth.thermal is not None
            q, err = solve_ik(Model(warm_params(truth.params, truth.thermal, t)), targets, q_ref)
            assert float(err.max()) < 1e-9, f"the warm arm missed a target by {err.max()} mm"
        counts = truth.counts(q, np.random.default_rng(noise_seed))
        out[t] = Readings(plan, np.asarray(counts, dtype=np.int64))
    return out


def calibrated(truth: Truth, seed: int) -> Params:
    """The arm calibrated from a kinematic-calibration session at 20 degC (Table 1 in
    force): what ``aacmm calibrate`` computes from the counts and the plan."""
    from aacmm.calibration import calibrate
    from aacmm.calibration.sessions import observations_from_plan

    plan = load_plan("kinematic-calibration")
    s = sessions(plan, truth, seed, (T_REF_C,))[T_REF_C]
    obs, _, _ = observations_from_plan(plan, s.angles(), SIGMA_MM, labels=plan.slots)
    res = calibrate(obs, Params())
    assert isinstance(res.params, Params)
    return res.params


def compensation(cte_per_k: tuple[float, ...] = (NOMINAL_CTE_PER_K,) * 6) -> ErrorModel:
    """The compensation applied: nominal aluminium on every link, reference 20 degC
    (``cte_per_k``: other CTEs, for the test's control)."""
    n = len(cte_per_k)
    return ErrorModel(harmonics=((),) * n, cte_per_k=cte_per_k, tref_c=(T_REF_C,) * n)


@dataclass(frozen=True)
class Outcome:
    """One arm: |E_Uni| (mm) and the RMS length error (mm) of each case, and its CTEs."""

    seed: int
    cte_per_k: tuple[float, ...]
    e_uni: dict[str, float]
    rms: dict[str, float]
    reports: dict[str, Report]


def length_rms(rep: Report) -> float:
    return float(math.sqrt(np.mean([m.test.error**2 for m in rep.lengths])))


def run(seed: int) -> Outcome:
    """The three verifications of the arm ``aluminium_truth(seed)`` (module doc)."""
    truth = aluminium_truth(seed)
    assert truth.thermal is not None
    cal = calibrated(truth, 1000 + seed)
    plan = load_plan("arm-verification")
    s = sessions(plan, truth, 2000 + seed, (T_REF_C, T_WARM_C))
    model = Model(cal)
    temps = np.full(6, T_WARM_C)
    pts = {
        CASES[0]: model.points(s[T_REF_C].angles()),
        CASES[1]: model.points(s[T_WARM_C].angles()),
        CASES[2]: em_points(model, compensation(), s[T_WARM_C].angles(), temps),
        ORACLE: em_points(
            model, compensation(truth.thermal.cte_per_k), s[T_WARM_C].angles(), temps
        ),
    }
    reports = {k: evaluate(plan, plan.slots, p) for k, p in pts.items()}
    return Outcome(
        seed,
        truth.thermal.cte_per_k,
        {k: abs(r.result("e_uni").value_mm) for k, r in reports.items()},
        {k: length_rms(r) for k, r in reports.items()},
        reports,
    )


def table(outcomes: list[Outcome]) -> str:
    """The figures of docs/calibration.md: per arm, |E_Uni| in um of each case."""
    lines = [
        "| arm (seed) | true CTEs (1e-6/K) | |E_Uni| 20 degC | 28 degC uncompensated | "
        "28 degC compensated | compensated / 20 degC | control: the true CTEs |",
        "|---|---|---|---|---|---|---|",
    ]
    for o in outcomes:
        e = [o.e_uni[c] * 1e3 for c in CASES]
        ctes = " ".join(f"{a * 1e6:.1f}" for a in o.cte_per_k)
        lines.append(
            f"| {o.seed} | {ctes} | {e[0]:.1f} um | {e[1]:.1f} um ({e[1] / e[0]:.1f}x) | "
            f"{e[2]:.1f} um | {e[2] / e[0]:.2f} | {o.e_uni[ORACLE] * 1e3:.1f} um |"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    import os

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    seeds = [int(a) for a in sys.argv[1:]] or list(range(1, 11))
    t0 = time.perf_counter()
    results = [run(s) for s in seeds]
    sys.stdout.write(table(results) + "\n")
    sys.stdout.write(f"{len(seeds)} arms, {time.perf_counter() - t0:.1f} s\n")
