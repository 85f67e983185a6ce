"""Tolerance allocation for any arm (issue 26): the 7-axis commercial7 model's 31
parameters and 7 encoders allocated, then checked by a Monte Carlo written here (own
draws within the allocated tolerances and encoder bounds, a batched numpy DH chain,
not the C core): the arms built to the allocation meet the point target within its
stated margin. And `aacmm tolerance --model` with its refusals."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from aacmm.analysis import tolerance as tl
from aacmm.arm import Arm
from aacmm.cli import main
from aacmm.commands.exitcodes import USAGE, WRONG_ARM
from aacmm.core import Params
from aacmm.models import load_model
from aacmm.uncertainty import ArmParameterError
from test_core_arm import oracle

ARCSEC = math.pi / 648000.0
ARM = load_model("commercial7").arm
POSES = np.random.default_rng(77).uniform(-180.0, 180.0, (24, 7))

SPEC: dict[str, Any] = {
    "angle_unit": "arcsec",
    "length_unit": "um",
    "target": {"value": 60.0, "over": "worst"},
    "workspace": {"poses": POSES.tolist()},
    "parameters": {
        "theta": {"c": 400.0, "k": 2, "min": 1.0},
        "alpha": {"c": 900.0, "k": 2, "min": 1.5},
        "d": {"c": 600.0, "k": 1.5, "min": 2.0},
        "a": {"c": 600.0, "k": 1.5, "min": 2.0},
        "beta": {"c": 900.0, "k": 2, "min": 1.5},  # none on this arm: the spec fits others
        "tip": {"tolerance": 5.0},
    },
    "residual": {"u": 4.0},
    "encoder": [
        {"name": "optical 23 bit", "bits": 23, "accuracy_arcsec": 5.0, "cost": 250.0},
        {"name": "optical 26 bit", "bits": 26, "accuracy_arcsec": 2.0, "cost": 900.0},
    ],
}


def _rot(axis: int, t: np.ndarray) -> np.ndarray:
    """Batched rotations (n, 4, 4) about x (0), y (1) or z (2)."""
    n = t.shape[0]
    m = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    c, s = np.cos(t), np.sin(t)
    m[:, i, i], m[:, i, j], m[:, j, i], m[:, j, j] = c, -s, s, c
    return m


def _trans(axis: int, v: np.ndarray) -> np.ndarray:
    m = np.broadcast_to(np.eye(4), (v.shape[0], 4, 4)).copy()
    m[:, axis, 3] = v
    return m


def numpy_points(arm: Arm, delta: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Probe points (T, 3) of the arms ``arm + delta[t]`` (T, P) at one pose (N,):
    docs/kinematics.md's transforms as explicit 4x4 products per joint."""
    n = arm.n_joints
    v = arm.to_vector() + delta
    t = np.broadcast_to(np.eye(4), (v.shape[0], 4, 4)).copy()
    kb = 4 * n
    for i, j in enumerate(arm.joints):
        th, al, d, a = theta[i] + v[:, i], v[:, n + i], v[:, 2 * n + i], v[:, 3 * n + i]
        beta = [] if j.beta_rad is None else [_rot(1, v[:, kb])]
        kb += j.beta_rad is not None
        std = [_rot(2, th), _trans(2, d), _trans(0, a), _rot(0, al)]
        mod = [_rot(0, al), _trans(0, a), *beta, _rot(2, th), _trans(2, d)]
        for m in [*beta, *std] if j.convention == "standard" else mod:
            t = t @ m
    tip = v[:, kb:]
    if arm.tip == "z":
        tip = np.concatenate([np.zeros((tip.shape[0], 2)), tip], axis=1)
    out: np.ndarray = np.einsum("nij,nj->ni", t[:, :3, :3], tip) + t[:, :3, 3]
    return out


def test_commercial7_allocation_meets_its_target_by_monte_carlo() -> None:
    spec = tl.parse_spec(SPEC, None, ARM, "commercial7")
    assert spec.param_names == ARM.param_names and len(spec.costs) == 31
    a = tl.allocate(spec)
    assert [p.name for p in a.params] == list(ARM.param_names)
    assert len(a.encoders) == 7 and {r.joint for r in a.encoders} == set(range(1, 8))
    assert a.ratio <= 1.0 + 1e-9
    assert {p.status for p in a.params if p.name in ("tx", "ty", "tz")} == {"fixed"}
    # own Monte Carlo: uniform errors within +-t, encoder accuracy and quantisation,
    # the residual isotropic normal; the fraction of arms whose point at the governing
    # pose lies within the target radius
    rng = np.random.default_rng(2026)
    n = 40_000
    delta = np.zeros((n, 31))
    for i, p in enumerate(a.params):
        h = p.tolerance * (ARCSEC if p.unit == "arcsec" else 1e-3)
        delta[:, i] = rng.uniform(-h, h, n)
    for r in a.encoders:
        e = r.encoder
        delta[:, r.joint - 1] += (
            rng.uniform(-e.accuracy_arcsec, e.accuracy_arcsec, n)
            + rng.uniform(-0.5, 0.5, n) * e.resolution_arcsec
        ) * ARCSEC
    g = a.governing_row
    pose = a.design.poses[g]
    nominal = numpy_points(ARM, np.zeros((1, 31)), pose)[0]
    assert np.allclose(nominal, a.design.points[g], rtol=0, atol=1e-9)  # the same arm
    pts = numpy_points(ARM, delta, pose) + rng.normal(0.0, 4e-3 / math.sqrt(3.0), (n, 3))
    frac = float(np.mean(np.linalg.norm(pts - nominal, axis=1) <= 60e-3))
    sd = math.sqrt(0.05 * 0.95 / n)
    # the stated margin: the target's 95 % within its standard error; the design is
    # tight at the governing pose (not a wasteful 99 %)
    assert 0.95 - 3 * sd <= frac < 0.97
    # the library's check (C core, its own draws) agrees at that pose
    chk = tl.monte_carlo_check(a, trials=n, seed=5, threads=2)
    assert chk.met and chk.worst_within >= 0.95 - 3 * sd
    k = int(np.flatnonzero(chk.rows == g)[0])
    assert abs(chk.within[k] - frac) < 5 * sd * math.sqrt(2.0)


def test_specs_for_another_arm_are_refused_clearly() -> None:
    m5 = load_model("microscribe5").arm
    with pytest.raises(ArmParameterError, match=r"\[parameters\] l: .*'l' is not one"):
        tl.parse_spec({**SPEC, "parameters": {**SPEC["parameters"], "l": {"c": 1.0}}}, None, m5)
    with pytest.raises(tl.SpecError, match=r"\[workspace\].poses: each pose needs 5"):
        tl.parse_spec(SPEC, None, m5, "microscribe5")
    with pytest.raises(tl.SpecError, match=r"joints: joint numbers are 1..7"):
        enc = [{**SPEC["encoder"][0], "joints": [8]}]
        tl.parse_spec({**SPEC, "encoder": enc}, None, ARM)
    with pytest.raises(tl.SpecError, match=r"needs its joint limits"):
        tl.parse_spec({**SPEC, "calibration": {"plan": "calibration"}}, None, ARM)
    with pytest.raises(tl.SpecError, match=r"\[nominal\]"):
        tl.parse_spec({**SPEC, "nominal": {"l_mm": 100.0}}, None, ARM, "commercial7")


def test_cli_model(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_json = tmp_path / "t.json"
    rc = main(
        ["tolerance", "example", "--model", "desk4", "--trials", "0", "--json", str(out_json)]
    )
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert "arm: desk4 (4 joints, 19 parameters)" in out.out and "beta4" in out.out
    doc = json.loads(out_json.read_text())
    assert doc["arm"] == {"model": "desk4", "joints": 4, "parameters": 19}
    assert [p["name"] for p in doc["parameters"]] == list(load_model("desk4").arm.param_names)
    spec = tmp_path / "paper.toml"
    spec.write_text(
        "[target]\nvalue = 60.0\n[parameters]\ntheta = { c = 1 }\nalpha = { c = 1 }\n"
        "d = { c = 1 }\na = { c = 1 }\nl = { c = 1 }\n"
    )
    assert main(["tolerance", str(spec), "--trials", "0", "-q"]) == 0  # the paper's arm
    capsys.readouterr()
    rc = main(["tolerance", str(spec), "--model", "microscribe5", "--trials", "0"])
    err = capsys.readouterr().err
    assert rc == WRONG_ARM and "'l' is not one of this arm's" in err and err.count("\n") == 1
    rc = main(["tolerance", str(spec), "--model", "nosuch", "--trials", "0"])
    err = capsys.readouterr().err
    assert rc == USAGE and "nosuch" in err and err.count("\n") == 1


def _projected_jacobian(plan: Any, theta: np.ndarray, arm: Arm) -> np.ndarray:
    """The calibration's view of the parameters, built here from the numpy DH oracle
    (not the C core): each seat's points centred on their mean (the unknown seat
    centre eliminated), each bar length along the bar."""
    pj = [oracle(arm, q) for q in theta]
    p = np.array([x[0] for x in pj])
    j = np.array([x[1] for x in pj])
    rows = []
    for step in plan.steps:
        idx = [s.index for s in plan.slots if s.step_id == step.id]
        if step.procedure == "cone":
            jc = j[idx]
            rows.append((jc - jc.mean(axis=0)).reshape(-1, j.shape[2]))
        elif step.procedure == "length":
            ends: dict[int, dict[str, int]] = {}
            for i in idx:
                slot = plan.slots[i]
                ends.setdefault(slot.position_index, {})[slot.end] = i
            for e in ends.values():
                d = p[e["A"]] - p[e["B"]]
                rows.append(((d / np.linalg.norm(d)) @ (j[e["A"]] - j[e["B"]]))[None, :])
    out: np.ndarray = np.vstack(rows)
    return out


@pytest.mark.parametrize("name", ["commercial7", "desk4"])
def test_calibrated_allocation_of_any_arm(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``[calibration] plan = ...`` for an arm model other than the paper's: the
    model's own calibration plan, the simulated operator within its joint limits.
    What the allocation says calibration sets is what an SVD of the plan's
    projected Jacobian (built here with the numpy oracle at the same
    articulations) can see: the identified columns have full rank (and, for
    an arm without betas, all the columns together have no more); theta1 and
    d1 (a turn about and a shift along axis 1) are invisible to seats and
    lengths and keep a manufacturing tolerance; the calibrated arm costs less
    than the uncalibrated one. The command line (desk4): the same allocation."""
    from importlib import resources

    from aacmm.plans import load_plan
    from aacmm.simulation.ik import JointLimits
    from aacmm.simulation.scenario import plan_poses

    model = load_model(name)
    example = resources.files("aacmm").joinpath("data", "example_tolerance.toml").read_text()
    spec_file = tmp_path / "cal.toml"
    spec_file.write_text(example + f'\n[calibration]\nplan = "{model.calibration_plan}"\n')
    spec = tl.load_spec(spec_file, model.arm, name, model.joint_limits_rad)
    a = tl.allocate(spec)
    plan = load_plan(model.calibration_plan)
    theta = plan_poses(plan, model.arm, 0, JointLimits.from_ranges(model.joint_limits_rad))
    assert all(model.within_limits(q) for q in theta)
    jp = _projected_jacobian(plan, theta, model.arm)
    names = list(model.arm.param_names)
    ident = [names.index(n) for n in a.set_by_calibration]
    norms = np.linalg.norm(jp, axis=0)
    scale = norms.max()

    def rank(cols: list[int]) -> int:
        # unit columns (a column zero to rounding stays zero, not unit noise)
        sub = jp[:, cols] / np.maximum(norms[cols], 1e-6 * scale)
        sv = np.linalg.svd(sub, compute_uv=False)
        return int(np.sum(sv > 1e-8 * sv[0]))

    assert rank(ident) == len(ident)  # what calibration sets, it can see
    if all(j.beta_rad is None for j in model.arm.joints):
        # and it sets all it can see (with betas the calibration holds more by
        # convention: the d of a beta joint, the last joint's split of the tip)
        assert rank(list(range(len(names)))) == len(ident)
    assert {"theta1", "d1"} <= set(a.needs_tolerance)
    for n in ("theta1", "d1"):
        assert np.linalg.norm(jp[:, names.index(n)]) <= 1e-9 * scale
    uncal = tl.allocate(replace(spec, calibration=None))
    assert a.total_cost < uncal.total_cost
    if name != "desk4":
        return
    # on the command line, as a user runs it
    out_json = tmp_path / "t.json"
    rc = main(["tolerance", str(spec_file), "--model", name, "--trials", "0",
               "--json", str(out_json)])  # fmt: skip
    out = capsys.readouterr()
    assert rc == 0, out.err
    doc = json.loads(out_json.read_text())
    assert doc["calibration"]["set_by_calibration"] == list(a.set_by_calibration)
    assert "calibrated arm (plan " in out.out


def test_nominal_from_a_parameter_file_of_any_arm(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``[nominal] file = "cal.toml"``: allocate around a calibrated set (here a
    random truth's arm written as a parameter file) of the model's shape: the
    design's points at the workspace poses are the numpy oracle's on that arm,
    not on the model's nominal one; the paper's arm takes a file of its shape; a
    file of another shape is one line, exit status 10."""
    from importlib import resources

    from aacmm.protocol import ParamSet
    from aacmm.records.paramfile import dump_param_set
    from aacmm.simulation.truth import model_truth

    example = resources.files("aacmm").joinpath("data", "example_tolerance.toml").read_text()
    for name in ("commercial7", "gao2013"):
        model = load_model(name)
        cal = model_truth(3, model).params
        (tmp_path / f"{name}.toml").write_text(
            dump_param_set(ParamSet.from_arm(cal, model.encoder_config()), "toml")
        )
        spec_file = tmp_path / f"spec_{name}.toml"
        spec_file.write_text(example + f'\n[nominal]\nfile = "{name}.toml"\n')
        if name == "gao2013":
            spec = tl.load_spec(spec_file)
            q = np.random.default_rng(2).uniform(-3.0, 3.0, (5, 6))
            got = np.array([oracle(spec.arm, x)[0] for x in q])
            want = np.array([oracle(cal, x)[0] for x in q])
            assert isinstance(spec.params, Params) and np.allclose(got, want, rtol=0, atol=1e-9)
            continue
        spec = tl.load_spec(spec_file, model.arm, name, model.joint_limits_rad)
        assert spec.arm == cal and spec.arm != model.arm
        d = tl.allocate(spec).design
        want = np.array([oracle(cal, q)[0] for q in d.poses])
        assert np.max(np.abs(d.points - want)) < 1e-9
        off = np.array([oracle(model.arm, q)[0] for q in d.poses])
        assert np.max(np.abs(d.points - off)) > 0.1  # mm: the file's arm, not the model's
    rc = main(["tolerance", str(tmp_path / "spec_commercial7.toml"), "--trials", "0"])
    err = capsys.readouterr().err
    assert rc == WRONG_ARM and err.count("\n") == 1 and "not of the paper's arm" in err
    rc = main(["tolerance", str(tmp_path / "spec_gao2013.toml"), "--model", "commercial7"])
    err = capsys.readouterr().err
    assert rc == WRONG_ARM and err.count("\n") == 1 and "not of model commercial7" in err
