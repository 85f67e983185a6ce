"""aacmm.analysis.tolerance and `aacmm tolerance`: allocation, encoder choice, MC check.

References are computed here, another way: the Lagrange solution in closed
form, a direct SLSQP over every row, brute force over encoder combinations,
a numpy forward model for the Monte Carlo, an explicit least-squares
calibration for the calibrated arm.
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from aacmm.analysis import tolerance as tl
from aacmm.core import JOINTS, PARAM_NAMES, Model, Params
from aacmm.errors import InfeasibleError
from clihelp import one_error_line, run
from scipy import optimize, special, stats

pytestmark = pytest.mark.timeout(300)
ARCSEC = math.pi / 648000.0
RNG_POSES = np.random.default_rng(2024).uniform(-180, 180, (40, 6))


def doc(**over: Any) -> dict[str, Any]:
    """A spec document: every parameter allocated, the given poses, no encoders."""
    d: dict[str, Any] = {
        "angle_unit": "arcsec",
        "length_unit": "um",
        "target": {"value": 30.0},
        "workspace": {"poses": RNG_POSES[:20].tolist()},
        "parameters": {
            "theta": {"c": 4.0, "k": 2},
            "alpha": {"c": 6.0, "k": 2},
            "d": {"c": 30.0, "k": 2},
            "a": {"c": 20.0, "k": 2},
            "l": {"c": 10.0, "k": 2},
        },
    }
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(d.get(k), dict):
            d[k] = {**d[k], **v}
        else:
            d[k] = v
    return d


def rms_sensitivity(poses_deg: np.ndarray) -> np.ndarray:
    """s_i (25,): RMS over the poses of |dp/dq_i| (mm per rad or mm), from the core."""
    _, j = Model(Params()).points_jacobians(np.radians(poses_deg))
    out: np.ndarray = np.sqrt((j**2).sum(axis=1).mean(axis=0))
    return out


def test_sensitivity_matches_central_differences() -> None:
    # the s_i used as references below, checked against the model itself
    poses = np.radians(RNG_POSES[:5])
    base = Params().to_vector()
    h = np.where(np.arange(25) < 12, 1e-7, 1e-5)
    fd = np.empty((5, 3, 25))
    for i in range(25):
        up, dn = base.copy(), base.copy()
        up[i] += h[i]
        dn[i] -= h[i]
        fd[:, :, i] = (
            Model(Params.from_vector(up)).points(poses)
            - Model(Params.from_vector(dn)).points(poses)
        ) / (2 * h[i])
    s_fd = np.sqrt((fd**2).sum(axis=1).mean(axis=0))
    assert np.allclose(rms_sensitivity(RNG_POSES[:5]), s_fd, rtol=1e-6)


# ------------------------------------------------------------------ closed form


@pytest.mark.parametrize("k", [2.0, 3.0])
def test_closed_form_equals_lagrange(k: float) -> None:
    # cost c_i / t_i^k, constraint sum s_i^2 t_i^2 <= U^2 (RMS over the workspace):
    # rad and mm, u = t (normal, k_normal = 1) and U = 1 x u_c, so the spec is
    # exactly the textbook problem.
    rng = np.random.default_rng(int(k))
    c = rng.uniform(0.5, 20.0, 25)
    params = {
        n: {"c": float(ci), "k": k, "distribution": "normal", "k_normal": 1.0}
        for n, ci in zip(PARAM_NAMES, c, strict=True)
    }
    u_target = 0.02  # mm
    spec = tl.parse_spec(
        doc(
            angle_unit="rad",
            length_unit="mm",
            target={"value": u_target, "over": "rms", "coverage_factor": 1.0},
            parameters=params,
        )
    )
    a = tl.allocate(spec)
    s = rms_sensitivity(RNG_POSES[:20])
    # Lagrange: -k c_i t_i^(-k-1) + 2 lam s_i^2 t_i = 0 -> t_i = C (k c_i / s_i^2)^(1/(k+2))
    r = (k * c / s**2) ** (1.0 / (k + 2.0))
    scale = u_target / math.sqrt(float(np.sum(s**2 * r**2)))
    ref = scale * r
    assert np.max(np.abs(a.t / ref - 1.0)) < 1e-9
    assert all(p.status == "allocated" for p in a.params)
    # the constraint holds with equality, and the solution is a minimum on it
    assert math.isclose(float(np.sum(s**2 * a.t**2)), u_target**2, rel_tol=1e-9)
    cost = float(np.sum(c / a.t**k))
    assert math.isclose(cost, a.tolerance_cost, rel_tol=1e-12)
    for _ in range(20):
        t2 = a.t * np.exp(rng.normal(0, 0.05, 25))
        t2 *= u_target / math.sqrt(float(np.sum(s**2 * t2**2)))  # back onto the constraint
        assert float(np.sum(c / t2**k)) > cost


def test_closed_form_in_user_units_with_uniform_tolerances() -> None:
    # arcsec and um, uniform errors (u = t / sqrt 3), U = 2 u_c: the same solution
    # with s_i' = 2 s_i scale_i / sqrt 3 derived here
    spec = tl.parse_spec(doc(target={"value": 25.0, "over": "rms", "coverage_factor": 2.0}))
    a = tl.allocate(spec)
    s = rms_sensitivity(RNG_POSES[:20])
    scale = np.where(np.arange(25) < 12, ARCSEC, 1e-3)
    c = np.array([4.0] * 6 + [6.0] * 6 + [30.0] * 6 + [20.0] * 6 + [10.0])
    s_eff = 2.0 * s * scale / math.sqrt(3.0)
    r = (2.0 * c / s_eff**2) ** 0.25
    ref = 25e-3 / math.sqrt(float(np.sum(s_eff**2 * r**2))) * r
    assert np.max(np.abs(a.t / ref - 1.0)) < 1e-9
    assert math.isclose(a.value_mm, 25e-3, rel_tol=1e-9)
    # the report's sensitivity column is s_i in um per arcsec / um per um
    assert np.allclose([p.sensitivity for p in a.params], s * scale / 1e-3, rtol=1e-12)


def test_limits_satisfy_the_kkt_conditions() -> None:
    spec = tl.parse_spec(
        doc(
            target={"value": 20.0, "over": "rms", "coverage_factor": 2.0},
            parameters={
                "theta": {"c": 4.0, "min": 1.5},  # too tight to make: at min
                "alpha": {"c": 6.0, "max": 0.8},  # looser is useless: at max
                "d": {"c": 30.0},
                "a": {"c": 20.0, "k": 3},
                "l": {"tolerance": 4.0},
            },
        )
    )
    a = tl.allocate(spec)
    st = {p.name: p.status for p in a.params}
    assert {st[f"theta{i}"] for i in range(1, 7)} <= {"at min", "allocated"}
    assert "at min" in {st[f"theta{i}"] for i in range(1, 7)}
    assert "at max" in {st[f"alpha{i}"] for i in range(1, 7)}
    assert st["l"] == "fixed"
    # KKT: dcost/dt_i = -k c t^-(k+1) and dg/dt_i = 2 s'^2 t: their ratio is -lambda
    # for every free parameter, and has the right sign at the limits
    s = rms_sensitivity(RNG_POSES[:20])
    scale = np.where(np.arange(25) < 12, ARCSEC, 1e-3)
    s_eff = 2.0 * s * scale / math.sqrt(3.0)
    c = np.array([4.0] * 6 + [6.0] * 6 + [30.0] * 6 + [20.0] * 6 + [10.0])
    kk = np.array([2.0] * 18 + [3.0] * 6 + [2.0])
    t = a.t
    lam = np.full(25, np.nan)
    lam[:24] = kk[:24] * c[:24] * t[:24] ** (-kk[:24] - 1) / (2 * s_eff[:24] ** 2 * t[:24])
    free = [i for i, n in enumerate(PARAM_NAMES[:24]) if st[n] == "allocated"]
    assert np.ptp(lam[free]) / np.mean(lam[free]) < 1e-8
    lam0 = float(np.mean(lam[free]))
    at_min = [i for i, n in enumerate(PARAM_NAMES) if st[n] == "at min"]
    at_max = [i for i, n in enumerate(PARAM_NAMES) if st[n] == "at max"]
    # at its minimum a parameter would rather be tighter still (its ratio is below
    # lambda, it rises as t falls); at its maximum it would rather be looser
    assert np.all(lam[at_min] < lam0)
    assert np.all(lam[at_max] > lam0)
    assert float(np.sum(s_eff**2 * t**2)) <= 20e-3**2 * (1 + 1e-12)


def _reference_worst(rows: np.ndarray, c: np.ndarray, k: float) -> tuple[float, np.ndarray]:
    """min sum c t^-k subject to every row . t^2 <= 1: SLSQP on all rows at once."""

    def cost(y: np.ndarray) -> float:
        return float(np.sum(c * np.exp(-k * y)))

    y0 = np.full(c.size, -3.0)
    best = None
    for y_start in (y0, y0 - 2):
        res = optimize.minimize(
            cost,
            y_start,
            bounds=[(-40.0, 10.0)] * c.size,
            jac=lambda y: -k * c * np.exp(-k * y),
            method="SLSQP",
            constraints=[
                {
                    "type": "ineq",
                    "fun": lambda y: 1 - rows @ np.exp(2 * y),
                    "jac": lambda y: -2 * rows * np.exp(2 * y)[None, :],
                }
            ],
            options={"ftol": 1e-14, "maxiter": 3000},
        )
        if best is None or res.fun < best.fun:
            best = res
    assert best is not None
    return float(best.fun), np.exp(best.x)


def test_worst_pose_matches_a_direct_solve_over_every_pose() -> None:
    spec = tl.parse_spec(doc(target={"value": 30.0, "over": "worst", "coverage_factor": 2.0}))
    a = tl.allocate(spec)
    _, j = Model(Params()).points_jacobians(np.radians(RNG_POSES[:20]))
    scale = np.where(np.arange(25) < 12, ARCSEC, 1e-3)
    f = scale / math.sqrt(3.0)
    rows = 4.0 * (j**2).sum(axis=1) * f**2 / 30e-3**2
    c = np.array([4.0] * 6 + [6.0] * 6 + [30.0] * 6 + [20.0] * 6 + [10.0])
    ref_cost, _ = _reference_worst(rows, c, 2.0)
    assert np.max(rows @ a.t**2) <= 1 + 1e-9
    assert a.tolerance_cost <= ref_cost * (1 + 1e-6)
    assert a.tolerance_cost >= ref_cost * (1 - 1e-6)
    assert math.isclose(a.ratio, 1.0, rel_tol=1e-9)
    # and it costs more than the RMS version of the same target
    rms = tl.allocate(replace(spec, target=replace(spec.target, over="rms")))
    assert rms.tolerance_cost < a.tolerance_cost


# ------------------------------------------------------------------ encoders

CATALOGUE: list[dict[str, Any]] = [
    {"name": "18 bit", "bits": 18, "accuracy_arcsec": 20.0, "cost": 40.0},
    {"name": "23 bit", "bits": 23, "accuracy_arcsec": 5.0, "cost": 160.0},
    {"name": "26 bit", "bits": 26, "accuracy_arcsec": 1.0, "cost": 700.0},
    {"name": "worse and dearer", "bits": 16, "accuracy_arcsec": 30.0, "cost": 900.0},
]


def _enc_u(e: dict[str, Any]) -> float:
    res = 1296000.0 / 2 ** e["bits"]
    return math.hypot(e["accuracy_arcsec"] / math.sqrt(3), res / math.sqrt(12)) * ARCSEC


def test_encoder_choice_is_the_brute_force_optimum() -> None:
    # RMS target, no limits: for a given choice the optimum is the closed form
    # (with the encoders' variance taken off the budget); try all 4^6 choices.
    d = doc(target={"value": 40.0, "over": "rms", "coverage_factor": 2.0}, encoder=CATALOGUE)
    a = tl.allocate(tl.parse_spec(d))
    _, j = Model(Params()).points_jacobians(np.radians(RNG_POSES[:20]))
    s2 = (j**2).sum(axis=1).mean(axis=0)
    scale = np.where(np.arange(25) < 12, ARCSEC, 1e-3)
    se2 = 4.0 * s2 * scale**2 / 3.0  # coefficient of t^2 in (U/2)^2 ... times 4
    c = np.array([4.0] * 6 + [6.0] * 6 + [30.0] * 6 + [20.0] * 6 + [10.0])
    r = (2.0 * c / se2) ** 0.25
    budget0 = 40e-3**2
    best: tuple[float, tuple[int, ...]] = (math.inf, ())
    for choice in itertools.product(range(len(CATALOGUE)), repeat=JOINTS):
        enc = sum(4.0 * s2[jt] * _enc_u(CATALOGUE[e]) ** 2 for jt, e in enumerate(choice))
        left = budget0 - enc
        if left <= 0:
            continue
        t = math.sqrt(left / float(np.sum(se2 * r**2))) * r
        total = float(np.sum(c / t**2)) + sum(CATALOGUE[e]["cost"] for e in choice)
        if total < best[0]:
            best = (total, choice)
    assert math.isclose(a.total_cost, best[0], rel_tol=1e-9)
    assert (
        tuple(
            CATALOGUE.index(next(x for x in CATALOGUE if x["name"] == r_.encoder.name))
            for r_ in a.encoders
        )
        == best[1]
    )
    assert "worse and dearer" not in {r_.encoder.name for r_ in a.encoders}


def test_encoder_choice_worst_pose_against_exhaustive_solves() -> None:
    # worst pose: branch and bound against solving every combination (2 entries
    # on joints 1-3, the cheap one elsewhere: 8 combinations)
    cat: list[dict[str, Any]] = [
        {**CATALOGUE[1], "joints": [1, 2, 3, 4, 5, 6]},
        {**CATALOGUE[2], "joints": [1, 2, 3]},
    ]
    d = doc(
        target={"value": 60.0, "over": "worst", "coverage_factor": 2.0},
        workspace={"poses": RNG_POSES[:12].tolist()},
        encoder=cat,
    )
    a = tl.allocate(tl.parse_spec(d))
    _, j = Model(Params()).points_jacobians(np.radians(RNG_POSES[:12]))
    jj = (j**2).sum(axis=1)
    scale = np.where(np.arange(25) < 12, ARCSEC, 1e-3)
    c = np.array([4.0] * 6 + [6.0] * 6 + [30.0] * 6 + [20.0] * 6 + [10.0])
    best = math.inf
    for choice in itertools.product([0, 1], repeat=3):
        e = [cat[x] for x in choice] + [cat[0]] * 3
        ev = np.array([_enc_u(x) ** 2 for x in e])
        left = 1.0 - 4.0 * (jj[:, :6] @ ev) / 60e-3**2
        if np.any(left <= 0):
            continue  # these encoders alone miss the target at some pose
        rows = 4.0 * jj * (scale**2 / 3.0) / 60e-3**2 / left[:, None]
        cost, _ = _reference_worst(rows, c, 2.0)
        best = min(best, cost + sum(x["cost"] for x in e))
    assert a.total_cost <= best * (1 + 1e-6)
    assert a.total_cost >= best * (1 - 1e-6)


def test_dominated_encoders_are_dropped() -> None:
    from aacmm.analysis.tolerance.solve import Candidate, prune

    c = [Candidate(0, 1.0, 10.0), Candidate(1, 2.0, 20.0), Candidate(2, 0.5, 30.0)]
    assert [x.index for x in prune(c)] == [0, 2]


# ------------------------------------------------------------------ coverage factor


def test_radius_factor() -> None:
    z = tl.z_two_sided(0.95)
    assert math.isclose(z, stats.norm.ppf(0.975), rel_tol=1e-12)
    k = tl.radius_factor([[1, 0, 0], [1, 1, 0], [1, 1, 1]], 0.95)
    assert math.isclose(k[0], z, rel_tol=1e-8)
    assert math.isclose(k[1], math.sqrt(stats.chi2.ppf(0.95, 2) / 2), rel_tol=1e-8)
    assert math.isclose(k[2], math.sqrt(stats.chi2.ppf(0.95, 3) / 3), rel_tol=1e-8)
    rng = np.random.default_rng(5)
    lam = rng.random((3, 3)) ** 3
    kk = tl.radius_factor(lam, 0.9)
    for i in range(3):
        x = rng.standard_normal((400_000, 3)) * np.sqrt(lam[i])
        r = np.linalg.norm(x, axis=1) / math.sqrt(lam[i].sum())
        frac = float(np.mean(r <= kk[i]))
        assert abs(frac - 0.9) < 4 * math.sqrt(0.09 / 400_000)


# ------------------------------------------------------------------ Monte Carlo


def _numpy_points(params: Params, delta: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Probe points (T, 3) of arms nominal + delta (T, 25) at one pose: DH products."""
    v = params.to_vector() + delta
    n = v.shape[0]
    m = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    for i in range(6):
        th = theta[i] + v[:, i]
        al, d, a = v[:, 6 + i], v[:, 12 + i], v[:, 18 + i]
        t = np.zeros((n, 4, 4))
        c, s, ca, sa = np.cos(th), np.sin(th), np.cos(al), np.sin(al)
        t[:, 0] = np.stack([c, -s * ca, s * sa, a * c], 1)
        t[:, 1] = np.stack([s, c * ca, -c * sa, a * s], 1)
        t[:, 2] = np.stack([np.zeros(n), sa, ca, d], 1)
        t[:, 3, 3] = 1.0
        m = m @ t
    tool = np.stack([np.zeros(n), np.zeros(n), v[:, 24], np.ones(n)], 1)
    out: np.ndarray = np.einsum("nij,nj->ni", m, tool)[:, :3]
    return out


def test_monte_carlo_of_1e5_arms_meets_the_target() -> None:
    d = doc(
        target={"value": 30.0, "over": "worst"},
        workspace={"poses": RNG_POSES[:24].tolist()},
        encoder=CATALOGUE[:3],
        residual={"u": 3.0},
    )
    a = tl.allocate(tl.parse_spec(d))
    assert a.ratio <= 1.0 + 1e-12
    chk = tl.monte_carlo_check(a, trials=100_000, seed=11)
    assert chk.trials == 100_000 and chk.rows.size == 24
    assert chk.met and chk.verdict == "met"
    assert chk.worst_within >= 0.95
    se = math.sqrt(chk.worst_within * (1 - chk.worst_within) / 1e5)
    assert math.isclose(chk.worst_within_se, se, rel_tol=1e-12)
    # the design is tight: the governing pose is close to its 95 % (not 99 %)
    g = int(np.flatnonzero(chk.rows == a.governing_row)[0])
    assert 0.95 <= chk.within[g] < 0.965
    # independent: numpy forward model, own draws within the same tolerances
    rng = np.random.default_rng(99)
    n = 100_000
    delta = np.zeros((n, 25))
    for i, p in enumerate(a.params):
        h = p.tolerance * (ARCSEC if i < 12 else 1e-3)
        delta[:, i] = rng.uniform(-h, h, n)
    for r in a.encoders:
        e = r.encoder
        delta[:, r.joint - 1] += (
            rng.uniform(-e.accuracy_arcsec, e.accuracy_arcsec, n)
            + rng.uniform(-0.5, 0.5, n) * e.resolution_arcsec
        ) * ARCSEC
    pose = a.design.poses[a.governing_row]
    pts = _numpy_points(Params(), delta, pose) + rng.normal(0, 3e-3 / math.sqrt(3), (n, 3))
    err = np.linalg.norm(pts - Model().point(pose), axis=1)
    frac = float(np.mean(err <= 30e-3))
    assert frac >= 0.95 - 3 * math.sqrt(0.05 * 0.95 / n)
    assert abs(frac - chk.within[g]) < 5 * math.sqrt(0.05 * 0.95 / n) * math.sqrt(2)


def test_monte_carlo_flags_an_allocation_that_misses() -> None:
    # the same allocation checked against a tighter target fails, clearly
    a = tl.allocate(tl.parse_spec(doc(target={"value": 30.0})))
    tighter = replace(a, design=replace(a.design, limit_mm=a.design.limit_mm * 0.9))
    chk = tl.monte_carlo_check(tighter, trials=5_000, seed=1)
    assert chk.verdict == "not met" and not chk.met
    assert chk.worst_within < 0.93


def test_length_target() -> None:
    d = doc(
        target={
            "quantity": "length",
            "value": 20.0,
            "per_metre": 10.0,
            "over": "worst",
            "min_length_mm": 300,
        },
        workspace={"random": 60, "seed": 4},
        encoder=CATALOGUE[:3],
    )
    a = tl.allocate(tl.parse_spec(d))
    st = {p.name: p.status for p in a.params}
    # a rigid motion of the whole arm changes no length: theta1 and d1 need no tolerance
    assert st["theta1"] == "no effect" and st["d1"] == "no effect"
    assert math.isinf(a.params[0].tolerance)
    assert a.design.lengths_mm.min() >= 300
    assert np.allclose(a.limit_mm, 20e-3 + 10e-3 * a.design.lengths_mm / 1000)
    chk = tl.monte_carlo_check(a, trials=20_000, seed=3)
    assert chk.verdict in ("met", "within noise")
    assert chk.worst_within >= 0.95 - 2 * chk.worst_within_se


# ------------------------------------------------------------------ calibrated arm


def _design_observations() -> Any:
    from aacmm.calibration import Cone, LengthSet, Observations
    from calib_synth import bar_poses, cone_poses

    rng = np.random.default_rng(8)
    model = Model(Params())
    qs, _ = cone_poses(model, rng, 3, 12)
    qa, qb, lens = bar_poses(model, rng, 12)
    th = np.concatenate([*qs, qa, qb])
    cones = tuple(Cone(f"cone{i}", np.arange(12 * i, 12 * i + 12)) for i in range(3))
    n0 = 36
    # the bar positions have different lengths: one set per position
    lengths = tuple(
        LengthSet(f"bar{i}", float(lens[i]), (np.array([n0 + i]),), (np.array([n0 + 12 + i]),))
        for i in range(12)
    )
    return Observations(th, np.full(th.shape[0], 0.005), cones + lengths)


def test_calibration_map_is_the_least_squares_correction() -> None:
    from aacmm.calibration import Problem

    obs = _design_observations()
    cal = tl.CalibrationModel.from_observations(obs)
    assert "theta1" in cal.fixed and "d1" in cal.fixed
    m = cal.error_map()
    assert np.allclose(m[:, cal.identified_mask], 0.0, atol=1e-9)
    # explicit: an arm off by dq; the calibration fits the identified parameters to
    # the (linearised, noise-free) residuals A dq; what is left is dq - fit
    a_mat = Problem(obs).evaluate(Params()).jac
    rng = np.random.default_rng(3)
    for _ in range(3):
        dq = rng.normal(0, 1e-4, 25)
        ident = cal.identified_mask
        fit, *_ = np.linalg.lstsq(a_mat[:, ident], a_mat @ dq, rcond=None)
        left = dq.copy()
        left[ident] -= fit
        assert np.allclose(m @ dq, left, rtol=1e-6, atol=1e-12)


def test_calibrated_arm_needs_tolerance_only_where_calibration_cannot_reach() -> None:
    # cones and lengths cannot see a rotation about axis 1 or a shift along it
    # (theta1, d1), nor split the tip vector (theta6, alpha6 held): the probe
    # point in the base frame still depends on theta1 and d1, not on the tip split
    obs = _design_observations()
    cal = tl.CalibrationModel.from_observations(obs)
    d = doc(
        target={"value": 60.0, "over": "worst"},
        workspace={"random": 30, "seed": 2},
        parameters={
            "theta": {"c": 4.0, "max": 3600},
            "alpha": {"c": 6.0, "max": 3600},
            "d": {"c": 30.0, "max": 1000},
            "a": {"c": 20.0, "max": 1000},
            "l": {"c": 10.0, "max": 1000},
        },
        residual={"u": 2.0},
    )
    spec = tl.parse_spec(d)
    a = tl.allocate(spec, calibration=cal)
    st = {p.name: p.status for p in a.params}
    assert set(a.set_by_calibration) == set(cal.identified)
    assert all(st[n] == "calibrated" for n in cal.identified)
    assert set(a.needs_tolerance) == {"theta1", "d1"}
    assert st["theta6"] == st["alpha6"] == "no effect"
    assert "calibration" in a.fixed_terms and "residual" in a.fixed_terms
    assert math.isclose(a.ratio, 1.0, rel_tol=1e-9)
    # the uncalibrated arm needs far tighter (dearer) tolerances for the same target
    raw = tl.allocate(spec)
    assert raw.tolerance_cost > 10 * a.tolerance_cost
    chk = tl.monte_carlo_check(a, trials=20_000, seed=5)
    assert chk.verdict in ("met", "within noise")
    assert chk.worst_within >= 0.95 - 2 * chk.worst_within_se
    # a length target sees neither theta1 nor d1: no manufacturing tolerance at all
    length = replace(spec, target=tl.Target("length", 0.04, "worst", min_length_mm=300))
    al = tl.allocate(length, calibration=cal)
    assert al.needs_tolerance == ()


def test_calibration_plan_in_the_spec() -> None:
    # [calibration] plan = the shipped kinematic-calibration plan: the same model
    # as composing the simulated operator's poses and the calibration's
    # plan-to-observations mapping by hand
    from aacmm.calibration.sessions import observations_from_plan
    from aacmm.plans import load_plan
    from aacmm.simulation.scenario import plan_poses

    d = doc(
        target={"value": 60.0},
        workspace={"random": 30, "seed": 2},
        calibration={"plan": "kinematic-calibration", "sigma": 5.0, "seed": 3},
    )
    spec = tl.parse_spec(d)
    assert spec.calibration == tl.CalibrationDesign("kinematic-calibration", 0.005, 3)
    a = tl.allocate(spec)
    assert a.design.calibration is not None
    assert "kinematic-calibration" in a.design.calibration.source
    plan = load_plan("kinematic-calibration")
    obs, used, _ = observations_from_plan(plan, plan_poses(plan, Params(), 3), 0.005)
    assert len(used) == len(plan.steps)
    direct = tl.allocate(spec, calibration=tl.CalibrationModel.from_observations(obs))
    assert np.allclose(a.t, direct.t, rtol=1e-12)
    assert set(a.needs_tolerance) == {"theta1", "d1"}
    assert {"theta6", "alpha6"} <= {p.name for p in a.params if p.status == "no effect"}
    with pytest.raises(tl.SpecError, match=r"\[calibration\]\.plan"):
        tl.allocate(replace(spec, calibration=tl.CalibrationDesign("no-such-plan")))


# ------------------------------------------------------------------ errors and CLI


def test_infeasible_target_names_the_limit() -> None:
    d = doc(target={"value": 3.0}, encoder=CATALOGUE[:2])
    with pytest.raises(InfeasibleError, match="encoders alone"):
        tl.allocate(tl.parse_spec(d))
    d = doc(target={"value": 3.0}, parameters={**doc()["parameters"], "d": {"c": 1, "min": 5}})
    with pytest.raises(InfeasibleError, match="process minimum"):
        tl.allocate(tl.parse_spec(d))


BAD = [
    ({"target": {}}, "[target]"),
    ({"target": {"value": -1}}, "[target]"),
    ({"target": {"value": 30, "over": "mean"}}, "[target].over"),
    ({"target": {"value": 30, "coverage": 1.5}}, "coverage"),
    ({"target": {"value": 30, "per_metre": 2}}, "[target].per_metre"),
    ({"parameters": {"theta": {"c": 1}}}, "no cost model or tolerance for alpha1"),
    ({"parameters": {**doc()["parameters"], "d3": {"c": 1, "k": -2}}}, "[parameters] d3"),
    ({"parameters": {**doc()["parameters"], "q": {"c": 1}}}, "[parameters] q"),
    ({"parameters": {**doc()["parameters"], "l": {"c": 1, "min": 5, "max": 2}}}, "[parameters] l"),
    ({"parameters": {**doc()["parameters"], "l": {"tolerance": 3, "c": 1}}}, "[parameters] l"),
    ({"encoder": [{"name": "x", "bits": 20, "cost": 1}]}, "[[encoder]] 'x'.accuracy_arcsec"),
    ({"encoder": [{"name": "x", "accuracy_arcsec": 1, "cost": 1}]}, "resolution_arcsec or bits"),
    ({"encoder": [{**CATALOGUE[0], "joints": [1, 2]}]}, "joint 3"),
    ({"workspace": {"poses": [[1, 2, 3]]}}, "[workspace].poses"),
    ({"workspace": {"random": 0}}, "no poses"),
    ({"workspace": {"log": "missing.csv"}}, "[workspace].log"),
    ({"residual": {"u": -1}}, "[residual].u"),
    ({"calibration": {"sigma": 5.0}}, "[calibration].plan"),
    ({"calibration": {"plan": "kinematic-calibration", "free": ["q"]}}, "[calibration].free"),
    ({"calibration": {"plan": "kinematic-calibration", "sigma": 0}}, "[calibration]"),
    ({"calibration": {"plan": "kinematic-calibration", "bogus": 1}}, "bogus"),
    ({"length_unit": "inch"}, "length_unit"),
    ({"bogus": 1}, "bogus"),
]


@pytest.mark.parametrize(("change", "field"), BAD)
def test_bad_spec_names_file_and_field(tmp_path: Path, change: dict[str, Any], field: str) -> None:
    import tomli_w

    p = tmp_path / "arm.toml"
    d = doc()
    d.update(change)  # whole sections replaced
    p.write_text(tomli_w.dumps(d), encoding="utf-8")
    with pytest.raises(tl.SpecError) as e:
        tl.load_spec(p)
    assert str(e.value).startswith(f"{p}: ")
    assert field in str(e.value)


def test_cli_example_outputs_and_exit_codes(tmp_path: Path) -> None:
    j, c, g = tmp_path / "a.json", tmp_path / "a.csv", tmp_path / "a.png"
    p = run(
        "tolerance",
        "example",
        "--trials",
        "2000",
        "--check-rows",
        "5",
        "--json",
        str(j),
        "--csv",
        str(c),
        "--png",
        str(g),
        timeout=240,
    )
    assert p.returncode == 0, p.stderr
    assert "Monte Carlo check: 2000 arms" in p.stdout and "target met" in p.stdout
    data = json.loads(j.read_text())
    assert len(data["parameters"]) == 25 and len(data["encoders"]) == 6
    assert data["monte_carlo"]["trials"] == 2000 and data["design"]["ratio"] <= 1 + 1e-9
    rows = c.read_text().splitlines()
    assert rows[0].startswith("kind,name,unit,tolerance") and len(rows) >= 1 + 25 + 6
    assert g.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # outputs are never overwritten without --force, and nothing is computed first
    again = run("tolerance", "example", "--json", str(j))
    one_error_line(again, 2, "exists", "--force")


def test_cli_infeasible_is_exit_8(tmp_path: Path) -> None:
    import tomli_w

    p = tmp_path / "tight.toml"
    p.write_text(tomli_w.dumps(doc(target={"value": 3.0}, encoder=CATALOGUE[:2])))
    r = run("tolerance", str(p), "--trials", "0")
    line = one_error_line(r, 8, "infeasible", "encoders alone")
    assert "3 um" in line


def test_cli_not_met_is_exit_7(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A Monte Carlo check that does not confirm the target: exit 7, report and files written.

    The check is run, for real, against 0.9 x the allocation's limit (as in
    test_monte_carlo_flags_an_allocation_that_misses): the command itself is unchanged."""
    from aacmm.cli import main

    real = tl.monte_carlo_check

    def tighter(a: tl.Allocation, **kw: Any) -> tl.CheckResult:
        return real(replace(a, design=replace(a.design, limit_mm=a.design.limit_mm * 0.9)), **kw)

    monkeypatch.setattr(tl, "monte_carlo_check", tighter)
    j = tmp_path / "a.json"
    code = main(["tolerance", "example", "--trials", "5000", "--json", str(j), "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 7, err
    assert err.strip().splitlines() == [
        "aacmm tolerance: the Monte Carlo check does not confirm the target (report written)"
    ]
    assert "NOT MET" in out or "not met" in out
    assert json.loads(j.read_text())["monte_carlo"]["verdict"] == "not met"


def test_cli_bad_spec_is_exit_2(tmp_path: Path) -> None:
    p = tmp_path / "bad.toml"
    p.write_text('[target]\nvalue = "thirty"\n')
    one_error_line(run("tolerance", str(p)), 2, str(p), "[target].value")
    p.write_text("[target\n")
    one_error_line(run("tolerance", str(p)), 2, str(p), "TOML")
    one_error_line(run("tolerance", "example", "--trials", "5"), 2, "--trials")


def test_unreadable_spec(tmp_path: Path) -> None:
    with pytest.raises(tl.SpecError, match=r"none\.toml"):
        tl.load_spec(tmp_path / "none.toml")


def test_workspace_from_a_log(tmp_path: Path) -> None:
    log = tmp_path / "run.csv"
    th = np.radians(RNG_POSES[:30])
    log.write_text(
        "# aacmm log\nt_s,theta1,theta2,theta3,theta4,theta5,theta6\n"
        + "".join(f"{i},{','.join(repr(float(x)) for x in row)}\n" for i, row in enumerate(th))
    )
    d = doc(workspace={"log": "run.csv", "log_max": 10})
    spec_path = tmp_path / "s.toml"
    import tomli_w

    del d["workspace"]["poses"]
    spec_path.write_text(tomli_w.dumps(d))
    spec = tl.load_spec(spec_path)
    poses = spec.workspace.poses()
    assert poses.shape == (10, 6)
    assert np.allclose(poses[0], th[0]) and np.allclose(poses[-1], th[-1])
    assert "from" in spec.workspace.describe()


def test_special_functions_used_by_the_radius_factor() -> None:
    # the chi-square(3) CDF used inside radius_factor: erf form vs scipy
    x = np.linspace(0.01, 20, 50)
    g = np.sqrt(x * 2 / np.pi) * np.exp(-x / 2)
    assert np.allclose(special.erf(np.sqrt(x / 2)) - g, stats.chi2.cdf(x, 3), atol=1e-14)


def test_cli_unbounded_checks_are_refused_with_the_estimate(tmp_path: Path) -> None:
    """Issue 29.3: `tolerance example --trials 10^12` ended in a numpy traceback
    ("182 TiB"). The check's memory is estimated before the allocation and its
    time by a pilot check of 2000 arms; beyond half the memory available or
    --max-hours it is refused with the estimate (one line, exit 2, no file)."""
    import tomli_w

    spec = tmp_path / "s.toml"
    spec.write_text(tomli_w.dumps(doc()))
    j = tmp_path / "a.json"
    r = run("tolerance", str(spec), "--trials", "1000000000000", "--json", str(j))
    line = one_error_line(r, 2, "the Monte Carlo check of 10^12 arms at 20 rows", "TiB")
    assert "needs about" in line and "more than half the" in line and "use fewer --trials" in line
    r = run("tolerance", str(spec), "--trials", "1000000", "--max-hours", "0.0001",
            "--json", str(j), timeout=240)  # fmt: skip
    line = one_error_line(r, 2, "the Monte Carlo check of 10^6 arms would take about")
    assert "arm-rows at" in line and "more than the limit of 0 s" in line
    assert list(tmp_path.iterdir()) == [spec]
