"""The simulator's own motion within an arm model's joint limits (issue 26, item 5).

``aacmm sim --model NAME`` without a truth lets the device's simulator move the
arm itself (``--motion sweep|walk|static``); for a model other than the
paper's it passes the model's joint limits (``aacmm-sim --joint-limits``), and
every joint 1..7 then moves inside its own range. Checked here:

- every pose of sweep, walk and static over 200 s of simulated time (a
  reading every 5 ms) is inside the limits the shipped model file states
  (read here with tomllib, compared here modulo a turn), for every shipped
  model other than the paper's; each joint's readings spread over its range
  (sweep >= 90 %, walk >= 55 % of a limited joint's span; a roll over more
  than 5 rad); the built-in motion of the paper's arm (no limits given) would
  leave the 7-axis model's limits, so the check can fail;
- the simulated operator's articulations (inverse kinematics) for each shipped
  model's own calibration plan, within the model's limits: every one inside
  them, and spread over the joints at every seat;
- on a pty, ``aacmm sim --model NAME --motion sweep`` (as a user runs it):
  the readings of ``aacmm measure`` within the model's limits;
- bad ``--joint-limits`` and ``--joint-limits`` with ``--control`` are one
  line and exit status 2.

The motion is read through ``build/sim/libaacmm_sim_motion.so`` (make
sim-motion-lib: firmware/src/sim/sim_motion.c as the device builds it).
"""

from __future__ import annotations

import ctypes
import json
import math
import os
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
from aacmm.models import load_model, shipped_model_path
from aacmm.plans import load_plan
from aacmm.simulation.articulation import joint_spread_deg
from aacmm.simulation.ik import Arm as IkArm
from aacmm.simulation.ik import JointLimits
from aacmm.simulation.scenario import choreograph

ROOT = Path(__file__).resolve().parents[2]
AACMM = Path(sys.executable).with_name("aacmm")
JOINTS_MAX = 7
STATIC, SWEEP, WALK = 0, 1, 2
MODELS = ("commercial7", "microscribe5", "desk4", "mpe2018")
STEP_US = 5000
SPAN_US = 200_000_000
EPS_RAD = 1e-5  # float32 angles and the count rounding (< 1e-6 rad at these resolutions)


class SimRanges(ctypes.Structure):
    _fields_ = [
        ("limited", ctypes.c_uint8 * JOINTS_MAX),
        ("lo_rad", ctypes.c_float * JOINTS_MAX),
        ("hi_rad", ctypes.c_float * JOINTS_MAX),
    ]


class SimConfig(ctypes.Structure):
    _fields_ = [
        ("motion", ctypes.c_int),
        ("seed", ctypes.c_uint32),
        ("noise_counts", ctypes.c_uint32),
        ("counts_per_rev", ctypes.c_uint64),
        ("replay", ctypes.POINTER(ctypes.c_uint32)),
        ("replay_poses", ctypes.c_uint32),
        ("button_period_us", ctypes.c_uint64),
        ("ranges", ctypes.POINTER(SimRanges)),
        ("replay_joints", ctypes.c_uint8),
    ]


class Sim(ctypes.Structure):
    _fields_ = [
        ("cfg", SimConfig),
        ("rng", ctypes.c_uint32),
        ("replay_pos", ctypes.c_uint32),
    ]


def _lib() -> ctypes.CDLL:
    path = os.environ.get("AACMM_SIM_MOTION_LIB")
    if path is None:  # run outside make: build it first
        subprocess.run(
            ["make", "-s", "--no-print-directory", "sim-motion-lib"],
            cwd=ROOT,
            check=True,
        )
        path = str(ROOT / "build" / "sim" / "libaacmm_sim_motion.so")
    lib = ctypes.CDLL(path)
    lib.aacmm_sim_init.argtypes = [ctypes.POINTER(Sim), ctypes.POINTER(SimConfig)]
    lib.aacmm_sim_init.restype = ctypes.c_int
    lib.aacmm_sim_read.argtypes = [
        ctypes.POINTER(Sim),
        ctypes.c_uint64,
        ctypes.POINTER(ctypes.c_uint32 * JOINTS_MAX),
    ]
    lib.aacmm_sim_read.restype = ctypes.c_int
    return lib


LIB = _lib()


def _limits(name: str) -> list[tuple[float, float] | None]:
    """The model file's joint limits in rad (None: no limit)."""
    doc = tomllib.loads(shipped_model_path(name).read_text())
    out: list[tuple[float, float] | None] = []
    for j in doc["joints"]:
        lo, hi = j["limits_deg"]
        out.append(None if math.isinf(lo) else (math.radians(lo), math.radians(hi)))
    return out


def _cpr(name: str) -> int:
    """The model file's encoder resolution (default 2^32, docs/models.md)."""
    enc = tomllib.loads(shipped_model_path(name).read_text())["encoder"]
    return int(enc.get("counts_per_rev", 2**32))


def _readings(
    limits: list[tuple[float, float] | None], motion: int, cpr: int, ranges: bool
) -> np.ndarray:
    """The simulator's readings (rad in [0, 2 pi)) of joints 1..N over SPAN_US."""
    cfg = SimConfig(motion=motion, seed=17, counts_per_rev=cpr)
    r = SimRanges()  # kept alive here while the simulation runs
    if ranges:
        for j, lim in enumerate(limits):
            if lim is not None:
                r.limited[j] = 1
                r.lo_rad[j], r.hi_rad[j] = lim
        cfg.ranges = ctypes.pointer(r)
    sim = Sim()
    assert LIB.aacmm_sim_init(ctypes.byref(sim), ctypes.byref(cfg)) == 0
    counts = (ctypes.c_uint32 * JOINTS_MAX)()
    rows = []
    for t in range(0, SPAN_US, STEP_US):
        assert LIB.aacmm_sim_read(ctypes.byref(sim), t, ctypes.byref(counts)) == 0
        rows.append(counts[: len(limits)])
    return np.array(rows, dtype=np.float64) * (2.0 * math.pi / cpr)


def _outside(theta: np.ndarray, limits: list[tuple[float, float] | None]) -> np.ndarray:
    """Per reading: how far outside its joint's limits (rad, 0 inside), modulo a turn."""
    out = np.zeros_like(theta)
    for j, lim in enumerate(limits):
        if lim is None:
            continue
        lo, hi = lim
        x = lo + np.mod(theta[:, j] - lo, 2.0 * math.pi)  # in [lo, lo + 2 pi)
        above = x - hi
        below = lo + 2.0 * math.pi - x  # just under lo, seen from the other side
        out[:, j] = np.where(x <= hi, 0.0, np.minimum(above, below))
    return out


def _unwrapped(theta: np.ndarray, lim: tuple[float, float] | None, j: int) -> np.ndarray:
    """Joint j's readings as angles near its range (or unwrapped for a roll)."""
    if lim is None:
        return np.unwrap(theta[:, j])
    return lim[0] + np.mod(theta[:, j] - lim[0] + 0.5 * EPS_RAD, 2.0 * math.pi)


@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize(("motion", "spread"), [(SWEEP, 0.90), (WALK, 0.55), (STATIC, 0.0)])
def test_every_pose_within_the_models_limits(name: str, motion: int, spread: float) -> None:
    limits = _limits(name)
    theta = _readings(limits, motion, _cpr(name), ranges=True)
    assert theta.shape == (SPAN_US // STEP_US, len(limits))
    worst = _outside(theta, limits).max()
    assert worst <= EPS_RAD, f"{name}: a reading {worst:.3g} rad outside the limits"
    for j, lim in enumerate(limits):
        x = _unwrapped(theta, lim, j)
        covered = float(x.max() - x.min())
        if motion == STATIC:
            assert covered <= 1e-6  # one pose
        elif lim is None:
            assert covered > 5.0, (name, j + 1, covered)
        else:
            assert covered >= spread * (lim[1] - lim[0]), (name, j + 1, covered)


def test_the_built_in_motion_would_leave_the_7_axis_limits() -> None:
    """Without --joint-limits the simulator moves the paper's arm's ranges (and a
    7th roll): joint 6 of commercial7 (+-115 deg) would be left, so the test above
    can fail; the paper's motion itself is unchanged (tests/device)."""
    limits = _limits("commercial7")
    theta = _readings(limits, SWEEP, _cpr("commercial7"), ranges=False)
    assert _outside(theta, limits)[:, 5].max() > 0.1


def test_bad_ranges_are_refused_by_the_library() -> None:
    r = SimRanges()
    cfg = SimConfig(motion=WALK, seed=1, counts_per_rev=4096, ranges=ctypes.pointer(r))
    sim = Sim()
    r.limited[1] = 1
    for lo, hi in ((1.0, 1.0), (2.0, 1.0), (-3.2, 3.2), (float("nan"), 1.0), (0.0, 20.0)):
        r.lo_rad[1], r.hi_rad[1] = lo, hi
        assert LIB.aacmm_sim_init(ctypes.byref(sim), ctypes.byref(cfg)) != 0, (lo, hi)
    r.lo_rad[1], r.hi_rad[1] = -1.0, 1.0
    assert LIB.aacmm_sim_init(ctypes.byref(sim), ctypes.byref(cfg)) == 0


@pytest.mark.parametrize("name", ["gao2013", *MODELS])
def test_operator_articulations_within_the_limits_and_spread(name: str) -> None:
    """The simulated operator's IK solutions for the model's own calibration plan
    (``aacmm sim --model NAME --scenario PLAN``'s choreography, with the model's
    limits): every articulation inside the file's limits; at each seat every joint
    moves between articulations and at least two joints turn by more than 90 deg."""
    model = load_model(name)
    plan = load_plan(model.calibration_plan)
    choreo = choreograph(
        plan,
        IkArm(model.arm),
        np.random.default_rng(0),
        JointLimits.from_ranges(model.joint_limits_rad),
    )
    limits = _limits(name)
    theta = np.array([p.theta for p in choreo.points])
    assert theta.shape == (len(plan.slots), len(limits))
    assert _outside(theta, limits).max() <= 1e-12
    cones = [s.id for s in plan.steps if s.procedure == "cone"]
    assert cones
    for step in cones:
        idx = [i for i, p in enumerate(choreo.points) if p.slot.step_id == step]
        spread = joint_spread_deg(theta[idx])
        assert np.all(spread > 5.0) and np.sum(spread > 90.0) >= 2, (step, spread)


def _env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}


@pytest.mark.parametrize("name", ["commercial7", "desk4"])
def test_aacmm_sim_model_motion_on_a_pty(name: str) -> None:
    limits = _limits(name)
    proc = subprocess.Popen(
        [str(AACMM), "sim", "--model", name, "--motion", "sweep"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
    )
    assert proc.stdout is not None
    try:
        url = proc.stdout.readline().strip()
        assert url.startswith("serial://"), proc.stderr.read() if proc.stderr else ""
        seen = []
        deadline = time.monotonic() + 4.0
        while time.monotonic() < deadline:
            r = subprocess.run(
                [str(AACMM), "measure", "--port", url, "--json"],
                capture_output=True,
                text=True,
                timeout=60,
                env=_env(),
                check=True,
            )
            counts = json.loads(r.stdout)["counts"]
            assert len(counts) == len(limits)
            seen.append(counts)
            time.sleep(0.3)
        theta = np.array(seen, dtype=np.float64) * (2.0 * math.pi / _cpr(name))
        assert _outside(theta, limits).max() <= EPS_RAD, seen
        assert len({tuple(c) for c in seen}) > 3  # the arm moves
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=30)
    assert proc.returncode == 0


@pytest.mark.parametrize(
    ("value", "extra"),
    [
        ("10:5", []),
        ("-,0:400", []),
        ("-,-,-,-,-,-,-,-", []),
        ("0:10,", []),
        ("abc", []),
        ("-90:90", ["--control", "0"]),
        ("-90:90", ["--motion", "replay:/nonexistent"]),
    ],
)
def test_bad_joint_limits_are_one_line(value: str, extra: list[str]) -> None:
    sim = os.environ.get("AACMM_SIM", str(ROOT / "build" / "sim" / "aacmm-sim"))
    r = subprocess.run(
        [sim, "--serial", "pty", f"--joint-limits={value}", *extra],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert r.returncode == 2
    first = r.stderr.splitlines()[0]
    assert first.startswith("aacmm-sim: ") and "--joint-limits" in first, r.stderr
