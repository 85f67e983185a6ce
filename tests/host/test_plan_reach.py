"""``aacmm.simulation.reach.check_reach`` and ``aacmm plan check PLAN --model``.

The plans are built here for an arm model: seats at the probe tip of random poses
inside the joint limits whose stylus points down (so reachable by construction), seats
farther from the shoulder than the whole arm is long (unreachable by the triangle
inequality), and a ball bar with one end of each kind. The reference is a forward
kinematics written here (4 x 4 homogeneous matrices of each joint, standard or modified
DH with Hayati's beta, numpy), not the core's: every solution ``check_reach`` gives is
put through it and must land on its target, inside the joint limits (checked here on
the readings modulo a turn) and with the stylus within the seat's 50 deg approach cone.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
from aacmm.commands import exitcodes
from aacmm.models import ArmModel, load_model, shipped_model_path
from aacmm.plans import Plan, loads_plan
from aacmm.simulation.reach import check_reach

AACMM = Path(sys.executable).with_name("aacmm")
FloatArray = npt.NDArray[np.float64]


def _rz(t: float) -> FloatArray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def _rx(t: float) -> FloatArray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def _ry(t: float) -> FloatArray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1.0]])


def _t(x: float, y: float, z: float) -> FloatArray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def forward(model: ArmModel, theta: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Tip (mm) and stylus direction (unit, along the tip vector) in the base frame."""
    m = np.eye(4)
    for j, q in zip(model.arm.joints, np.asarray(theta, dtype=np.float64), strict=True):
        beta = _ry(j.beta_rad) if j.beta_rad is not None else np.eye(4)
        rot = _rz(float(q) + j.theta_offset_rad)
        if j.convention == "standard":
            m = m @ beta @ rot @ _t(0, 0, j.d_mm) @ _t(j.a_mm, 0, 0) @ _rx(j.alpha_rad)
        else:
            m = m @ _rx(j.alpha_rad) @ _t(j.a_mm, 0, 0) @ beta @ rot @ _t(0, 0, j.d_mm)
    tip = np.asarray(model.arm.tip_mm, dtype=np.float64)
    stylus = m[:3, :3] @ (tip / np.linalg.norm(tip))
    return (m @ np.append(tip, 1.0))[:3], stylus


def inside_limits(model: ArmModel, theta: npt.ArrayLike) -> bool:
    for q, (lo, hi) in zip(np.asarray(theta), model.joint_limits_rad, strict=True):
        if math.isinf(lo):
            continue
        if lo + (float(q) - lo) % (2 * math.pi) > hi + 1e-12:
            return False
    return True


def tilt_deg(stylus: FloatArray) -> float:
    """Angle between the stylus and straight down."""
    return math.degrees(math.acos(float(np.clip(-stylus[2], -1.0, 1.0))))


def reachable_points(model: ArmModel, count: int, seed: int) -> list[FloatArray]:
    """Tips of random poses inside the limits with the stylus within 40 deg of down."""
    rng = np.random.default_rng(seed)
    out: list[FloatArray] = []
    while len(out) < count:
        q = np.array(
            [
                rng.uniform(-math.pi, math.pi) if math.isinf(lo) else rng.uniform(lo, hi)
                for lo, hi in model.joint_limits_rad
            ]
        )
        p, u = forward(model, q)
        if tilt_deg(u) <= 40.0:
            out.append(p)
    return out


def far_point(model: ArmModel, direction: tuple[float, float, float]) -> FloatArray:
    """A point farther from joint 1's frame origin than every length of the arm added."""
    length = model.reach_mm  # every |d|, |a| and tip component: more than any reach
    shoulder = np.array([0.0, 0.0, model.arm.joints[0].d_mm])
    d = np.asarray(direction, dtype=np.float64) / np.linalg.norm(direction)
    out: FloatArray = shoulder + (length + 50.0) * d
    return out


def _fmt(p: npt.ArrayLike) -> str:
    return ", ".join(f"{float(x)!r}" for x in np.asarray(p, dtype=np.float64))


def build_plan(model: ArmModel, seed: int = 3) -> tuple[Plan, str, list[bool]]:
    """Seats (reachable, far, reachable, far, reachable) and one ball bar (A reachable,
    B far); the expected reachability of each item in plan order."""
    near = reachable_points(model, 4, seed)
    far = [far_point(model, (1.0, 0.3, -0.2)), far_point(model, (-0.4, 1.0, 0.5))]
    seats = [near[0], far[0], near[1], far[1], near[2]]
    expected = [True, False, True, False, True]
    lines = ['format = "aacmm-plan-1"', 'title = "reach test"', "[probe]", "ball_diameter_mm = 6.0"]
    for i, p in enumerate(seats):
        lines += [f"[artefacts.seat{i + 1}]", 'type = "cone"', f"location_mm = [{_fmt(p)}]"]
    a, b = near[3], far_point(model, (0.2, -1.0, 0.1))
    length = float(np.linalg.norm(b - a))
    lines += ["[artefacts.bar]", 'type = "ballbar"', f"length_mm = {length!r}"]
    for i in range(len(seats)):
        lines += ["[[steps]]", f'id = "s{i + 1}"', 'procedure = "cone"']
        lines += [f'artefact = "seat{i + 1}"', "articulations = 3"]
    centre, direction = (a + b) / 2, (b - a) / length
    lines += ["[[steps]]", 'id = "len"', 'procedure = "length"', 'artefact = "bar"']
    lines.append(
        f"positions = [{{ centre_mm = [{_fmt(centre)}], direction = [{_fmt(direction)}] }}]"
    )
    text = "\n".join(lines) + "\n"
    return loads_plan(text, "reach-test"), text, [*expected, True, False]


@pytest.mark.parametrize("name", ["desk4", "microscribe5", "gao2013"])
def test_check_reach_against_an_independent_forward_kinematics(name: str) -> None:
    model = load_model(name)
    plan, _, expected = build_plan(model)
    report = check_reach(plan, model)
    assert [i.reachable for i in report.items] == expected
    assert [i.number for i in report.items] == list(range(1, len(expected) + 1))
    assert report.unchecked == () and not report.ok
    # every cone step is one item (its 3 articulations probe one point); the bar two
    assert [len(i.slots) for i in report.items] == [3] * 5 + [1, 1]
    for item in report.items:
        slot = plan.slots[item.slots[0]]
        assert slot.target is not None
        np.testing.assert_array_equal(item.target_mm, slot.target.tip_mm)
        if item.reachable:
            assert item.theta_rad is not None and item.reason == ""
            tip, stylus = forward(model, item.theta_rad)
            assert float(np.linalg.norm(tip - np.asarray(item.target_mm))) < 1e-6
            assert inside_limits(model, item.theta_rad)
            assert tilt_deg(stylus) <= 50.5  # the seat's approach cone (+ the 0.5 deg slack)
        else:
            assert item.theta_rad is None
            assert item.reason.startswith("out of reach")
            assert item.closest_mm >= 40.0  # 50 mm beyond the sum of every length
    bad = report.unreachable
    assert [i.label for i in bad] == [
        "step s2: cone seat seat2",
        "step s4: cone seat seat4",
        "step len: bar position 1, end B",
    ]


def test_a_plan_the_arm_reaches_is_ok_and_the_result_is_reproducible() -> None:
    model = load_model("desk4")
    near = reachable_points(model, 3, 11)
    lines = ['format = "aacmm-plan-1"', "[probe]", "ball_diameter_mm = 6.0"]
    for i, p in enumerate(near):
        xyz = ", ".join(repr(float(x)) for x in p)
        lines += [f"[artefacts.c{i}]", 'type = "cone"', f"location_mm = [{xyz}]"]
        lines += ["[[steps]]", 'procedure = "cone"', f'artefact = "c{i}"', "articulations = 2"]
    plan = loads_plan("\n".join(lines) + "\n", "ok-test")
    a, b = check_reach(plan, model, seed=5), check_reach(plan, model, seed=5)
    assert a.ok and a == b


def test_steps_without_a_target_are_listed_apart_and_bad_arguments_refused() -> None:
    plan = loads_plan(
        'format = "aacmm-plan-1"\n[artefacts.c]\ntype = "cone"\n'
        '[[steps]]\nid = "pivot"\nprocedure = "cone"\nartefact = "c"\narticulations = 3\n',
        "no-target",
    )
    report = check_reach(plan, load_model("desk4"))
    assert report.items == () and report.unchecked == ("pivot",) and report.ok
    with pytest.raises(ValueError, match="tries"):
        check_reach(plan, load_model("desk4"), tries=0)
    with pytest.raises(ValueError, match="joint limits"):
        check_reach(plan, load_model("desk4").arm)


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(AACMM), *args], capture_output=True, text=True, timeout=120, check=False
    )


def test_cli_plan_check_model_lists_the_unreachable_items_and_exits_7(tmp_path: Path) -> None:
    model = load_model("desk4")
    plan, text, expected = build_plan(model)
    f = tmp_path / "reach.toml"
    f.write_text(text, encoding="utf-8")
    first = r = _run("plan", "check", str(f), "--model", "desk4")
    assert r.returncode == exitcodes.NOT_MET == 7, r.stderr
    lines = r.stdout.strip().splitlines()
    numbers = [k + 1 for k, ok in enumerate(expected) if not ok]
    assert [int(line.split(":")[0]) for line in lines[:-1]] == numbers
    assert "step s2: cone seat seat2 at [" in lines[0] and "out of reach" in lines[0]
    assert "end B" in lines[2]
    assert lines[-1].endswith(f"model desk4 cannot reach 3 of {len(expected)} targets")
    # without --model: the plan is only validated
    r = _run("plan", "check", str(f))
    assert r.returncode == 0 and ": ok, " in r.stdout
    assert r.stdout.strip().endswith(f"{len(plan.steps)} steps, {len(plan.slots)} points")
    # a model file works as well as a name; an unknown model is a usage error
    mf = tmp_path / "mine.toml"
    mf.write_bytes(shipped_model_path("desk4").read_bytes())
    r2 = _run("plan", "check", str(f), "--model", str(mf))
    assert r2.returncode == 7 and r2.stdout == first.stdout
    r = _run("plan", "check", "kinematic-calibration", "--model", "nosuchmodel")
    assert r.returncode == exitcodes.USAGE and len(r.stderr.strip().splitlines()) == 1


def test_cli_plan_check_model_exit_0_when_every_target_is_reached() -> None:
    r = _run("plan", "check", "kinematic-calibration-compact", "--model", "desk4")
    assert r.returncode == exitcodes.OK, r.stdout + r.stderr
    assert r.stdout.strip().splitlines() == [
        "kinematic-calibration-compact: 6 steps, 135 points, 63 targets; "
        "model desk4 reaches every target"
    ]
