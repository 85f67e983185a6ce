"""The simulated operator end to end (issue 11 items 3-4): ``aacmm sim --truth
--scenario`` against ``aacmm capture`` over a pty, at ``--fast``.

- truth = the device's stored set, no error source: every captured point,
  recomputed from its counts with the double-precision core and the session's
  parameter set, lies within 1e-5 mm of the seat (32-bit quantisation leaves
  nanometres), and the device's own float points within 1e-3 mm of that;
- the true tip is within 1 nm of each probed target (the core's model of the
  truth evaluated independently at the unquantised angles of the report), and
  every step's joint spread is reported and wide;
- a random truth: the cone dispersion and the ball-bar length errors are the
  ones the parameter perturbation predicts to first order (J dq), within the
  noise and eccentricity the truth states;
- ``--follow``: a deliberate mis-probe undone with button 1 and re-probed, and
  a capture killed with SIGKILL and resumed: the session ends complete, every
  point labelled with the slot whose press made it.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from aacmm.core import Model, Params
from aacmm.records import read_session
from aacmm.simulation.articulation import joint_spread_deg
from aacmm.simulation.truth import load_truth, random_truth

pytestmark = pytest.mark.timeout(240)
AACMM = Path(sys.executable).with_name("aacmm")

SMALL_PLAN = """
format = "aacmm-plan-1"
title = "cone and ball bar"
[probe]
ball_diameter_mm = 6.0
[artefacts.seat]
type = "cone"
location_mm = [750.0, -150.0, -150.0]
[artefacts.bar]
type = "ballbar"
length_mm = 750.0
ends = "cone"
[[steps]]
id = "seat"
procedure = "cone"
artefact = "seat"
articulations = 12
[[steps]]
id = "bar"
procedure = "length"
artefact = "bar"
positions = [
  { centre_mm = [800, 0, -150], direction = [1, 0, 0] },
  { centre_mm = [800, 0, -150], direction = [0, 1, 0] },
  { centre_mm = [750, 200, -100], direction = [0.6, 0, 0.8] },
  { centre_mm = [700, -250, -200], direction = [0.5, 0.5, 0.7071067811865476] },
]
"""


def _env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}


class Session:
    """``aacmm sim ...`` and ``aacmm capture`` in one folder, the way a user runs them."""

    def __init__(self, folder: Path, plan: str, *sim_args: str) -> None:
        self.folder = folder
        self.plan = plan
        self.link = folder / "arm"
        self.sim = subprocess.Popen(
            [str(AACMM), "sim", "--scenario", plan, "--fast", "--link", str(self.link),
             "--report", str(folder / "report.json"), "--truth-out", str(folder / "truth.toml"),
             *sim_args],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env(),
        )  # fmt: skip
        assert self.sim.stdout is not None
        self.url = self.sim.stdout.readline().strip()
        assert self.url.startswith("serial://"), self.sim.stderr.read() if self.sim.stderr else ""

    def capture(self, *args: str) -> subprocess.Popen[str]:
        return subprocess.Popen(
            [str(AACMM), "capture", self.plan, "-o", str(self.folder / "s"), "--port", self.url,
             "-q", *args],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env(),
        )  # fmt: skip

    def finish(self, timeout: float = 120) -> tuple[dict[str, Any], str]:
        try:
            _, err = self.sim.communicate(timeout=timeout)
        finally:
            if self.sim.poll() is None:
                self.sim.kill()
        assert self.sim.returncode == 0, err
        return json.loads((self.folder / "report.json").read_text()), err


def _run(tmp_path: Path, plan: str, *sim_args: str) -> tuple[Any, dict[str, Any], Path]:
    s = Session(tmp_path, plan, *sim_args)
    cap = s.capture()
    _, err = cap.communicate(timeout=180)
    assert cap.returncode == 0, err
    report, _ = s.finish()
    return read_session(tmp_path / "s"), report, tmp_path / "truth.toml"


def _presses_by_slot(report: dict[str, Any]) -> dict[int, dict[str, Any]]:
    """The last capture press of every slot (the one a session keeps)."""
    out: dict[int, dict[str, Any]] = {}
    for p in report["presses"]:
        if p["button"] == 0 and p["slot"] is not None:
            out[p["slot"]] = p
    return out


def _check_labels(session: Any, report: dict[str, Any]) -> None:
    """Every session row holds the counts of the press made for its slot."""
    by_slot = _presses_by_slot(report)
    assert len(session.points) == report["points"]
    for k, pt in enumerate(session.points):
        assert pt.slot == k
        assert tuple(pt.counts) == tuple(by_slot[k]["counts"]), f"slot {k} mislabelled"


def test_nominal_truth_points_coincide(tmp_path: Path) -> None:
    session, report, truth_path = _run(tmp_path, "probe-calibration", "--truth", "nominal")
    truth = load_truth(truth_path)
    assert truth.errors.perfect
    _check_labels(session, report)
    seat = np.array(session.plan.slots[0].target.tip_mm)
    pts = session.points_mm()  # counts -> double core, with the set in force per row
    assert np.abs(pts - seat).max() <= 1e-5
    assert np.abs(session.device_points_mm - pts).max() <= 1e-3
    # the true tip on target within 1 nm, evaluated independently at the unquantised angles
    presses = report["presses"]
    theta = np.array([p["theta_rad"] for p in presses])
    probed = np.array([p["probed_mm"] for p in presses])
    err = np.linalg.norm(Model(truth.params).points(theta) - probed, axis=1)
    assert err.max() <= 1e-6 and report["max_ik_error_mm"] <= 1e-6
    # each step's articulations really differ: every joint's spread reported and wide
    spread = report["joint_spread_deg"]["pivot"]
    assert spread == pytest.approx(joint_spread_deg(theta).tolist(), abs=0.01)
    assert min(spread[0], spread[2], spread[4]) > 180 and min(spread[1], spread[3], spread[5]) > 90


def _predicted(truth: Any, theta: np.ndarray, nominal: Params) -> np.ndarray:
    """Where the nominal model puts a tip that the truth has at p_true: the first
    order change J(theta) (nominal - true) of the parameters (no noise, no eccentricity)."""
    m = Model(truth.params)
    p_true, jac = m.points_jacobians(theta)
    dq = nominal.to_vector() - truth.params.to_vector()
    out: np.ndarray = p_true + jac @ dq
    return out


def test_random_truth_errors_are_the_predicted_size(tmp_path: Path) -> None:
    plan = tmp_path / "small.toml"
    plan.write_text(SMALL_PLAN)
    session, report, truth_path = _run(tmp_path, str(plan), "--truth", "random:11", "--seed", "3")
    truth = load_truth(truth_path)
    assert truth == random_truth(11)
    _check_labels(session, report)
    by_slot = _presses_by_slot(report)
    theta = np.array([by_slot[k]["theta_rad"] for k in range(len(session.points))])
    observed = session.points_mm()  # what the uncalibrated device set says
    predicted = _predicted(truth, theta, Params())
    # noise + eccentricity + second order: a few um against mm-sized errors
    assert np.abs(observed - predicted).max() < 0.03
    cone = [k for k, pt in enumerate(session.points) if pt.step_id == "seat"]
    obs_d = observed[cone] - observed[cone].mean(axis=0)
    pred_d = predicted[cone] - predicted[cone].mean(axis=0)
    rms_obs = float(np.sqrt((obs_d**2).sum(axis=1).mean()))
    rms_pred = float(np.sqrt((pred_d**2).sum(axis=1).mean()))
    assert rms_obs > 0.3  # a perturbed arm: the seat smears over a millimetre or so
    assert rms_obs == pytest.approx(rms_pred, rel=0.05)
    bar = [k for k, pt in enumerate(session.points) if pt.step_id == "bar"]
    lengths_obs, lengths_pred = [], []
    for a, b in zip(bar[0::2], bar[1::2], strict=True):
        lengths_obs.append(np.linalg.norm(observed[b] - observed[a]) - 750.0)
        lengths_pred.append(np.linalg.norm(predicted[b] - predicted[a]) - 750.0)
    assert np.abs(np.array(lengths_obs) - np.array(lengths_pred)).max() < 0.03
    assert max(abs(v) for v in lengths_obs) > 0.05


def test_follow_misprobe_undo_and_resume_after_kill(tmp_path: Path) -> None:
    s = Session(
        tmp_path, "probe-calibration", "--truth", "random:2",
        "--follow", str(tmp_path / "s"), "--misprobe", "pivot:5:3",
    )  # fmt: skip
    cap = s.capture()
    progress = tmp_path / "s" / "progress.json"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        try:
            if json.loads(progress.read_text())["points"] >= 12:
                break
        except (OSError, ValueError):
            pass
        time.sleep(0.02)
    cap.send_signal(signal.SIGKILL)
    cap.wait(timeout=30)
    kept = read_session(tmp_path / "s")
    again = s.capture("--resume")
    _, err = again.communicate(timeout=180)
    assert again.returncode == 0, err
    report, _ = s.finish()
    session = read_session(tmp_path / "s")
    assert session.complete and len(session.points) == 30
    # nothing acknowledged before the kill was lost or changed
    for old, new in zip(kept.points, session.points, strict=False):
        assert tuple(old.counts) == tuple(new.counts)
    _check_labels(session, report)
    # the mis-probe: pressed 3 mm off, undone with button 1, probed again
    mis = [p for p in report["presses"] if p["misprobe_mm"] > 0]
    undos = [p for p in report["presses"] if p["button"] == 1]
    assert len(mis) == 1 and mis[0]["slot"] == 4 and len(undos) == 1
    assert np.linalg.norm(np.subtract(mis[0]["probed_mm"], mis[0]["target_mm"])) > 2.9
    assert tuple(session.points[4].counts) != tuple(mis[0]["counts"])
    journal = (tmp_path / "s" / "events.csv").read_text().splitlines()
    assert sum(1 for line in journal if line.split(",")[1:2] == ["undo"]) == 1


def test_rendezvous_without_port(tmp_path: Path) -> None:
    """`aacmm sim --scenario ... & aacmm capture ...` without --port: the URL is published."""
    env = _env()
    sim = subprocess.Popen(
        [str(AACMM), "sim", "--scenario", "probe-calibration", "--fast", "--truth", "nominal"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path,
    )  # fmt: skip
    try:
        cap = subprocess.run(
            [str(AACMM), "capture", "probe-calibration", "-o", "s1", "-q"],
            capture_output=True, text=True, timeout=180, env=env, cwd=tmp_path,
        )  # fmt: skip
        _, err = sim.communicate(timeout=60)
    finally:  # a failed rendezvous must not leave the simulator running for other tests
        if sim.poll() is None:
            sim.kill()
            sim.communicate()
    assert cap.returncode == 0, cap.stderr
    assert "using the simulator at serial://" in cap.stderr
    assert sim.returncode == 0, err
    assert read_session(tmp_path / "s1").complete
    # issue 29.7: in one terminal every prompt printed twice (the simulated operator
    # said each point it probed as capture's prompt); now only with --verbose
    from aacmm.plans import load_plan

    slots = load_plan("probe-calibration").slots
    assert not any(sl.text in err for sl in slots), err
    assert "operator presses" not in err


def test_second_simulator_does_not_take_discovery_away(tmp_path: Path) -> None:
    """Issue 29.7: a second `aacmm sim` silently took over discovery and, when it
    stopped, the first was no longer found. Now each publishes its own URL: the
    newest is used (and says so), and the first is found again when it stops."""

    def sim() -> tuple[subprocess.Popen[str], str]:
        p = subprocess.Popen(
            [str(AACMM), "sim", "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True, env=_env(),
        )  # fmt: skip
        assert p.stdout is not None
        return p, p.stdout.readline().strip()

    def info() -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [str(AACMM), "info"], capture_output=True, text=True, timeout=60, env=_env()
        )

    first, url1 = sim()
    second: subprocess.Popen[str] | None = None
    try:
        r = info()
        assert r.returncode == 0 and r.stderr == f"aacmm info: using the simulator at {url1}\n"
        second, url2 = sim()
        r = info()
        assert r.returncode == 0, r.stderr
        assert r.stderr == (
            f"aacmm info: using the simulator at {url2} (the newest of 2 running; --port "
            "for another)\n"
        )
        second.terminate()
        _, err2 = second.communicate(timeout=30)
        assert f"also running: {url1} (pid " in err2, err2  # said when it started
        r = info()
        assert r.returncode == 0 and r.stderr == f"aacmm info: using the simulator at {url1}\n"
    finally:
        for p in (first, second):
            if p is not None and p.poll() is None:
                p.terminate()
                p.communicate(timeout=30)
    r = info()
    assert r.returncode == 2 and "no device given" in r.stderr


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--follow", "x"], "--follow needs"),
        (["--truth", "random:x"], "seed"),
        (["--truth", "nominal", "--noise-counts", "3"], "encoder noise"),
        (["--scenario", "probe-calibration", "--motion", "walk"], "operator moves"),
        (["--scenario", "probe-calibration", "--misprobe", "pivot:99:1"], "points 1..30"),
        (["--scenario", "probe-calibration", "--misprobe", "nostep:1:1"], "no step"),
        (["--scenario", "probe-calibration", "--misprobe", "pivot:1"], "STEP:POINT:MM"),
        (["--scenario", "no-such-plan"], "no-such-plan"),
        (["--truth", "nominal", "--motion", "sweep"], "walk or static"),
        (["--fast"], "need --scenario"),
        (["--verbose"], "need --scenario"),
    ],
)
def test_option_errors(args: list[str], needle: str) -> None:
    r = subprocess.run(
        [str(AACMM), "sim", *args], capture_output=True, text=True, timeout=60, env=_env()
    )
    assert r.returncode == 2, r.stderr
    assert needle in r.stderr and r.stderr.count("\n") == 1, r.stderr


def test_truth_file_resolution_must_match(tmp_path: Path) -> None:
    t = random_truth(1, cpr=1 << 20)
    path = tmp_path / "t.toml"
    path.write_text(t.dumps())
    r = subprocess.run(
        [str(AACMM), "sim", "--truth", str(path), "--cpr", str(1 << 24)],
        capture_output=True, text=True, timeout=60, env=_env(),
    )  # fmt: skip
    assert r.returncode == 2 and "counts per revolution" in r.stderr, r.stderr


def test_truth_without_scenario_static_and_walk() -> None:
    from aacmm.client import connect
    from aacmm.simulation.ik import ARM_LIMITS
    from aacmm.simulation.run import STATIC_POSE_RAD
    from aacmm.simulation.truth import nominal_truth

    sim = subprocess.Popen(
        [str(AACMM), "sim", "--truth", "nominal", "--motion", "static", "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env(),
    )  # fmt: skip
    try:
        assert sim.stdout is not None
        url = sim.stdout.readline().strip()
        want = nominal_truth().counts(ARM_LIMITS.canonical(STATIC_POSE_RAD))[0]
        with connect(url, timeout=2.0) as c:
            deadline = time.monotonic() + 10
            while tuple(c.measure().counts) != tuple(want) and time.monotonic() < deadline:
                time.sleep(0.05)
            assert tuple(c.measure().counts) == tuple(int(v) for v in want)
    finally:
        sim.send_signal(signal.SIGTERM)
        sim.wait(timeout=20)
    assert sim.returncode == 0
    sim = subprocess.Popen(
        [str(AACMM), "sim", "--truth", "random:4", "--button-every", "0.3", "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env(),
    )  # fmt: skip
    try:
        assert sim.stdout is not None
        url = sim.stdout.readline().strip()
        with connect(url, timeout=2.0) as c:
            first = c.measure().counts
            t = c.wait_trigger(timeout=5.0)
            assert t.button == 0 and t.pressed
            time.sleep(0.3)
            assert c.measure().counts != first  # the true arm walks
    finally:
        sim.send_signal(signal.SIGINT)
        sim.wait(timeout=20)
    assert sim.returncode == 0
