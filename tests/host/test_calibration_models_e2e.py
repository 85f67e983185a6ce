"""``aacmm calibrate`` and ``aacmm verify`` on sessions of any arm model (issue 26), end to end.

For each model of :data:`MODELS` the simulator runs the model (``aacmm sim
--model``) with a random true arm of it (``--truth random:SEED``, hidden from
the device); the simulated operator probes the shipped plans while ``aacmm
capture`` records them, as a user runs it:

1. the verification plan with the device's nominal set, ``aacmm verify``;
2. the kinematic-calibration plan, ``aacmm calibrate`` (with its report and
   the point uncertainty), ``aacmm params set --save``;
3. the verification plan again, ``aacmm verify``; ``aacmm fit`` of its sphere.

Checked against things computed here, never against the commands' own
arithmetic alone:

- the length error E_Uni and the single-point articulation figure (SPAT)
  fall >= 20x from the first verification to the last, and the calibrated
  arm's points are near the truth's (the truth is read only here);
- the rank and the named null directions the calibration reports agree with
  an SVD of the nuisance-projected Jacobian built in this test from the core's
  point Jacobians of the session's own joint readings (seat points centred on
  their mean, lengths along the bar), at the calibrated arm, with the null
  kinds the arm's shape predicts;
- the reports name the arm's own P parameters (correlation figure, JSON, the
  propagated point uncertainty);
- sessions of two arm shapes, and ``--previous`` of another arm's
  calibration, are refused in one line with exit status 2 and no file.
"""

from __future__ import annotations

import json
import math
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from aacmm.arm import Arm
from aacmm.core import Model, Params
from aacmm.models import load_model
from aacmm.plans.model import Sphere as PlanSphere
from aacmm.records import read_session
from aacmm.records.paramfile import load_param_file
from aacmm.simulation.truth import load_truth
from clihelp import AACMM, cli_env, one_error_line, run

pytestmark = pytest.mark.timeout(600)

MODELS = ["gao2013", "commercial7"]
SEEDS = {"gao2013": 21, "commercial7": 23}
SIGMA_MM = 0.005  # aacmm calibrate's default probing uncertainty (--sigma-um 5)
E_UNI = "E_Uni:0:AArm"
SPAT = "SPAT (max - min)/2 per axis"
FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Case:
    model: str
    folder: Path
    provenance: dict[str, Any]
    before: dict[str, Any]  # aacmm verify's JSON report of the first verification
    after: dict[str, Any]


def _sim(folder: Path, model: str, seed: int, *extra: str) -> subprocess.Popen[str]:
    args = [str(AACMM), "sim", "--model", model, "--truth", f"random:{seed}"]
    args += ["--storage", str(folder / "arm.bin"), "--quiet", *extra]
    return subprocess.Popen(
        args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=cli_env()
    )


def _url(sim: subprocess.Popen[str]) -> str:
    assert sim.stdout is not None
    url = sim.stdout.readline().strip()
    assert url.startswith("serial://"), sim.stderr.read() if sim.stderr else ""
    return url


def _capture(folder: Path, model: str, plan: str, name: str, op_seed: int, *extra: str) -> Path:
    scenario = ("--scenario", plan, "--fast", "--seed", str(op_seed))
    sim = _sim(folder, model, SEEDS[model], *scenario, *extra)
    try:
        url = _url(sim)
        p = run("capture", plan, "-o", str(folder / name), "--port", url, "-q", timeout=240)
        assert p.returncode == 0, p.stderr
        _, err = sim.communicate(timeout=120)
        assert sim.returncode == 0, err
    finally:
        if sim.poll() is None:
            sim.kill()
            sim.wait()
    return folder / name


def _verify(folder: Path, name: str) -> dict[str, Any]:
    p = run("verify", str(folder / name), "--json", "-", timeout=120)
    assert p.returncode in (0, 7), p.stderr
    rep: dict[str, Any] = json.loads(p.stdout)
    return rep


def _value(rep: dict[str, Any], name: str) -> float:
    return float(next(r["value_mm"] for r in rep["results"] if r["name"] == name))


@pytest.fixture(scope="module")
def cases(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Case]:
    out = {}
    for model in MODELS:
        folder = tmp_path_factory.mktemp(model)
        truth_out = ("--truth-out", str(folder / "truth.toml"))
        _capture(folder, model, "arm-verification", "before", 1, *truth_out)
        before = _verify(folder, "before")
        _capture(folder, model, "kinematic-calibration", "cal", 2)
        cal = folder / "cal.toml"
        # the arm's own P parameters (issue 26): the arm alone, as these tests check it
        # against an independent SVD of its P columns (the harmonics: issue 27's tests)
        p = run(
            "calibrate", str(folder / "cal"), "-o", str(cal), "--report", str(folder / "rep"),
            "--workspace", "20", "-q", "--harmonics", "0", timeout=240,
        )  # fmt: skip
        assert p.returncode == 0, p.stdout[-2000:] + p.stderr
        sim = _sim(folder, model, SEEDS[model])
        try:
            r = run("params", "set", str(cal), "--save", "--port", _url(sim))
            assert r.returncode == 0, r.stderr
        finally:
            sim.terminate()
            sim.wait(timeout=30)
        _capture(folder, model, "arm-verification", "after", 3)
        prov = json.loads((folder / "cal.provenance.json").read_text())
        out[model] = Case(model, folder, prov, before, _verify(folder, "after"))
    return out


# ----------------------------------------------------------------- independent checks


def theta_limits(model: str) -> list[tuple[float, float]]:
    """Each joint's reading range (rad), one turn at most, from the model."""
    return [(max(a, -math.pi), min(b, math.pi)) for a, b in load_model(model).joint_limits_rad]


def _arm_of(path: Path) -> Params | Arm:
    """The kinematic model of a parameter file (the calibrated set)."""
    ps = load_param_file(path)
    return ps.to_core()[0] if ps.is_paper_shape else ps.to_arm()[0]


def projected_jacobian(session: Path, arm: Params | Arm) -> FloatArray:
    """Whitened residual Jacobian of the session's seats (rows centred on each seat's
    mean: the unknown seat centre eliminated) and bar lengths (along the bar), from
    the core's point Jacobians at the session's joint readings."""
    s = read_session(session)
    theta = s.angles_rad()
    p, j = Model(arm).points_jacobians(theta)
    steps: dict[str, list[int]] = {}
    for i, lab in enumerate(s.points):
        steps.setdefault(lab.step_id, []).append(i)
    rows = []
    for step in s.plan.steps:
        idx = steps.get(step.id, [])
        if step.procedure == "cone":
            jc = j[idx]
            rows.append((jc - jc.mean(axis=0)).reshape(-1, j.shape[2]) / SIGMA_MM)
        elif step.procedure == "length":
            ends: dict[int, dict[str, int]] = {}
            for i in idx:
                lab = s.points[i]
                assert lab.position_index is not None and lab.end is not None
                ends.setdefault(lab.position_index, {})[lab.end] = i
            for e in ends.values():
                d = p[e["A"]] - p[e["B"]]
                g = (d / np.linalg.norm(d)) @ (j[e["A"]] - j[e["B"]])
                rows.append(g[None, :] / (SIGMA_MM * math.sqrt(2.0)))
    return np.vstack(rows)


def expected_null(arm: Arm) -> list[str]:
    """The null space the arm's shape predicts from seats and lengths: theta1, d1 (+ alpha1,
    a1 for a modified first joint) and the tip's split: the last joint's theta offset, what
    its convention applies after the rotation and the tip, less the tip's 3 coordinates."""
    base = ["theta1", "d1"] + (["alpha1", "a1"] if arm.joints[0].convention == "modified" else [])
    after = 3 if arm.joints[-1].convention == "standard" else 1
    return sorted(base + ["tip"] * (1 + after + (3 if arm.tip == "xyz" else 1) - 3))


# ----------------------------------------------------------------- the tests


@pytest.mark.parametrize("model", MODELS)
def test_length_error_and_spat_fall_20x(model: str, cases: dict[str, Case]) -> None:
    c = cases[model]
    assert c.before["verdict"] == "FAIL" and c.after["verdict"] == "PASS"
    e0, e1 = abs(_value(c.before, E_UNI)), abs(_value(c.after, E_UNI))
    s0, s1 = _value(c.before, SPAT), _value(c.after, SPAT)
    print(f"{model}: E_Uni {e0 * 1e3:.1f} -> {e1 * 1e3:.2f} um ({e0 / e1:.0f}x), "
          f"SPAT {s0 * 1e3:.1f} -> {s1 * 1e3:.2f} um ({s0 / s1:.0f}x)")  # fmt: skip
    assert e0 >= 20 * e1 and s0 >= 20 * s1
    # the calibrated arm against the truth (read only here): distances between random
    # postures, the base's unobservable motion cancelling, >= 20x nearer than nominal
    truth = load_truth(c.folder / "truth.toml")
    assert (truth.params.n_joints if isinstance(truth.params, Arm) else 6) == len(
        theta_limits(model)
    )
    m = load_model(model)
    rng = np.random.default_rng(1)
    lo, hi = np.array(theta_limits(model)).T
    theta = rng.uniform(lo, hi, (400, m.n_joints))
    true = truth.model().points(theta)
    true_len = np.linalg.norm(true[0::2] - true[1::2], axis=1)

    def rms(arm: Params | Arm) -> float:
        q = Model(arm).points(theta)
        err = np.linalg.norm(q[0::2] - q[1::2], axis=1) - true_len
        return float(np.sqrt(np.mean(err**2)))

    nominal: Params | Arm = Params() if model == "gao2013" else m.arm
    assert rms(nominal) >= 20 * rms(_arm_of(c.folder / "cal.toml"))


@pytest.mark.parametrize("model", MODELS)
def test_rank_and_named_null_space_against_an_independent_svd(
    model: str, cases: dict[str, Case]
) -> None:
    c = cases[model]
    arm = _arm_of(c.folder / "cal.toml")
    shape = arm.to_arm() if isinstance(arm, Params) else arm
    names = shape.param_names
    idn = c.provenance["result"]["identifiability"]
    assert idn["parameters"] == list(names) and len(names) == load_model(model).n_params
    a = projected_jacobian(c.folder / "cal", arm)
    _, j = Model(arm).points_jacobians(read_session(c.folder / "cal").angles_rad())
    scale = np.sqrt(np.einsum("nak,nak->k", j, j))  # each parameter's effect on the points
    _, s, vt = np.linalg.svd(a / scale, full_matrices=True)
    rank = int(np.sum(s > 1e-4 * s[0]))
    print(f"{model}: rank {rank} of {len(names)}, singular values {s[rank - 1]:.3g} | "
          f"{s[rank]:.3g}")  # fmt: skip
    assert s[rank - 1] > 100 * s[rank]  # a clean gap
    assert idn["rank"] == rank
    null = idn["null_space"]
    assert len(null) == len(names) - rank
    assert sorted(d["kind"] for d in null) == expected_null(shape)
    # every named direction lies in this test's null space, and together they span it
    ours = vt[rank:].T  # in the column-scaled coordinates
    named = np.column_stack([np.asarray(d["vector"]) * scale for d in null])
    for k in range(named.shape[1]):
        v = named[:, k] / np.linalg.norm(named[:, k])
        assert np.linalg.norm((a / scale) @ v) <= 1e-4 * s[0]
    named /= np.linalg.norm(named, axis=0)
    assert np.linalg.matrix_rank(np.column_stack([named, ours]), tol=1e-3) == ours.shape[1]
    # the held parameters are what the fix strategy names; the rest were estimated
    res = c.provenance["result"]
    assert len(res["free"]) == rank and set(res["free"]) | set(res["held"]) == set(names)


@pytest.mark.parametrize("model", MODELS)
def test_reports_and_point_uncertainty_name_the_arms_parameters(
    model: str, cases: dict[str, Case]
) -> None:
    c = cases[model]
    names = list(load_model(model).arm.param_names)
    res = c.provenance["result"]
    assert list(res["calibrated"]) == names and list(res["std"]) == names
    assert np.asarray(res["covariance"]).shape == (len(names), len(names))
    assert c.provenance["quality_gate"]["passed"]
    pu = c.provenance["point_uncertainty"]
    assert list(pu["uncertainties"]) == names
    ws = pu["workspace_poses"]
    assert len(ws) == 20
    n = load_model(model).n_joints
    assert all(len(p["theta_rad"]) == n for p in ws)
    # linear and Monte Carlo agree, and the propagation is J Sigma J^T (recomputed here)
    arm = _arm_of(c.folder / "cal.toml")
    cov = np.asarray(res["covariance"])
    theta = np.array([p["theta_rad"] for p in ws])
    _, j = Model(arm).points_jacobians(theta)
    u_lin = np.sqrt(np.einsum("nak,kl,nal->na", j, cov, j))
    assert np.allclose([p["u_lin_mm"] for p in ws], u_lin, rtol=1e-6, atol=1e-12)
    u3 = np.array([[p["u3_lin_mm"], p["u3_mc_mm"]] for p in ws])
    assert np.all(np.abs(u3[:, 1] / u3[:, 0] - 1) < 0.05)
    for f in ("correlation.png", "uncertainty.png", "spectrum.png", "report.html"):
        assert (c.folder / "rep" / f).stat().st_size > 0, f
    text = (c.folder / "rep" / "report.txt").read_text()
    assert all(f"  {x} " in text for x in names)
    shape = f"(an arm of {n} joints, {len(names)} parameters)"
    assert (shape in text) == (model != "gao2013")  # the paper's report as before


def test_fit_on_sessions_of_the_seven_axis_arm(cases: dict[str, Case]) -> None:
    """``aacmm fit`` on the 7-axis arm's verification sessions: the probed sphere's
    radius (probe-compensated) is the plan's to a few um after calibration, and off by
    far more before (the nominal set on the random true arm)."""
    c = cases["commercial7"]
    s = read_session(c.folder / "after")
    step = next(st for st in s.plan.steps if st.procedure == "sphere")
    art = s.plan.artefact_of(step)
    assert isinstance(art, PlanSphere)
    off = {}
    for name in ("before", "after"):
        p = run("fit", str(c.folder / name), "sphere", "--step", step.id, "--json", "-")
        assert p.returncode == 0, p.stderr
        fit = json.loads(p.stdout)
        assert fit["kind"] == "sphere" and fit["n_points"] == len(
            [q for q in s.points if q.step_id == step.id]
        )
        off[name] = abs(fit["feature"]["radius"] - art.radius_mm)
    assert off["after"] < 0.005 and off["before"] > 5 * off["after"], off


def test_sessions_of_two_arms_refused(cases: dict[str, Case], tmp_path: Path) -> None:
    six, seven = cases["gao2013"].folder / "cal", cases["commercial7"].folder / "cal"
    out = tmp_path / "mixed.toml"
    p = run("calibrate", str(six), str(seven), "-o", str(out), "-q")
    line = one_error_line(p, 2, "7 joints", "6 joints", "one arm")
    assert str(seven) in line
    assert not out.exists() and not (tmp_path / "mixed.provenance.json").exists()
    # a held-out session of another arm too
    p = run("calibrate", str(seven), "-o", str(out), "--validate", str(six), "-q")
    one_error_line(p, 2, "6 joints", "7 joints", "one arm")
    assert not out.exists()


def test_previous_of_another_arm_refused(cases: dict[str, Case], tmp_path: Path) -> None:
    seven = cases["commercial7"].folder / "cal"
    prev = cases["gao2013"].folder / "cal.provenance.json"
    out = tmp_path / "again.toml"
    p = run("calibrate", str(seven), "-o", str(out), "--previous", str(prev), "-q")
    one_error_line(p, 2, "--previous", "another arm", "6 joints", "7 joints")
    assert not out.exists()
    # its own arm's provenance is read (it did not make the set in force: refused as such)
    own = cases["commercial7"].folder / "cal.provenance.json"
    p = run("calibrate", str(seven), "-o", str(out), "--previous", str(own), "-q")
    one_error_line(p, 2, "--previous", "not the provenance of the set in force")


def test_previous_of_the_arms_own_calibration_is_the_bar(
    cases: dict[str, Case], tmp_path: Path
) -> None:
    """The 7-axis arm's verification session taken with its calibrated set, calibrated
    again with ``--previous`` its calibration's provenance: that provenance made the set
    in force, so it is read, and its predicted length error is the bar the gate prints."""
    c = cases["commercial7"]
    own = c.folder / "cal.provenance.json"
    out = tmp_path / "again.toml"
    p = run(
        "calibrate", str(c.folder / "after"), "-o", str(out), "--previous", str(own),
        "--workspace", "0", "-q", timeout=240,
    )  # fmt: skip
    assert p.returncode in (0, 9), p.stderr  # written, or "as found, not adjusted"
    u_prev = c.provenance["quality_gate"]["prediction"]["calibrated_rms_mm"]
    assert f"its own calibration predicted {u_prev * 1e3:.3g} um ({own})" in p.stdout
    assert out.exists() == (p.returncode == 0)
