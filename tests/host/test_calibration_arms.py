"""Calibration and simulation of arms other than the paper's (issue 26), at library level.

Two arms built here with :class:`aacmm.arm.Arm`:

* FIVE: 5 axes in modified DH (base roll, shoulder, elbow, forearm roll, wrist)
  with the shoulder and elbow parallel, a Hayati beta on the elbow, a stylus
  as a tip vector;
* SEVEN: 7 axes in standard DH (the paper's alternating rolls and hinges plus
  a handle roll), a stylus offset from the last axis.

The data: a random true geometry of the arm (:func:`random_truth`), a
calibration plan scaled to the arm's reach, the simulated operator's
articulations within the arm's joint limits (:func:`choreograph`) probed with
no device (:class:`RecordingChannel`): the counts the true encoders give at
each press, turned into angles with the nominal encoder configuration as the
device would. The calibration sees only those; the truth is read here, after.

Checked against computations written here: the rank and the null space of the
nuisance-projected Jacobian (seat points centred, lengths along the bar),
built from the core's point Jacobians and decomposed by numpy's SVD; the null
directions' meaning (a rigid motion of every point, or no motion at all);
the length error on other articulations and the point error against the
truth at random poses (after the best rigid fit, the base's unobservable
motion) falling >= 20x; for the parallel hinges the condition number with
and without the beta.
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
from aacmm.arm import Arm, Joint
from aacmm.calibration import Observations, calibrate, report
from aacmm.calibration.observations import Cone, LengthSet
from aacmm.calibration.probe import calibrate_probe
from aacmm.calibration.sessions import observations_from_plan
from aacmm.calibration.validation import measure
from aacmm.core import Model, counts_to_angles
from aacmm.models import load_model
from aacmm.plans import Plan, loads_plan
from aacmm.simulation.ik import Arm as IkArm
from aacmm.simulation.ik import JointLimits
from aacmm.simulation.operator import FAST, Operator, RecordingChannel
from aacmm.simulation.scenario import choreograph
from aacmm.simulation.truth import Truth, model_truth, random_truth

pytestmark = pytest.mark.timeout(600)

SIGMA_MM = 0.005
CPR = 1 << 24
PAPER_PLAN = Path(__file__).parents[2] / "host/src/aacmm/data/plans/kinematic-calibration.toml"
D = math.radians
FloatArray = npt.NDArray[np.float64]


def five_axis(beta: bool = True) -> Arm:
    """Shoulder (2) and elbow (3) parallel; beta on the elbow; the stylus along x5."""
    return Arm(
        joints=(
            Joint("modified", 0.0, 0.0, 210.0, 0.0),
            Joint("modified", 0.0, D(90.0), 0.0, 24.0),
            Joint("modified", 0.0, 0.0, 0.0, 260.0, 0.0 if beta else None),
            Joint("modified", 0.0, D(-90.0), 230.0, 0.0),
            Joint("modified", 0.0, D(90.0), 0.0, 0.0),
        ),
        tip="xyz",
        tip_mm=(110.0, 0.0, 0.0),
    )


FIVE_LIMITS = JointLimits.around((0, 0, 0, 0, 0), (None, 120, 150, None, 150))


def seven_axis() -> Arm:
    d = (300.0, 65.5, 650.0, 65.5, 600.0, 0.0, 100.0)
    return Arm(
        joints=tuple(Joint("standard", 0.0, D(90.0) if i < 6 else 0.0, x) for i, x in enumerate(d)),
        tip="xyz",
        tip_mm=(40.0, 0.0, 90.0),
    )


SEVEN_LIMITS = JointLimits.around(
    (0, 180, 0, 180, 0, 180, 0), (None, 120, None, 155, None, 115, None)
)


def scaled_plan(scale: float) -> Plan:
    """The shipped kinematic-calibration plan (3 seats x 25, 30 bar positions) with
    every location and length scaled to an arm of another reach; exact lengths."""
    d = tomllib.loads(PAPER_PLAN.read_text())
    out = ['format = "aacmm-plan-1"', 'title = "scaled calibration"', "[probe]"]
    out.append("ball_diameter_mm = 6.0")
    for name, a in d["artefacts"].items():
        out += [f"[artefacts.{name}]", f'type = "{a["type"]}"']
        if "location_mm" in a:
            xyz = ", ".join(f"{x * scale:.3f}" for x in a["location_mm"])
            out.append(f"location_mm = [{xyz}]")
        if "length_mm" in a:
            out += [f"length_mm = {a['length_mm'] * scale:.4f}", 'ends = "cone"']
    for st in d["steps"]:
        out += ["[[steps]]", f'id = "{st["id"]}"', f'procedure = "{st["procedure"]}"']
        out.append(f'artefact = "{st["artefact"]}"')
        if "articulations" in st:
            out.append(f"articulations = {st['articulations']}")
        if "positions" in st:
            items = []
            for p in st["positions"]:
                centre = ", ".join(f"{x * scale:.2f}" for x in p["centre_mm"])
                direction = ", ".join(str(x) for x in p["direction"])
                items.append(f"{{ centre_mm = [{centre}], direction = [{direction}] }}")
            out.append(f"positions = [{', '.join(items)}]")
    return loads_plan("\n".join(out) + "\n", "scaled")


@dataclasses.dataclass
class Capture:
    obs: Observations
    theta_true: FloatArray  # the operator's true angles (checks only)
    within_limits: bool
    spread_deg: dict[str, list[float]]


def capture(truth: Truth[Arm], plan: Plan, limits: JointLimits, seed: int) -> Capture:
    """The simulated operator probing ``plan`` on the true arm, no device."""
    rng = np.random.default_rng(seed)
    choreo = choreograph(plan, IkArm(truth.params), rng, limits)
    op = Operator(RecordingChannel(), truth, rng, FAST, limits)
    presses = [op.probe(p.target_mm, p.theta, p.slot.text) for p in choreo.points]
    counts = np.array([p.counts for p in presses])
    nominal_encoders = truth.encoders  # cpr, zero 0, direction +1: what the device stores
    theta = counts_to_angles(counts, nominal_encoders)
    obs, _, _ = observations_from_plan(plan, theta, SIGMA_MM)
    true = np.array([p.theta_rad for p in presses])
    inside = all(limits.contains(q) for q in true)
    return Capture(obs, true, inside, choreo.spread_deg)


@dataclasses.dataclass
class Case:
    nominal: Arm
    limits: JointLimits
    truth: Truth[Arm]
    cal: Capture
    check: Capture


def make_case(nominal: Arm, limits: JointLimits, scale: float, seed: int) -> Case:
    truth = random_truth(seed, nominal, cpr=CPR)
    plan = scaled_plan(scale)
    return Case(
        nominal,
        limits,
        truth,
        capture(truth, plan, limits, seed + 1),
        capture(truth, plan, limits, seed + 2),
    )


@pytest.fixture(scope="module")
def five() -> Case:
    return make_case(five_axis(), FIVE_LIMITS, 0.32, 3)


@pytest.fixture(scope="module")
def seven() -> Case:
    return make_case(seven_axis(), SEVEN_LIMITS, 0.75, 5)


# ----------------------------------------------------------------- independent checks


def projected_jacobian(obs: Observations, arm: Arm) -> FloatArray:
    """Whitened Jacobian of seat and exact-length residuals with the seat centres
    eliminated (each seat's rows centred on its mean): written here from the
    core's point Jacobians, independent of aacmm.calibration.problem."""
    p, j = Model(arm).points_jacobians(obs.theta_rad)
    rows = []
    for c in obs.constraints:
        if isinstance(c, Cone):
            jc = j[c.poses]
            rows.append((jc - jc.mean(axis=0)).reshape(-1, j.shape[2]) / SIGMA_MM)
        elif isinstance(c, LengthSet):
            for ea, eb in zip(c.ends_a, c.ends_b, strict=True):
                d = p[ea].mean(axis=0) - p[eb].mean(axis=0)
                u = d / np.linalg.norm(d)
                g = u @ (j[ea].mean(axis=0) - j[eb].mean(axis=0))
                rows.append(g[None, :] / (SIGMA_MM * math.sqrt(2.0)))
    return np.vstack(rows)


def column_norms(obs: Observations, arm: Arm) -> FloatArray:
    """Each parameter's whole effect on the probe points (unprojected): the column scale
    (a rigid motion's projected column is zero, its effect on the points is not)."""
    _, j = Model(arm).points_jacobians(obs.theta_rad)
    out: FloatArray = np.sqrt(np.einsum("nak,nak->k", j, j))
    return out


def svd_rank_null(
    a: FloatArray, cols: list[int], norms_all: FloatArray
) -> tuple[int, FloatArray, FloatArray]:
    """Rank (singular values above 1e-4 of the largest: the symmetries' spurious
    values, ~ residuals / lever, sit near 1e-5), null basis in parameter units
    (P, k), singular values."""
    sub = a[:, cols]
    norms = norms_all[cols]
    _, s, vt = np.linalg.svd(sub / norms, full_matrices=True)
    rank = int(np.sum(s > 1e-4 * s[0]))
    null = np.zeros((a.shape[1], len(cols) - rank))
    null[cols, :] = (vt[rank:].T) / norms[:, None]
    return rank, null, s


def rigid_residual(points: FloatArray, motion: FloatArray) -> float:
    """How far a displacement field is from a rigid one (omega x p + t), relative."""
    n = points.shape[0]
    a = np.zeros((3 * n, 6))
    for i, q in enumerate(points):
        a[3 * i : 3 * i + 3, :3] = -np.array(
            [[0.0, -q[2], q[1]], [q[2], 0.0, -q[0]], [-q[1], q[0], 0.0]]
        )
        a[3 * i : 3 * i + 3, 3:] = np.eye(3)
    b = motion.reshape(-1)
    x, *_ = np.linalg.lstsq(a, b, rcond=None)
    return float(np.linalg.norm(a @ x - b) / max(float(np.linalg.norm(b)), 1e-300))


def kabsch_error(p: FloatArray, q: FloatArray) -> float:
    """Largest distance between point sets after the best rigid fit of p onto q."""
    pc, qc = p - p.mean(axis=0), q - q.mean(axis=0)
    u, _, vt = np.linalg.svd(pc.T @ qc)
    r = (u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt).T
    return float(np.max(np.linalg.norm(pc @ r.T - qc, axis=1)))


def expected_null(arm: Arm) -> list[str]:
    """The named null space an arm's shape predicts (cones and exact lengths):
    theta1, d1 (+ alpha1, a1 for a modified first joint) and the tip's split:
    (last joint's theta offset, what its convention applies after the rotation,
    the tip) minus the 3 components of the tip in that frame."""
    base = ["theta1", "d1"] + (["alpha1", "a1"] if arm.joints[0].convention == "modified" else [])
    after = 3 if arm.joints[-1].convention == "standard" else 1
    tip = 1 + after + (3 if arm.tip == "xyz" else 1) - 3
    return sorted(base + ["tip"] * tip)


# ----------------------------------------------------------------- the tests


@pytest.mark.parametrize("which", ["five", "seven"])
def test_end_to_end_lengths_and_points_fall_20x(which: str, request: pytest.FixtureRequest) -> None:
    case: Case = request.getfixturevalue(which)
    assert case.cal.within_limits and case.check.within_limits
    # the articulations use every joint (a seat is probed with each joint turned)
    for spread in case.cal.spread_deg.values():
        assert len(spread) == case.nominal.n_joints
    assert (
        min(max(s[k] for s in case.cal.spread_deg.values()) for k in range(case.nominal.n_joints))
        > 20
    )
    res = calibrate(case.cal.obs, case.nominal)
    assert isinstance(res.params, Arm) and res.params.n_joints == case.nominal.n_joints
    before = measure(case.check.obs, case.nominal)
    after = measure(case.check.obs, res.params)
    length_fall = before.length_rms / after.length_rms
    spat_fall = before.cone_spat.max() / after.cone_spat.max()
    # point error: the calibrated model at the measured angles against the true probed
    # points of the check capture, the base's unobservable rigid motion removed
    true = case.truth.model().points(case.check.theta_true)
    err_before = kabsch_error(Model(case.nominal).points(case.check.obs.theta_rad), true)
    err_after = kabsch_error(Model(res.params).points(case.check.obs.theta_rad), true)
    print(
        f"{which}: length rms {before.length_rms * 1e3:.1f} -> {after.length_rms * 1e3:.2f} um "
        f"({length_fall:.0f}x), SPAT {before.cone_spat.max() * 1e3:.1f} -> "
        f"{after.cone_spat.max() * 1e3:.2f} um ({spat_fall:.0f}x), point error "
        f"{err_before * 1e3:.1f} -> {err_after * 1e3:.2f} um ({err_before / err_after:.0f}x)"
    )
    assert length_fall >= 20 and spat_fall >= 20
    assert err_before / err_after >= 20


@pytest.mark.parametrize("which", ["five", "seven"])
def test_rank_and_named_null_space_against_an_independent_svd(
    which: str, request: pytest.FixtureRequest
) -> None:
    case: Case = request.getfixturevalue(which)
    res = calibrate(case.cal.obs, case.nominal)
    idn = res.identifiability
    arm = res.params
    assert isinstance(arm, Arm)
    names = arm.param_names
    # Hayati: the d of a joint with a beta is not estimated (the beta replaces it)
    hayati = [f"d{j + 1}" for j in arm.beta_joints]
    assert set(res.fixed) == set(hayati)
    cols = [k for k, n in enumerate(names) if n not in hayati]
    a = projected_jacobian(case.cal.obs, arm)
    scale = column_norms(case.cal.obs, arm)
    rank, null, s = svd_rank_null(a, cols, scale)
    print(f"{which}: rank {rank} of {len(cols)}, singular values {s[rank - 1]:.3g} | {s[rank]:.3g}")
    assert s[rank - 1] > 100 * s[rank]  # a clean gap
    assert idn.rank == rank
    assert len(idn.null) == len(cols) - rank
    assert sorted(d.kind for d in idn.null) == expected_null(case.nominal)
    # every named direction lies in the independent null space (below the rank threshold
    # in the same scaled coordinates) ...
    for d in idn.null:
        v = d.vector
        assert np.linalg.norm(a @ v) <= 1e-4 * s[0] * np.linalg.norm(v * scale)
    # ... and they span it (scaled coordinates: both bases together have its dimension)
    named = np.column_stack([d.vector for d in idn.null]) * scale[:, None]
    ours = null * scale[:, None]
    named /= np.linalg.norm(named, axis=0)
    ours /= np.linalg.norm(ours, axis=0)
    assert np.linalg.matrix_rank(np.column_stack([named, ours]), tol=1e-3) == null.shape[1]
    # what they mean: the base directions move every probe point rigidly, the tip's not at all
    p, j = Model(arm).points_jacobians(case.cal.obs.theta_rad)
    for d in idn.null:
        motion = j @ d.vector
        if d.kind == "tip":
            assert np.max(np.abs(motion)) < 1e-9 * np.max(np.abs(j @ np.abs(d.vector)))
        else:
            assert d.kind in ("theta1", "d1", "alpha1", "a1")
            assert np.max(np.abs(motion)) > 1e-3
            assert rigid_residual(p, motion) < 1e-9
    # the held set makes the rest identifiable
    free = [k for k in cols if names[k] not in res.held]
    sf = np.linalg.svd(a[:, free] / scale[free], compute_uv=False)
    assert sf[-1] > 1e-4 * s[0]
    # the reports use the arm's own parameters
    data = report.to_json(res)
    assert list(data["calibrated"]) == list(names) and list(data["units"].values()) == list(
        arm.param_units
    )
    text = report.format_parameters(res)
    assert all(f"  {n} " in text for n in names)
    assert len(free) == rank


def test_parallel_hinges_condition_with_and_without_beta(five: Case) -> None:
    """At the true geometry (axes 2 and 3 parallel to within the truth's 0.05 deg),
    free parameters less the exact symmetries: without the beta the common
    normal's position along the two axes (d2 against d3) is nearly free, so the
    Jacobian is ill-conditioned; with it (d3 replaced by beta3) it is not."""
    truth = five.truth.params
    assert isinstance(truth, Arm)
    no_beta = Arm(
        joints=tuple(dataclasses.replace(j, beta_rad=None) for j in truth.joints),
        tip=truth.tip,
        tip_mm=truth.tip_mm,
    )
    held = {"theta1", "d1", "alpha1", "a1", "theta5", "d5"}  # base and tip symmetries

    def condition(arm: Arm, drop: set[str]) -> float:
        a = projected_jacobian(five.cal.obs, arm)
        scale = column_norms(five.cal.obs, arm)
        cols = [k for k, n in enumerate(arm.param_names) if n not in drop]
        s = np.linalg.svd(a[:, cols] / scale[cols], compute_uv=False)
        return float(s[0] / s[-1])

    with_beta = condition(truth, held | {"d3"})
    without = condition(no_beta, held)
    print(f"parallel hinges: condition number with beta {with_beta:.3g}, without {without:.3g}")
    assert with_beta < 100.0
    assert without > 1e5
    # the engine names the same direction on the model without beta, at its nominal
    res = calibrate(five.cal.obs, five_axis(beta=False))
    kinds = [d.kind for d in res.identifiability.null]
    assert "parallel" in kinds
    par = next(d for d in res.identifiability.null if d.kind == "parallel")
    assert sorted(n for n, _ in par.components) == ["d2", "d3"]
    with_res = calibrate(five.cal.obs, five.nominal)
    assert "parallel" not in [d.kind for d in with_res.identifiability.null]
    assert with_res.identifiability.condition_number < 100.0


def test_probe_calibration_of_a_general_arm(seven: Case) -> None:
    """The tip of the 7-axis arm from its seats alone: the tip in the last frame
    after = the truth's (computed here with a 4x4 product), to the noise."""
    truth = seven.truth.params
    assert isinstance(truth, Arm)
    seats = Observations(
        seven.cal.obs.theta_rad,
        seven.cal.obs.sigma_mm,
        tuple(c for c in seven.cal.obs.constraints if isinstance(c, Cone)),
    )
    # start: the truth but the tip (what a probe calibration assumes: the arm known)
    start = dataclasses.replace(truth, tip_mm=seven.nominal.tip_mm)
    pr = calibrate_probe(seats, start)

    def tip_frame(arm: Arm) -> FloatArray:
        j = arm.joints[-1]
        c, s = math.cos(j.theta_offset_rad), math.sin(j.theta_offset_rad)
        rz = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
        tz = np.eye(4)
        tz[2, 3] = j.d_mm
        tx = np.eye(4)
        tx[0, 3] = j.a_mm
        ca, sa = math.cos(j.alpha_rad), math.sin(j.alpha_rad)
        rx = np.array([[1, 0, 0, 0], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1.0]])
        out: FloatArray = (rz @ tz @ tx @ rx @ np.array([*arm.tip_mm, 1.0]))[:3]
        return out

    before = np.linalg.norm(tip_frame(start) - tip_frame(truth))
    after = np.linalg.norm(pr.tip_after - tip_frame(truth))
    assert before > 0.1
    assert after < 0.02 and after < before / 20


@pytest.mark.parametrize("name", ["commercial7", "mpe2018", "gao2013"])
def test_shipped_models_end_to_end(name: str) -> None:
    """A shipped model (aacmm.models) through the simulation library: its random
    truth (its encoders), its joint limits, the plan scaled to its reach;
    calibrated from its nominal arm, then checked against the truth."""
    model = load_model(name)
    limits = JointLimits.from_ranges(model.joint_limits_rad)
    truth = model_truth(3, model)
    assert truth.encoders == model.encoder_config()
    plan = scaled_plan(model.reach_mm / load_model("gao2013").reach_mm)
    cal, check = capture(truth, plan, limits, 4), capture(truth, plan, limits, 5)
    assert cal.within_limits and check.within_limits
    assert all(model.within_limits(q) for q in cal.theta_true)
    res = calibrate(cal.obs, model.arm)
    assert sorted(d.kind for d in res.identifiability.null) == expected_null(model.arm)
    before, after = measure(check.obs, model.arm), measure(check.obs, res.params)
    length_fall = before.length_rms / after.length_rms
    spat_fall = before.cone_spat.max() / after.cone_spat.max()
    print(f"{name}: length error falls {length_fall:.0f}x, SPAT {spat_fall:.0f}x")
    assert length_fall >= 20 and spat_fall >= 20


def test_quality_gate_of_a_general_arm(five: Case) -> None:
    """The gate on the 5-axis arm's calibration: a modified first joint's alpha1 and a1
    are rigid motions of the base (symmetries, like theta1 and d1), so the rank check
    passes; the uncertainty check reads the arm's own units (beta3 an angle, tx a
    length), and a limit below what the data give refuses by those names."""
    from aacmm.calibration.gate import GateLimits, assess

    res = calibrate(five.cal.obs, five.nominal)
    kinds = {d.kind for d in res.identifiability.null}
    assert {"alpha1", "a1"} <= kinds
    gate = assess(res)
    assert gate.passed, gate.refusals
    names, units = res.params.param_names, res.params.param_units
    sd = dict(zip(names, res.scaled_std, strict=True))
    assert "beta3" in res.free and "tx" in res.free
    tight = GateLimits(max_u_length_mm=sd["tx"] * 0.99, max_u_angle_rad=sd["beta3"] * 0.99)
    # the offenders, by each parameter's own unit (computed here)
    over = {
        n
        for n, u in zip(names, units, strict=True)
        if n in res.free
        and sd[n] > (tight.max_u_angle_rad if u == "rad" else tight.max_u_length_mm)
    }
    assert {"tx", "beta3"} <= over
    msg = next(r.message for r in assess(res, limits=tight).refusals if r.check == "uncertainty")
    shown = re.findall(r"(\w+) u = [\d.e+-]+( um|\")", msg)
    assert {n for n, _ in shown} <= over and len(shown) == min(3, len(over))
    for n, unit in shown:
        assert unit.strip() == ("um" if units[names.index(n)] == "mm" else '"'), (n, unit)
    assert (f"and {len(over) - 3} more" in msg) == (len(over) > 3)
