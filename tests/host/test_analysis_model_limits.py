"""Random poses of ``aacmm mc``, ``aacmm uncertainty`` and ``aacmm tolerance`` within
an arm model's joint limits (issue 26, item 5), for every shipped model other than
the paper's; the paper's arm keeps every joint in [-180, 180) deg.

The limits are read here from the shipped model files with tomllib (not through
aacmm.models), every pose is checked against them by a comparison written here,
and the poses must spread over each limited joint's range (not merely sit in
it). ``mc``: the command's coefficients equal those of the numpy DH oracle of
test_core_arm over poses drawn uniformly between those limits, so the command
used them. ``uncertainty``: its JSON's workspace poses. ``tolerance``: the
spec's workspace poses and the report's words.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from aacmm.analysis import mc_poses
from aacmm.analysis import tolerance as tl
from aacmm.cli import main
from aacmm.models import load_model, shipped_model_path
from test_core_arm import oracle

OTHER_MODELS = ("commercial7", "microscribe5", "desk4", "mpe2018")
SPEC = """
angle_unit = "arcsec"
length_unit = "um"
[parameters]
theta = { u = 2.0 }
alpha = { u = 2.0 }
d = { u = 5.0 }
a = { u = 4.0 }
tip = { u = 3.0 }
"""


def _limits_deg(name: str) -> list[tuple[float, float]]:
    """The model file's joint limits in deg, (-180, 180) for a joint without limits."""
    doc = tomllib.loads(shipped_model_path(name).read_text())
    out = []
    for j in doc["joints"]:
        lo, hi = j["limits_deg"]
        out.append((-180.0, 180.0) if math.isinf(lo) else (float(lo), float(hi)))
    return out


def _check_within_and_spread(poses_rad: np.ndarray, name: str) -> None:
    """Every pose inside the file's limits; each joint spread over >= 80 % of its range."""
    lim = np.array(_limits_deg(name))
    deg = np.degrees(np.asarray(poses_rad))
    assert deg.shape[1] == lim.shape[0]
    assert np.all(deg >= lim[:, 0] - 1e-9) and np.all(deg < lim[:, 1] + 1e-9), name
    spread = (deg.max(axis=0) - deg.min(axis=0)) / (lim[:, 1] - lim[:, 0])
    assert np.all(spread > 0.8), (name, spread)


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    rc = main(argv)
    out = capsys.readouterr()
    return rc, out.out, out.err


@pytest.mark.parametrize("name", OTHER_MODELS)
def test_mc_poses_within_the_models_limits(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out_json = tmp_path / "mc.json"
    n = 600
    rc, _, err = _run(
        [
            "mc",
            "--model",
            name,
            "-n",
            str(n),
            "--seed",
            "4",
            "-q",
            "--json",
            str(out_json),
        ],
        capsys,
    )
    assert rc == 0, err
    lim = np.radians(np.array(_limits_deg(name)))
    js = [mc_poses.JointDistribution.uniform(lo, hi) for lo, hi in lim]
    theta = mc_poses.draw_poses(n, js, seed=4, count=len(js))
    _check_within_and_spread(theta, name)
    arm = load_model(name).arm
    ref = np.abs(np.array([oracle(arm, q)[1] for q in theta])).mean(axis=0)
    doc = json.loads(out_json.read_text())
    c = doc["coefficients"]
    got = np.array([[c[p][a]["mean_abs"] for p in arm.param_names] for a in "xyz"])
    assert np.allclose(got, ref, rtol=1e-9, atol=1e-9)
    # the whole turn would give other coefficients: the limits matter here
    full = mc_poses.draw_poses(n, seed=4, count=len(js))
    if not np.allclose(lim, [[-math.pi, math.pi]] * len(js)):
        wide = np.abs(np.array([oracle(arm, q)[1] for q in full])).mean(axis=0)
        assert not np.allclose(got, wide, rtol=1e-3)


def test_mc_of_the_paper_arm_keeps_the_whole_turn(
    capsys: pytest.CaptureFixture[str],
) -> None:
    rc, out, err = _run(["mc", "--model", "gao2013", "-n", "300", "--seed", "1"], capsys)
    assert rc == 0, err
    assert "joints: uniform[-180, 180) deg; seed 1" in out


@pytest.mark.parametrize("name", OTHER_MODELS)
def test_uncertainty_workspace_within_the_models_limits(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec, out_json = tmp_path / "s.toml", tmp_path / "u.json"
    spec.write_text(SPEC)
    argv = [
        "uncertainty",
        str(spec),
        "--model",
        name,
        "--trials",
        "200",
        "--workspace",
        "300",
    ]
    rc, out, err = _run([*argv, "--threads", "1", "--json", str(out_json)], capsys)
    assert rc == 0, err
    doc = json.loads(out_json.read_text())
    poses = np.array([p["theta_rad"] for p in doc["workspace_poses"]])
    assert poses.shape == (300, len(_limits_deg(name)))
    _check_within_and_spread(poses, name)
    assert np.allclose(doc["workspace_joint_ranges_deg"], _limits_deg(name), rtol=0, atol=1e-9)
    assert "joints uniform within the arm's limits" in out


def test_uncertainty_of_the_paper_arm_keeps_its_workspace(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The paper's arm: every joint uniform in [-pi, pi), the very draws of before
    (numpy's uniform with the workspace seed, seed + 1)."""
    out_json = tmp_path / "u.json"
    argv = [
        "uncertainty",
        "example",
        "--trials",
        "200",
        "--workspace",
        "20",
        "--seed",
        "5",
    ]
    rc, out, err = _run([*argv, "--threads", "1", "--json", str(out_json)], capsys)
    assert rc == 0, err
    doc = json.loads(out_json.read_text())
    poses = np.array([p["theta_rad"] for p in doc["workspace_poses"]])
    ref = np.random.default_rng(6).uniform(-math.pi, math.pi, (20, 6))
    assert np.array_equal(poses, ref)
    assert "workspace_joint_ranges_deg" not in doc
    assert "joints uniform in [-180, 180) deg" in out


@pytest.mark.parametrize("name", OTHER_MODELS)
def test_tolerance_workspace_within_the_models_limits(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from importlib import resources

    spec = tmp_path / "t.toml"
    example = resources.files("aacmm").joinpath("data", "example_tolerance.toml").read_text()
    assert "random = 100 " in example
    spec.write_text(example.replace("random = 100 ", "random = 200 "))
    model = load_model(name)
    s = tl.load_spec(spec, model.arm, name, model.joint_limits_rad)
    _check_within_and_spread(s.workspace.poses(), name)
    out_json = tmp_path / "t.json"
    argv = [
        "tolerance",
        str(spec),
        "--model",
        name,
        "--trials",
        "0",
        "--json",
        str(out_json),
    ]
    rc, _, err = _run(argv, capsys)
    assert rc in (0, 7), err  # met or not: the workspace is what is checked here
    words = ", ".join(f"[{lo:g}, {hi:g})" for lo, hi in _limits_deg(name))
    assert f"joints uniform in {words} deg" in json.loads(out_json.read_text())["workspace"]
    # the same spec on the paper's arm (no --model): every joint in [-180, 180)
    paper = tl.load_spec(spec)
    assert np.array_equal(paper.workspace.ranges_rad, [[-math.pi, math.pi]] * 6)
