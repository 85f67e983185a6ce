"""The 200-truth study of encoder angle harmonics on the shipped plan (issue 27, Done when 2).

Each run is one seeded random truth of the simulator with one-head encoders
(:func:`aacmm.simulation.truth.random_truth`, grade ``one-head``: harmonics 1
and 2 of 10-30 arcsec on every joint, any phase) and the same arm with ideal
encoders (eccentricity and harmonics removed, the geometry unchanged). Data
are generated in-process, not by the simulator process: every slot of the
shipped kinematic-calibration plan (3 seats x 25 articulations, 3 ball bars x
10 positions) is reached on the *true* geometry, the tip displaced by the
truth's probing noise (2 um per axis), by Newton steps from the simulated
operator's articulation of that slot (:func:`aacmm.simulation.scenario.plan_poses`
on the nominal arm, one of four choreographies per run: the joint ranges
``aacmm sim --scenario`` probes with, within the simulator's joint limits, as
the check's postures are); the encoders read those exact angles as the simulator's do
(:meth:`Truth.counts`, here without the 0.3 arcsec encoder noise: the
calibration states the probing noise only). The calibration sees the counts
converted with the device's encoder configuration, never the truth.

Three calibrations per run, all from the same poses and the same noise:

* ``full``: ``harmonics=2`` on the one-head data;
* ``dh``: the arm alone (``harmonics=0``) on the one-head data;
* ``base``: ``harmonics=2`` on the ideal-encoder data (what the same
  calibration reaches without harmonics), and ``base_dh``: the arm alone there.

Each is judged as ``aacmm demo --check`` judges an arm
(:mod:`aacmm.simulation.truthcheck`: 2,000 lengths between random postures
within the simulator's joint limits, the true encoders' noise-free readings
converted by the calibrated model, against the true distances) and by its
identifiable combinations: the 18 single parameters and the tip vector of
tests/host/test_calibration.py plus the 24 harmonic coefficients, against
the truth's, with their standard uncertainty from the calibration's
covariance. The true coefficients are what a reading-side correction can
be: the harmonics 1 and 2 of ``q(r) - r`` (``r = q + e(q)`` inverted on a
grid of 256 readings); its mean goes to the joint's theta offset, its
harmonics 3 and up (a few 1e-8 rad, products of the 1e-4 rad amplitudes) are
left to the model error.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
from aacmm.calibration import calibrate
from aacmm.calibration.parameters import CalibParams, arm_part, error_model
from aacmm.calibration.sessions import observations_from_plan
from aacmm.core import EncoderConfig, Model, Params, counts_to_angles
from aacmm.errmodel import points as em_points
from aacmm.plans import Plan, load_plan
from aacmm.simulation.scenario import plan_poses
from aacmm.simulation.truth import Truth, random_truth
from aacmm.simulation.truthcheck import ReachLengths, length_errors, reach_lengths
from calib_synth import solve_ik
from test_calibration import SINGLES, K, tip, tip_grad

PLAN = "kinematic-calibration"
GRADE = "one-head"
ORDERS = 2
#: the lengths of each run's check (``aacmm demo --check`` takes 2,000: the same)
CHECK_LENGTHS = 2000
#: the operator's articulations the runs start from (run i: one of them, drawn)
CHOREOGRAPHIES = 4
COMBOS = [*SINGLES, "tip_x", "tip_y", "tip_z"] + [
    f"{w}{j}_{k}" for j in range(1, 7) for k in range(1, ORDERS + 1) for w in "cs"
]


def ideal(truth: Truth) -> Truth:
    """The same arm with ideal encoders: no eccentricity, no harmonics."""
    n = truth.joints
    errors = replace(
        truth.errors,
        eccentricity_arcsec=(0.0,) * n,
        eccentricity_phase_rad=(0.0,) * n,
        harmonic_orders=(),
        harmonic_arcsec=(),
        harmonic_phase_rad=(),
    )
    return replace(truth, errors=errors)


def true_correction(truth: Truth, orders: int = ORDERS, m: int = 256) -> np.ndarray:
    """(N, orders + 1, 2): per joint the mean (``[:, 0, 0]``) and the harmonics
    ``(c_k, s_k)`` of the correction ``q(r) - r`` that maps the encoder's reading
    ``r = q + e(q)`` back onto the angle ``q`` (a Fourier series on ``m`` readings)."""
    r = np.tile(2 * np.pi * np.arange(m)[:, None] / m, (1, truth.joints))
    q = r.copy()
    for _ in range(30):  # |e'| <= sum k A_k ~ 5e-4: contracts by that per step
        q = r - truth.reading_error_rad(q)
    c = q - r
    out = np.zeros((truth.joints, orders + 1, 2))
    out[:, 0, 0] = c.mean(axis=0)
    for k in range(1, orders + 1):
        out[:, k, 0] = 2.0 / m * np.sum(c * np.cos(k * r), axis=0)
        out[:, k, 1] = 2.0 / m * np.sum(c * np.sin(k * r), axis=0)
    return out


def true_combos(truth: Truth) -> np.ndarray:
    """The identifiable combinations of the truth as a calibration of its readings
    sees it: the correction's mean in the theta offsets, its harmonics as the
    coefficients."""
    corr = true_correction(truth)
    v = truth.params.to_vector()
    v[:6] += corr[:, 0, 0]
    p = Params.from_vector(v)
    arm = np.concatenate([v[[K[n] for n in SINGLES]], tip(p)])
    return np.concatenate([arm, corr[:, 1:, :].reshape(-1)])


def combos_and_sd(p: CalibParams, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A full-model calibration's combinations (as :func:`true_combos`) and their
    standard uncertainties (the covariance through the combinations' gradient)."""
    arm = p.arm
    assert isinstance(arm, Params)
    v = arm.to_vector()
    coef = np.array([x for h in p.errors.harmonics for pair in h for x in pair])
    e = coef.size
    g = np.zeros((len(SINGLES) + 3 + e, 25 + e))
    for i, n in enumerate(SINGLES):
        g[i, K[n]] = 1.0
    g[len(SINGLES) : len(SINGLES) + 3, [K[n] for n in ("theta6", "alpha6", "d6", "a6", "l")]] = (
        tip_grad(arm)
    )
    g[len(SINGLES) + 3 :, 25:] = np.eye(e)
    c = np.concatenate([v[[K[n] for n in SINGLES]], tip(arm), coef])
    return c, np.sqrt(np.diag(g @ cov @ g.T))


def choreographies(plan: Plan, n: int = CHOREOGRAPHIES) -> list[np.ndarray]:
    """The simulated operator's articulations of every slot (``aacmm sim --scenario PLAN
    --seed S``, S = 1 .. n) on the nominal arm: (n_slots, 6) each, within the
    simulator's joint limits."""
    return [plan_poses(plan, Params(), seed) for seed in range(1, n + 1)]


def sample_angles(
    plan: Plan, truth: Truth, rng: np.random.Generator, starts: list[np.ndarray]
) -> np.ndarray:
    """Exact joint angles (n, 6) of the true arm on every slot's target plus probing
    noise: Newton steps on the true geometry from one of the operator's
    articulations ``starts`` (drawn by ``rng``), so the poses stay in its branch."""
    targets = np.array([s.target.tip_mm for s in plan.slots if s.target is not None], dtype=float)
    assert targets.shape[0] == len(plan.slots), "every slot needs a nominal target"
    sigma = truth.errors.probing_sigma_um * 1e-3
    targets = targets + rng.normal(0.0, sigma, targets.shape)
    start = starts[int(rng.integers(len(starts)))]
    q, err = solve_ik(Model(truth.params), targets, start)
    assert err.max() < 1e-11, err.max()
    return q


def measured_points(p: Params | CalibParams, counts: np.ndarray) -> np.ndarray:
    """The tip points a calibrated model computes from raw counts (device encoders)."""
    r = counts_to_angles(counts.astype(np.uint64), EncoderConfig())
    m, em = Model(arm_part(p)), error_model(p)
    return m.points(r) if em is None else em_points(m, em, r)


@dataclass(frozen=True)
class Run:
    """One truth's figures: RMS length error over the reach (mm) of each calibration,
    the chi-square verdicts and ratios, the combinations' normalised errors."""

    seed: int
    rms_mm: dict[str, float]
    verdict: dict[str, str]
    chi2_ratio: dict[str, float]
    z: np.ndarray  # (len(COMBOS),): (estimate - truth) / sd of the full model
    held: tuple[str, ...]
    rank: int
    seconds: float


def one_run(
    seed: int,
    plan: Plan,
    starts: list[np.ndarray],
    lengths: int = CHECK_LENGTHS,
    encoder_noise: bool = False,
) -> Run:
    """One run (module doc); ``encoder_noise``: the counts with the truth's encoder
    noise too (the same draw for the one-head truth and its twin), the stated
    sigma still the probing noise's."""
    t0 = time.perf_counter()
    truth = random_truth(seed, grade=GRADE)
    clean = ideal(truth)
    sigma = truth.errors.probing_sigma_um * 1e-3
    q = sample_angles(plan, truth, np.random.default_rng(seed), starts)
    results = {}
    for name, t in (("one-head", truth), ("ideal", clean)):
        noise = np.random.default_rng(10_000 + seed) if encoder_noise else None
        r = counts_to_angles(t.counts(q, noise).astype(np.uint64), EncoderConfig())
        obs, _, _ = observations_from_plan(plan, r, sigma)
        results[f"{name}/full"] = calibrate(obs, harmonics=ORDERS)
        results[f"{name}/dh"] = calibrate(obs)
    named = {
        "full": results["one-head/full"],
        "dh": results["one-head/dh"],
        "base": results["ideal/full"],
        "base_dh": results["ideal/dh"],
    }
    checks: dict[bool, ReachLengths] = {
        True: reach_lengths(clean, lengths),
        False: reach_lengths(truth, lengths),
    }
    rms = {}
    for name, res in named.items():
        check = checks[name.startswith("base")]
        rms[name] = length_errors(check, measured_points(res.params, check.counts)).rms_mm
    full = named["full"]
    assert isinstance(full.params, CalibParams)
    est, sd = combos_and_sd(full.params, full.covariance)
    return Run(
        seed,
        rms,
        {k: v.chi_square.verdict for k, v in named.items()},
        {k: v.chi_square.ratio for k, v in named.items()},
        (est - true_combos(truth)) / sd,
        full.held,
        full.identifiability.rank,
        time.perf_counter() - t0,
    )


@dataclass(frozen=True)
class Study:
    runs: list[Run]

    def rms(self, name: str) -> np.ndarray:
        return np.array([r.rms_mm[name] for r in self.runs])

    def ratio(self, a: str, b: str) -> np.ndarray:
        out: np.ndarray = self.rms(a) / self.rms(b)
        return out

    def within_3_sigma(self) -> np.ndarray:
        """Per combination: the fraction of runs within 3 standard uncertainties."""
        z = np.array([r.z for r in self.runs])
        out: np.ndarray = np.mean(np.abs(z) <= 3.0, axis=0)
        return out

    def verdicts(self, name: str) -> dict[str, int]:
        out: dict[str, int] = {}
        for r in self.runs:
            out[r.verdict[name]] = out.get(r.verdict[name], 0) + 1
        return out


def study(
    runs: int,
    first_seed: int = 0,
    lengths: int = CHECK_LENGTHS,
    plan: Plan | None = None,
    encoder_noise: bool = False,
) -> Study:
    """``runs`` runs of seeds ``first_seed ..`` on the shipped plan (or ``plan``)."""
    plan = plan or load_plan(PLAN)
    starts = choreographies(plan)
    return Study(
        [one_run(first_seed + i, plan, starts, lengths, encoder_noise) for i in range(runs)]
    )


def distribution(x: np.ndarray) -> dict[str, float]:
    """Median, 95th percentile and worst of a per-run figure."""
    return {
        "median": float(np.median(x)),
        "p95": float(np.quantile(x, 0.95)),
        "worst": float(np.max(x)),
        "best": float(np.min(x)),
    }


def summary(st: Study) -> dict[str, object]:
    """The study's figures (JSON-ready): the distributions over runs, verdicts, 3-sigma rates."""
    frac = st.within_3_sigma()
    return {
        "runs": len(st.runs),
        "plan": PLAN,
        "grade": GRADE,
        "harmonics": ORDERS,
        "check_lengths": CHECK_LENGTHS,
        "rms_um": {n: distribution(1e3 * st.rms(n)) for n in ("full", "dh", "base", "base_dh")},
        "full_over_base": distribution(st.ratio("full", "base")),
        "dh_over_base": distribution(st.ratio("dh", "base")),
        "full_over_base_dh": distribution(st.ratio("full", "base_dh")),
        "verdicts": {n: st.verdicts(n) for n in ("full", "dh", "base", "base_dh")},
        "chi2_ratio": {
            n: distribution(np.array([r.chi2_ratio[n] for r in st.runs]))
            for n in ("full", "dh", "base")
        },
        "within_3_sigma": dict(zip(COMBOS, (float(f) for f in frac), strict=True)),
        "within_3_sigma_min": float(frac.min()),
        "held": sorted({h for r in st.runs for h in r.held}),
        "rank": sorted({r.rank for r in st.runs}),
        "seconds_per_run": distribution(np.array([r.seconds for r in st.runs])),
        "per_run": [
            {"seed": r.seed, **{f"{k}_um": 1e3 * v for k, v in r.rms_mm.items()}} for r in st.runs
        ],
    }


#: the 9 seats of :func:`spread_plan`: three distances, azimuths and heights (mm)
SPREAD_SEATS = (
    (450, -350, -350), (450, 0, -100), (450, 350, 200),
    (750, -350, -100), (750, 0, 200), (750, 350, -350),
    (1050, -350, 200), (1050, 0, -350), (1050, 350, -100),
)  # fmt: skip


def spread_plan(articulations: int) -> Plan:
    """A design study, not a shipped plan: the kinematic-calibration plan with its 3
    seats replaced by the 9 of :data:`SPREAD_SEATS`, ``articulations`` each (the
    same 3 ball bars at the same 30 positions)."""
    from aacmm.plans import loads_plan, shipped_plan_path

    text = shipped_plan_path(PLAN).read_text()
    a, b = text.index("[artefacts.cone1]"), text.index("# Ball bars with a cone seat")
    seats = "".join(
        f'[artefacts.cone{k}]\ntype = "cone"\nlocation_mm = [{x}.0, {y}.0, {z}.0]\n\n'
        for k, (x, y, z) in enumerate(SPREAD_SEATS, 1)
    )
    text = text[:a] + seats + text[b:]
    a, b = text.index('[[steps]]\nid = "cone1"'), text.index('[[steps]]\nid = "bar500"')
    steps = "".join(
        f'[[steps]]\nid = "cone{k}"\nprocedure = "cone"\nartefact = "cone{k}"\n'
        f"articulations = {articulations}\n\n"
        for k in range(1, len(SPREAD_SEATS) + 1)
    )
    text = text[:a] + steps + text[b:]
    return loads_plan(text.replace('title = "Kinematic calibration"', 'title = "Nine seats"'))


def precision_budget(
    seed: int, plan: Plan | None = None, choreography: int | None = None, lengths: int = 500
) -> dict[str, float]:
    """What the full model's RMS length error over the reach is made of, from its
    covariance (um): the predicted RMS with every parameter estimated (``all``),
    with one joint's harmonic coefficients known (``joint J known``) and with
    all of them known (``arm alone``: the covariance of the arm's part given
    the harmonics, the DH-only calibration's on the same poses); and each
    term's observability. ``plan``: default the shipped one; ``choreography``:
    the operator's seed (default: one of the study's four, drawn)."""
    from aacmm.errmodel import points_jacobians as em_points_jacobians

    plan = plan or load_plan(PLAN)
    starts = (
        choreographies(plan) if choreography is None else [plan_poses(plan, Params(), choreography)]
    )
    truth = random_truth(seed, grade=GRADE)
    q = sample_angles(plan, truth, np.random.default_rng(seed), starts)
    r = counts_to_angles(truth.counts(q).astype(np.uint64), EncoderConfig())
    obs, _, _ = observations_from_plan(plan, r, truth.errors.probing_sigma_um * 1e-3)
    res = calibrate(obs, harmonics=ORDERS)
    p = res.params
    assert isinstance(p, CalibParams) and isinstance(p.arm, Params)
    check = reach_lengths(truth, lengths)
    rc = counts_to_angles(check.counts.astype(np.uint64), EncoderConfig())
    pts, jac = em_points_jacobians(Model(p.arm), p.errors, rc)
    u = pts[0::2] - pts[1::2]
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    g = np.einsum("na,nap->np", u, jac[0::2] - jac[1::2])  # d length / d parameter
    cov = res.covariance
    names = list(p.param_names)

    def predicted(known: list[int]) -> float:
        rest = [i for i in range(len(names)) if i not in known]
        c = cov[np.ix_(rest, rest)]
        k = [i for i in known if cov[i, i] > 0]
        if k:
            crk = cov[np.ix_(rest, k)]
            c = c - crk @ np.linalg.solve(cov[np.ix_(k, k)], crk.T)
        gr = g[:, rest]
        return float(1e3 * np.sqrt(np.mean(np.einsum("np,pq,nq->n", gr, c, gr))))

    out = {"all": predicted([])}
    for j in range(1, 7):
        cols = [names.index(f"{w}{j}_{k}") for k in range(1, ORDERS + 1) for w in "cs"]
        out[f"joint {j} known"] = predicted(cols)
    out["arm alone"] = predicted([i for i, n in enumerate(names) if n[0] in "cs" and "_" in n])
    for t in res.error_terms:
        out[f"observability {t.name}"] = t.observability
    return out
