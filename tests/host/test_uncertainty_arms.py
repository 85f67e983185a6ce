"""aacmm.uncertainty for any arm (issue 26): specs with the arm's parameter names,
the linear propagation J Sigma J^T against an independent numpy computation (the
numpy DH oracle of test_core_arm, not the C core), the Monte Carlo beside it, and
`aacmm uncertainty --model` with its refusals."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from aacmm import uncertainty as unc
from aacmm.arm import Arm
from aacmm.cli import main
from aacmm.commands.exitcodes import USAGE, WRONG_ARM
from aacmm.models import load_model
from test_core_arm import oracle

ARCSEC = math.pi / 648000.0

SPEC = """
angle_unit = "arcsec"
length_unit = "um"
[parameters]
theta = { u = 2.0 }
alpha = { tolerance = 5.0, distribution = "uniform" }
d = { u = 5.0 }
a = { u = 4.0 }
tip = { u = 3.0 }
d2 = { u = 9.0 }
"""


def _parse(text: str, arm: Arm, name: str) -> unc.UncertaintySpec:
    from aacmm.fileio import loads_toml

    return unc.parse_spec(loads_toml(text, "spec"), arm, name)


@pytest.mark.parametrize("name", ["commercial7", "microscribe5"])
def test_linear_propagation_is_j_sigma_jt_of_an_independent_jacobian(name: str) -> None:
    model = load_model(name)
    arm = model.arm
    spec = _parse(SPEC + ("beta = { u = 7.0 }\n" if arm.beta_joints else ""), arm, name)
    names = arm.param_names
    assert spec.param_names == names and spec.joints == arm.n_joints
    u = spec.u_vector()
    # the spec's u by hand: groups, the joint entry over its group, units, tolerances
    want = {}
    for n in names:
        if n.startswith("theta"):
            want[n] = 2.0 * ARCSEC
        elif n.startswith("alpha"):
            want[n] = 5.0 / math.sqrt(3.0) * ARCSEC
        elif n.startswith("beta"):
            want[n] = 7.0 * ARCSEC
        elif n == "d2":
            want[n] = 9e-3
        elif n.startswith("d"):
            want[n] = 5e-3
        elif n.startswith("a"):
            want[n] = 4e-3
        else:  # the tip: l or tx, ty, tz
            want[n] = 3e-3
    assert np.allclose(u, [want[n] for n in names], rtol=1e-15, atol=0)
    rng = np.random.default_rng(26)
    poses = rng.uniform(-math.pi, math.pi, (5, arm.n_joints))
    spec = unc.UncertaintySpec(spec.params, spec.items, poses, model=name)
    res = unc.propagate(spec, trials=4000, workspace=3, seed=3, threads=1)
    assert len(res.poses) == 8 and res.n_given == 5
    sigma = np.diag(u**2)
    for p in res.poses:
        point, jac = oracle(arm, p.theta_rad)
        assert np.allclose(p.point_mm, point, rtol=0, atol=1e-9)
        cov = jac @ sigma @ jac.T  # numpy, not the core
        assert np.allclose(p.u_lin, np.sqrt(np.diag(cov)), rtol=1e-9, atol=0)
        assert math.isclose(p.u3_lin, math.sqrt(np.trace(cov)), rel_tol=1e-9)
        assert np.allclose(p.contrib, (jac**2).sum(axis=0) * u**2, rtol=1e-9, atol=1e-18)
        # the Monte Carlo (the core's perturbed arms) agrees with the linear law for
        # micrometre-sized errors: 4000 trials, standard error of u about 1.1 %
        assert np.all(np.abs(p.u_mc / p.u_lin - 1.0) < 0.06)
    # the budget: every parameter of the arm, shares summing to 1, groups of this arm
    assert sorted(e.name for e in res.budget) == sorted(names)
    assert math.isclose(sum(e.share for e in res.budget), 1.0, rel_tol=1e-12)
    groups = ["theta", "alpha", "d", "a"] + (["beta"] if arm.beta_joints else [])
    assert list(res.group_shares) == [*groups, "tip" if arm.tip == "xyz" else "l"]
    jacs = np.array([oracle(arm, p.theta_rad)[1] for p in res.poses])
    mean_contrib = ((jacs**2).sum(axis=1) * u**2).mean(axis=0)
    top = res.budget[0]
    k = names.index(top.name)
    assert math.isclose(top.share, mean_contrib[k] / mean_contrib.sum(), rel_tol=1e-9)
    assert int(np.argmax(mean_contrib)) == k


def test_correlated_parameters_of_a_seven_axis_arm() -> None:
    arm = load_model("commercial7").arm
    p = arm.n_params
    rng = np.random.default_rng(7)
    root = rng.normal(size=(p, p)) * 1e-4
    cov = root @ root.T
    pose = rng.uniform(-math.pi, math.pi, (1, arm.n_joints))
    spec = unc.UncertaintySpec.from_covariance(cov, arm, pose, model="commercial7")
    assert spec.covariance is not None and spec.covariance.shape == (p, p)
    res = unc.propagate(spec, trials=2000, workspace=0, seed=1, threads=1)
    _, jac = oracle(arm, pose[0])
    assert np.allclose(res.poses[0].u_lin, np.sqrt(np.diag(jac @ cov @ jac.T)), rtol=1e-9)
    with pytest.raises(ValueError, match=f"{p} x {p}"):
        unc.UncertaintySpec.from_covariance(np.eye(25), arm)


def test_specs_name_the_arms_parameters() -> None:
    m5 = load_model("microscribe5").arm  # modified DH, beta3, tip vector
    assert unc.expand_name("beta", m5) == ("beta3",)
    assert unc.expand_name("tip", m5) == ("tx", "ty", "tz")
    assert unc.expand_name("d", m5) == tuple(f"d{i}" for i in range(1, 6))
    assert unc.expand_name("tip") == ("l",)  # the paper's arm
    # a parameter another arm has: ArmParameterError (a spec of another arm)
    assert unc.expand_name("beta") == ()  # no betas on the paper's arm: a portable spec
    for bad, arm in (("theta7", None), ("l", m5), ("d6", m5), ("beta2", m5), ("tx", None)):
        with pytest.raises(unc.ArmParameterError, match="not one of this arm's"):
            unc.expand_name(bad, arm)
    with pytest.raises(unc.SpecError, match="unknown parameter name 'foo'") as ei:
        unc.expand_name("foo", m5)
    assert not isinstance(ei.value, unc.ArmParameterError)
    with pytest.raises(unc.SpecError, match=r"\[nominal\]"):
        _parse("[nominal]\nl_mm = 100\n[parameters]\nd = { u = 1 }\n", m5, "microscribe5")
    with pytest.raises(unc.SpecError, match="5 joint angles"):
        _parse("poses = [[0, 0, 0, 0, 0, 0]]\n[parameters]\nd = { u = 1 }\n", m5, "m5")
    # the paper's arm given as a model is the paper's Params spec, [nominal] allowed
    paper = _parse("[nominal]\nl_mm = 150\n[parameters]\nd = { u = 1 }\n", Arm.paper(), "gao2013")
    assert paper.param_names == unc.UncertaintySpec.from_u({"d": 1.0}).param_names
    assert paper.arm.tip_mm[2] == 150.0


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    rc = main(argv)
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_cli_model_and_refusals(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "s7.toml"
    spec.write_text("poses = [[0, 90, 0, 90, 0, 0, 0]]\n" + SPEC + "theta7 = { u = 3.0 }\n")
    out_json = tmp_path / "u.json"
    argv = ["uncertainty", str(spec), "--model", "commercial7", "--trials", "500"]
    rc, out, err = _run([*argv, "--workspace", "2", "--json", str(out_json)], capsys)
    assert rc == 0, err
    assert "arm: commercial7 (7 joints, 31 parameters)" in out
    doc = json.loads(out_json.read_text())
    assert doc["arm"]["model"] == "commercial7" and len(doc["arm"]["parameters"]) == 31
    assert math.isclose(doc["uncertainties"]["theta7"]["u"], 3.0 * ARCSEC, rel_tol=1e-12)
    assert len(doc["given_poses"][0]["theta_rad"]) == 7
    # the same spec against the paper's arm (the default): theta7 is not one of its
    rc, out, err = _run(["uncertainty", str(spec), "--trials", "100"], capsys)
    assert rc == WRONG_ARM and out == ""
    assert err.count("\n") == 1 and "'theta7' is not one of this arm's" in err
    # the packaged example names d5: not a parameter of the 4-axis arm
    rc, _, err = _run(["uncertainty", "example", "--model", "desk4"], capsys)
    assert rc == WRONG_ARM and "'d5'" in err and err.count("\n") == 1
    # a pose of the wrong width, an unknown model: usage errors
    rc, _, err = _run([*argv, "--pose", "0,0,0,0,0,0"], capsys)
    assert rc == USAGE and "7 finite joint angles" in err
    rc, _, err = _run([*argv[:3], "nosuchmodel"], capsys)
    assert rc == USAGE and "nosuchmodel" in err and err.count("\n") == 1


def test_cli_log_of_a_seven_axis_arm(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--log`` of a 7-axis log (written as ``aacmm log`` writes it) with its model;
    against the paper's arm (the default) it is refused in one line, exit 10."""
    from test_mc_arms_cli import _log

    log, theta = _log(tmp_path, "commercial7", rows=12)
    spec = tmp_path / "s7.toml"
    spec.write_text(SPEC)
    out_json = tmp_path / "u.json"
    argv = ["uncertainty", str(spec), "--log", str(log), "--every", "3", "--trials", "300"]
    rc, _, err = _run([*argv, "--model", "commercial7", "--json", str(out_json)], capsys)
    assert rc == 0, err
    doc = json.loads(out_json.read_text())
    assert len(doc["given_poses"]) == 4 and doc["workspace_poses"] == []
    got = np.array([p["theta_rad"] for p in doc["given_poses"]])
    assert np.allclose(got, theta[::3], rtol=0, atol=1e-12)
    rc, out, err = _run(argv, capsys)
    assert rc == WRONG_ARM and out == "" and err.count("\n") == 1
    assert "7 joints" in err and "model gao2013" in err
