"""``aacmm sim --model NAME|FILE`` and parameter files of any arm (issue 26, item 5).

On a pty simulator started by the command line as a user starts it: ``aacmm
info`` names the model's N and P; the set the device holds is the model's
nominal set (read back with ``aacmm params get`` and compared with
``ParamSet.from_arm`` of the model file); the points and Jacobians of
``aacmm measure`` and ``aacmm compute`` agree with ``aacmm.core`` in double
precision on that set (the device's single-precision chain: within 1 um);
``--truth random:SEED`` of a model (7, 5 and 4 joints) writes the model's random truth
(:func:`aacmm.simulation.truth.model_truth`, recomputed here) and walks the
true arm within the model's joint limits (every reading checked against them);
``params get``/``set`` round-trips a 7-axis set and loads a model file (the
model change is noted); bad models and truths of another model are one line
and exit status 2.
"""

from __future__ import annotations

import json
import math
import os
import random
import signal
import subprocess
import sys
import time
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from aacmm import core
from aacmm.models import load_model, shipped_model_path
from aacmm.protocol import ParamSet
from aacmm.records.paramfile import (
    ParamFileError,
    dump_param_set,
    load_param_file,
    param_set_from_mapping,
)
from aacmm.simulation.truth import load_truth, model_truth

AACMM = Path(sys.executable).with_name("aacmm")
FLOAT_PATH_BOUND_MM = 1e-3  # the device's single-precision chain against float64
USAGE = 2


def _env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}


def aacmm(*args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    r = subprocess.run(
        [str(AACMM), *args], capture_output=True, text=True, timeout=60, env=_env(), check=False
    )
    if check:
        assert r.returncode == 0, r.stderr
    return r


class SimCommand:
    """``aacmm sim ARGS`` in the background, its URL and the lines it said."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            [str(AACMM), "sim", *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=_env(),
        )
        assert self.proc.stdout is not None and self.proc.stderr is not None
        self.url = self.proc.stdout.readline().strip()
        if not self.url.startswith("serial://"):
            self.proc.kill()
            pytest.fail(f"aacmm sim did not start: {self.proc.stderr.read()}")
        self.first_line = self.proc.stderr.readline().strip()

    def stop(self) -> str:
        self.proc.send_signal(signal.SIGTERM)
        _, err = self.proc.communicate(timeout=30)
        assert self.proc.returncode == 0, err
        return err


@pytest.fixture(params=["commercial7", "microscribe5"])
def model_sim(request: pytest.FixtureRequest) -> Iterator[tuple[Any, SimCommand]]:
    model = load_model(request.param)
    s = SimCommand("--model", request.param)
    try:
        yield model, s
    finally:
        s.stop()


def _nominal(model: Any) -> ParamSet:
    return ParamSet.from_arm(model.arm, model.encoder_config())


def _reference(model_arm: Any, enc: core.EncoderConfig, counts: list[int]) -> Any:
    theta = core.counts_to_angles(np.array([counts], dtype=np.int64), enc)[0]
    return core.Model(model_arm).point_jacobian(theta)


def test_model_on_pty_info_params_measure_compute(
    model_sim: tuple[Any, SimCommand], tmp_path: Path
) -> None:
    model, s = model_sim
    n, p = model.n_joints, model.n_params
    assert s.first_line == f"aacmm sim: model {model.name}: {n} joints, {p} parameters"
    info = aacmm("info", "--port", s.url)
    assert f"arm model   {n} joints, {p} parameters" in info.stdout
    js = json.loads(aacmm("info", "--port", s.url, "--json").stdout)
    assert (js["joints"], js["params"]) == (n, p)
    # the set the device holds is the model file's nominal set, read back as a file
    out = tmp_path / "device.toml"
    aacmm("params", "get", "--port", s.url, "-o", str(out))
    held = load_param_file(out)
    assert held == _nominal(model)
    arm, enc = held.to_arm()
    assert arm == model.arm and enc == model.encoder_config()
    # measure: the device's point and Jacobian of the counts it read
    for _ in range(3):
        m = json.loads(aacmm("measure", "--port", s.url, "--json", "-j").stdout)
        assert len(m["counts"]) == n
        point, jac = _reference(model.arm, model.encoder_config(), m["counts"])
        assert np.max(np.abs(np.array(m["point_mm"]) - point)) < FLOAT_PATH_BOUND_MM
        j = np.array(m["jacobian"])
        assert j.shape == jac.shape == (3, p)
        assert np.allclose(j, jac, rtol=1e-4, atol=1e-3)
    text = aacmm("measure", "--port", s.url, "-j").stdout
    assert f"  {model.arm.param_names[-1]:<7} " in text  # columns named by the model
    # compute: counts of our choosing, all over each encoder's range
    rng = random.Random(26)
    for i in range(4):
        counts = [rng.randrange(c) for c in model.encoder_config().counts_per_rev]
        args = ["compute", "--port", s.url, "--json", *map(str, counts)]
        r = json.loads(aacmm(*args, *(["-j"] if i % 2 else [])).stdout)
        point, jac = _reference(model.arm, model.encoder_config(), counts)
        assert np.max(np.abs(np.array(r["point_mm"]) - point)) < FLOAT_PATH_BOUND_MM
        if i % 2:
            assert np.allclose(np.array(r["jacobian"]), jac, rtol=1e-4, atol=1e-3)
    bad = aacmm("compute", "--port", s.url, *["1"] * (13 - n), check=False)
    assert bad.returncode != 0 and bad.stderr.count("\n") == 1, bad.stderr


def _angles_in_limits(model: Any, counts: list[int]) -> bool:
    theta = core.counts_to_angles(np.array([counts], dtype=np.int64), model.encoder_config())[0]
    return bool(model.within_limits(theta))


@pytest.mark.parametrize("name", ["commercial7", "microscribe5", "desk4"])
def test_model_random_truth_walks_within_the_limits(name: str, tmp_path: Path) -> None:
    model = load_model(name)
    truth_file = tmp_path / "truth.toml"
    s = SimCommand("--model", name, "--truth", "random:5", "--truth-out", str(truth_file))
    try:
        truth = load_truth(truth_file)
        want = model_truth(5, model)
        assert np.array_equal(truth.params.to_vector(), want.params.to_vector())
        assert (truth.encoders, truth.errors) == (want.encoders, want.errors)
        js = json.loads(aacmm("info", "--port", s.url, "--json").stdout)
        assert js["serial_number"] == want.device_serial == truth.device_serial
        # a truth file is a parameter file of its arm (its error tables are not parameters)
        assert load_param_file(truth_file) == ParamSet.from_arm(want.params, want.encoders)
        out = tmp_path / "device.toml"
        aacmm("params", "get", "--port", s.url, "-o", str(out))
        assert load_param_file(out) == _nominal(model)  # the device holds the nominal set
        seen = []
        deadline = time.monotonic() + 6.0
        while time.monotonic() < deadline:
            m = json.loads(aacmm("measure", "--port", s.url, "--json").stdout)
            assert _angles_in_limits(model, m["counts"]), m["counts"]
            # the device computes with its nominal set, not with the truth
            point, _ = _reference(model.arm, model.encoder_config(), m["counts"])
            assert np.max(np.abs(np.array(m["point_mm"]) - point)) < FLOAT_PATH_BOUND_MM
            seen.append(tuple(m["counts"]))
            time.sleep(0.4)
        assert len(set(seen)) > 3  # the true arm walks
    finally:
        s.stop()
    # the same truth file given back is taken; another model's is refused in one line
    s = SimCommand("--model", name, "--truth", str(truth_file), "--motion", "static")
    s.stop()
    other = "microscribe5" if name == "commercial7" else "commercial7"
    r = aacmm("sim", "--model", other, "--truth", str(truth_file), check=False)
    assert r.returncode == USAGE and r.stderr.count("\n") == 2, r.stderr  # model line + error
    assert f"not of the model {other}" in r.stderr.splitlines()[-1]
    r = aacmm("sim", "--truth", str(truth_file), check=False)  # the default model: gao2013
    assert r.returncode == USAGE and r.stderr.count("\n") == 1, r.stderr
    assert "not of the model gao2013 (6 joints, 25 parameters)" in r.stderr


def test_params_get_set_round_trip_of_a_7_axis_set(tmp_path: Path) -> None:
    model = load_model("commercial7")
    s = SimCommand("--model", "commercial7")
    try:
        got = tmp_path / "got.toml"
        aacmm("params", "get", "--port", s.url, "-o", str(got))
        data = tomllib.loads(got.read_text())
        assert len(data["theta_offset_rad"]) == 7 and len(data["tip_mm"]) == 3
        assert "l_mm" not in data
        # an engineer's edit: the elbow 0.2 mm longer, the tip moved, written back
        data["a_mm"][2] += 0.2
        data["tip_mm"][0] -= 0.5
        edited = tmp_path / "edited.json"
        edited.write_text(json.dumps(data))
        r = aacmm("params", "set", "--port", s.url, str(edited))
        assert "read back and identical" in r.stdout and "note" not in r.stderr
        back = json.loads(aacmm("params", "get", "--port", s.url, "--format", "json").stdout)
        assert back["a_mm"][2] == model.arm.joints[2].a_mm + 0.2
        assert back["tip_mm"] == [model.arm.tip_mm[0] - 0.5, *model.arm.tip_mm[1:]]
        again = tmp_path / "again.toml"
        aacmm("params", "get", "--port", s.url, "-o", str(again))
        assert load_param_file(again) == load_param_file(edited)
        # a model file: its nominal set; the arm model changes, and the command says so
        m5 = shipped_model_path("microscribe5")
        r = aacmm("params", "set", "--port", s.url, str(m5))
        note = "note: the device's arm model changes from 7 joints, 31 parameters"
        assert note in r.stderr and "to 5 joints, 24 parameters" in r.stderr, r.stderr
        assert "arm model   5 joints, 24 parameters" in aacmm("info", "--port", s.url).stdout
        aacmm("params", "get", "--port", s.url, "-o", str(tmp_path / "m5.toml"))
        assert load_param_file(tmp_path / "m5.toml") == _nominal(load_model("microscribe5"))
        chk = aacmm("params", "set", "--check", str(m5))
        assert "valid parameter set, 5 joints, 24 parameters" in chk.stdout
        aacmm("params", "defaults", "--port", s.url)  # the simulator's defaults: the model's
        assert "arm model   7 joints, 31 parameters" in aacmm("info", "--port", s.url).stdout
    finally:
        s.stop()


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--model", "no-such-model"], "no such file, nor a shipped model"),
        (["--model", "commercial7", "--cpr", "1024"], "counts per revolution"),
        (["--model", "commercial7", "--board", "mps2-an386"], "no --model"),
        (["--model", "{bad}"], "joints"),
    ],
)
def test_bad_models_are_one_line(args: list[str], needle: str, tmp_path: Path) -> None:
    if "{bad}" in args:  # a model file of 8 joints: its last joint once more
        text = shipped_model_path("commercial7").read_text()
        bad = tmp_path / "bad8.toml"
        bad.write_text(text + "\n[[joints]]" + text.split("[[joints]]")[-1])
        args = [str(bad) if a == "{bad}" else a for a in args]
    r = aacmm("sim", *args, check=False)
    assert r.returncode == USAGE, r.stderr
    last = r.stderr.splitlines()[-1]
    assert last.startswith("aacmm sim: error: ") and needle in last, r.stderr
    assert not any("Traceback" in ln for ln in r.stderr.splitlines())


def test_param_files_of_every_shipped_model_round_trip() -> None:
    for name in ("commercial7", "microscribe5", "desk4", "mpe2018", "gao2013"):
        model = load_model(name)
        ps = _nominal(model)
        for fmt in ("toml", "json"):
            text = dump_param_set(ps, fmt, 1)
            data = tomllib.loads(text) if fmt == "toml" else json.loads(text)
            assert param_set_from_mapping(data, name) == ps
            paper_keys = {"format", "param_crc32", "theta_offset_rad", "alpha_rad", "d_mm"}
            paper_keys |= {"a_mm", "l_mm", "counts_per_rev", "zero_offset_counts", "direction"}
            assert (set(data) == paper_keys) == ps.is_paper_shape


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda d: d.update(d_mm=d["d_mm"][:6]), "d_mm must be a list of 7 numbers"),
        (lambda d: d.update(convention=["dh"] * 7), "convention[0] must be one of"),
        (lambda d: d.update(beta_joints=[1], beta_rad=[0.0]), "joint 1 has no beta"),
        (lambda d: d.pop("beta_rad"), "beta_joints and beta_rad go together"),
        (lambda d: d.update(l_mm=100.0), "l_mm and tip_mm"),
        (lambda d: d.update(tip_mm=[0.0, math.nan, 1.0]), "tip_mm[1] is not finite"),
        (lambda d: d.update(theta_offset_rad=[0.0] * 8), "4 to 7 numbers"),
    ],
)
def test_bad_param_files_of_any_arm(edit: Any, needle: str) -> None:
    data = json.loads(dump_param_set(_nominal(load_model("commercial7")), "json"))
    data.setdefault("beta_joints", [3])
    data.setdefault("beta_rad", [0.001])
    edit(data)
    with pytest.raises(ParamFileError) as info:
        param_set_from_mapping(data, "f.json")
    assert needle in str(info.value) and str(info.value).startswith("f.json: ")


def test_model_scenario_operator_within_limits_true_tip_on_target(tmp_path: Path) -> None:
    """``aacmm sim --model commercial7 --scenario probe-calibration``: a client
    streams and takes the 30 presses as ``aacmm capture`` would. Every press is
    read back from the device's own trigger samples: the readings within the
    model's joint limits, the device's point computed with the nominal set
    (core on the counts), the true tip (core on the truth file's arm at the
    same readings) on the plan's seat within the encoder and probing errors,
    while the uncalibrated device's points scatter by far more."""
    from aacmm.client import connect
    from aacmm.plans import load_plan

    model = load_model("commercial7")
    truth_file, report_file = tmp_path / "truth.toml", tmp_path / "report.json"
    s = SimCommand(
        "--model", "commercial7", "--scenario", "probe-calibration", "--fast", "--quiet",
        "--truth", "random:2", "--truth-out", str(truth_file), "--report", str(report_file),
    )  # fmt: skip
    plan = load_plan("probe-calibration")
    presses: list[Any] = []
    with connect(s.url, timeout=2.0) as c:
        stream = c.stream(20)
        while len(presses) < len(plan.slots):
            t = c.wait_trigger(timeout=60.0)
            if t.button == 0 and t.pressed:
                presses.append(t.sample)
        stream.stop()
    _, err = s.proc.communicate(timeout=60)
    assert s.proc.returncode == 0, err
    report = json.loads(report_file.read_text())
    truth = load_truth(truth_file)
    enc = model.encoder_config()
    counts = np.array([p.counts for p in presses], dtype=np.int64)
    assert counts.shape == (30, 7)
    assert [tuple(p["counts"]) for p in report["presses"] if p["button"] == 0] == [
        tuple(r) for r in counts.tolist()
    ]
    theta = core.counts_to_angles(counts, enc)
    assert all(model.within_limits(th) for th in theta)
    device = np.array([[v * 1e-4 for v in p.point_100nm] for p in presses])
    assert np.max(np.abs(device - core.Model(model.arm).points(theta))) < FLOAT_PATH_BOUND_MM
    true_tip = core.Model(truth.params).points(theta)
    target = np.array([p["target_mm"] for p in report["presses"] if p["button"] == 0])
    # 0.3 arcsec noise + 2 arcsec eccentricity over a 1.3 m arm, 2 um probing: < 50 um
    assert np.max(np.linalg.norm(true_tip - target, axis=1)) < 0.05
    scatter = np.linalg.norm(device - device.mean(axis=0), axis=1)
    assert np.max(scatter) > 0.2  # the device computes with its nominal set, not the truth
    spread = report["joint_spread_deg"]["pivot"]
    assert len(spread) == 7 and min(spread) > 45  # articulations over every joint


def _arms() -> Any:
    from aacmm.arm import Arm, Joint
    from hypothesis import strategies as st

    angle = st.floats(-6.28, 6.28, allow_nan=False)
    length = st.floats(-9999.0, 9999.0, allow_nan=False)

    @st.composite
    def arm(draw: Any) -> tuple[Arm, core.EncoderConfig]:
        n = draw(st.integers(4, 7))
        joints = []
        for i in range(n):
            beta = draw(st.none() | angle) if i else None
            conv = draw(st.sampled_from(["standard", "modified"]))
            joints.append(Joint(conv, draw(angle), draw(angle), draw(length), draw(length), beta))
        tip = draw(st.sampled_from(["z", "xyz"]))
        vec = (draw(length), draw(length), draw(length)) if tip == "xyz" else (0, 0, draw(length))
        cpr = [draw(st.integers(2, 1 << 32)) for _ in range(n)]
        zero = [draw(st.integers(0, c - 1)) for c in cpr]
        direction = [draw(st.sampled_from([1, -1])) for _ in range(n)]
        return Arm(tuple(joints), tip, vec), core.EncoderConfig(
            tuple(cpr), tuple(zero), tuple(direction)
        )

    return arm()


def test_param_files_of_any_arm_round_trip_exactly() -> None:
    from hypothesis import given, settings

    @settings(max_examples=200, deadline=None)
    @given(_arms())
    def check(case: Any) -> None:
        arm, enc = case
        ps = ParamSet.from_arm(arm, enc)
        for fmt in ("toml", "json"):
            text = dump_param_set(ps, fmt)
            data = tomllib.loads(text) if fmt == "toml" else json.loads(text)
            back = param_set_from_mapping(data, "f")
            assert back == ps
            assert back.to_arm() == (arm, enc)

    check()


def test_hostile_param_mappings_are_one_error() -> None:
    from hypothesis import given, settings
    from hypothesis import strategies as st

    base = json.loads(dump_param_set(_nominal(load_model("microscribe5")), "json"))
    leaf = st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8)
    value = st.recursive(leaf, lambda v: st.lists(v, max_size=8), max_leaves=20)

    @settings(max_examples=300, deadline=None)
    @given(st.sampled_from(sorted(base)), value)
    def check(key: str, v: Any) -> None:
        data = {**base, key: v}
        try:
            param_set_from_mapping(data, "f.json")
        except ParamFileError as exc:
            assert str(exc).startswith("f.json: ") and "\n" not in str(exc)

    check()
