"""Logs and sessions of any arm (issue 26 item 5, records): N count columns, the
parameter set of any arm in the sidecar, today's six-joint files still read, and a
log or session read with a model of another arm refused in one line.

On the pty simulator started with the 7-axis and the 5-axis shipped models
(``aacmm-sim --param-set``, the set built with ``ParamSet.from_arm``): ``aacmm
log`` writes count1..countN and reads back; ``aacmm capture`` of the probe
calibration plan (the simulator presses the button itself) writes a session of N
count columns; ``aacmm summary`` and ``aacmm export`` read both. Every point the
readers recompute from the counts is checked against a forward kinematics written
here (explicit 4x4 products, docs/kinematics.md's transforms) and against the
device's own point.
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from aacmm.arm import Arm
from aacmm.core import EncoderConfig, Params
from aacmm.models import load_model
from aacmm.plans import load_plan
from aacmm.protocol import ParamSet, Sample, encode_param_set, param_set_crc32
from aacmm.records import ParamSetRecord, RecordError, SessionWriter, read_session
from aacmm.records.logs import read_log, read_triggers
from aacmm.records.paramfile import load_param_file
from aacmm.simulation.process import SimProcess
from aacmm.view.scene import log_scene, session_scene
from clihelp import AACMM, cli_env, one_error_line, run

pytestmark = pytest.mark.timeout(180)

ARMS = {"commercial7": 7, "microscribe5": 5}
DEVICE_BOUND_MM = 2e-3  # the device's float chain, 0.1 um output, against double precision

# -------------------------------------------------------- an independent reference


def _rz(t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float)


def _rx(t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], dtype=float)


def _ry(t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1]], dtype=float)


def _tr(x: float, y: float, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def fk(arm: Arm, theta: np.ndarray) -> np.ndarray:
    """The probe point by explicit 4x4 products: standard [Ry(b)] Rz Tz Tx Rx,
    modified Rx Tx [Ry(b)] Rz Tz (docs/kinematics.md), the tip in the last frame."""
    t = np.eye(4)
    for j, th in zip(arm.joints, theta, strict=True):
        q = th + j.theta_offset_rad
        beta = _ry(j.beta_rad) if j.beta_rad is not None else np.eye(4)
        if j.convention == "standard":
            t = t @ beta @ _rz(q) @ _tr(0, 0, j.d_mm) @ _tr(j.a_mm, 0, 0) @ _rx(j.alpha_rad)
        else:
            t = t @ _rx(j.alpha_rad) @ _tr(j.a_mm, 0, 0) @ beta @ _rz(q) @ _tr(0, 0, j.d_mm)
    out: np.ndarray = (t @ np.array([*arm.tip_mm, 1.0]))[:3]
    return out


def angles(enc: EncoderConfig, counts: np.ndarray) -> np.ndarray:
    """Readings in rad from counts (offset, wrap to a half turn, direction)."""
    out = []
    for c, cpr, z, d in zip(
        counts, enc.counts_per_rev, enc.zero_offset_counts, enc.direction, strict=True
    ):
        delta = (int(c) - z) % cpr
        s = delta if 2 * delta < cpr else delta - cpr
        out.append(d * s * 2.0 * math.pi / cpr)
    return np.array(out)


def reference_points(arm: Arm, enc: EncoderConfig, counts: np.ndarray) -> np.ndarray:
    return np.array([fk(arm, angles(enc, c)) for c in counts])


def set_file(tmp_path: Path, name: str) -> tuple[Path, ParamSet]:
    ps = ParamSet.from_arm(load_model(name).arm)
    f = tmp_path / f"{name}.params.bin"
    f.write_bytes(encode_param_set(ps))
    return f, ps


# -------------------------------------------------------- logs and sessions on the simulator


@pytest.mark.parametrize("name", sorted(ARMS))
def test_log_of_an_arm_on_the_simulator(tmp_path: Path, name: str) -> None:
    n = ARMS[name]
    f, ps = set_file(tmp_path, name)
    arm = load_model(name).arm
    out = tmp_path / "run.csv"
    with SimProcess(
        ["--serial", "pty", "--quiet", "--param-set", str(f), "--button-every", "0.05"]
    ) as sim:
        p = run("log", str(out), "-r", "200", "-n", "100", "-q", "-p", sim.url)
    assert p.returncode == 0, p.stderr
    header = out.read_text().splitlines()[0].split(",")
    counts = [f"count{i}" for i in range(1, n + 1)]
    temps = [f"temp{i}_c" for i in range(1, n + 1)]
    assert header == ["seq", "device_time_us", "host_time", *counts, "x_mm", "y_mm", "z_mm",
                      "flags", "param_crc32", *temps]  # fmt: skip
    meta = json.loads((tmp_path / "run.csv.json").read_text())
    assert meta["joints"] == n and meta["columns"] == header
    assert load_param_file(tmp_path / "run.csv.json") == ps  # what `params set run.csv.json` sends
    log = read_log(out)
    assert len(log) == 100 and log.joints == n
    rec = log.param_set_of(0)
    assert rec.crc32 == param_set_crc32(ps) and rec.to_device() == ps
    assert rec.arm == arm
    ref = reference_points(arm, rec.encoders, log.counts)
    assert np.abs(log.points_mm() - ref).max() < 1e-9
    device = np.column_stack([log.column(c) for c in ("x_mm", "y_mm", "z_mm")])
    assert np.abs(ref - device).max() < DEVICE_BOUND_MM
    trig = read_triggers(log)
    assert trig and all(len(t.sample.counts) == n for t in trig)
    s = run("summary", str(out), "--json")
    assert s.returncode == 0, s.stderr
    summary = json.loads(s.stdout)
    assert summary["samples"] == 100 and summary["joints"] == n
    scene = log_scene(out)  # aacmm view LOG: the arm drawn at the last sample
    assert np.abs(np.array(scene["arm"]["tip"]) - ref[-1]).max() < 1e-5  # scene: 5 decimals
    # capture --from-log: the log's presses as a session of the same arm
    folder = tmp_path / "labelled"
    c = run("capture", "probe-calibration", "--from-log", str(out), "-o", str(folder))
    assert c.returncode == 0, c.stderr
    sess = read_session(folder)
    presses = [t for t in trig if t.pressed and t.button == 0 and t.sample.status & 1]
    assert sess.joints == n and len(sess) == min(len(presses), 30) > 0
    assert sess.counts.tolist() == [list(t.sample.counts) for t in presses[: len(sess)]]


@pytest.mark.parametrize("name", sorted(ARMS))
def test_capture_of_an_arm_on_the_simulator(tmp_path: Path, name: str) -> None:
    """A whole plan (probe calibration, 30 points; the simulator presses the button
    itself, at poses of its random walk: the points are not at the plan's cone,
    which this test does not need: it checks the records)."""
    n = ARMS[name]
    f, _ = set_file(tmp_path, name)
    arm = load_model(name).arm
    out = tmp_path / "s"
    with SimProcess(
        ["--serial", "pty", "--quiet", "--param-set", str(f), "--button-every", "0.1"]
    ) as sim:
        p = run("capture", "probe-calibration", "-o", str(out), "--port", sim.url, timeout=120)
    assert p.returncode == 0, p.stderr
    header = (out / "points.csv").read_text().splitlines()[0].split(",")
    assert [h for h in header if h.startswith("count")] == [f"count{i}" for i in range(1, n + 1)]
    events = (out / "events.csv").read_text().splitlines()[0].split(",")
    assert f"count{n}" in events and f"count{n + 1}" not in events
    s = read_session(out)
    assert s.complete and s.joints == n and s.meta["joints"] == n
    ps = s.param_set_of(0)
    assert ps.arm == arm
    ref = reference_points(arm, ps.encoders, s.counts)
    assert np.abs(s.points_mm() - ref).max() < 1e-9
    assert np.abs(ref - s.device_points_mm).max() < DEVICE_BOUND_MM
    summ = run("summary", str(out))
    assert summ.returncode == 0, summ.stderr
    assert summ.stdout.splitlines()[0] == f"session {out} (complete): 30 of 30 points"
    summ = run("summary", str(out), "--json")
    assert summ.returncode == 0 and json.loads(summ.stdout)["joints"] == n, summ.stderr
    scene = session_scene(out, verify=False)  # aacmm view SESSION: points and the arm
    assert np.abs(np.array(scene["arm"]["tip"]) - ref[-1]).max() < 1e-5  # scene: 5 decimals
    csv_out = tmp_path / "points.csv"
    e = run("export", str(out), "-o", str(csv_out))
    assert e.returncode == 0, e.stderr
    rows = list(csv.DictReader(line for line in csv_out.open() if not line.startswith("#")))
    got = np.array([[float(r[c]) for c in ("x_mm", "y_mm", "z_mm")] for r in rows])
    assert got.shape == (30, 3)
    assert np.abs(got - ref).max() < 1e-5  # 6 decimals


# -------------------------------------------------------- today's files still read

PAPER_LOG_HEADER = (
    "seq,device_time_us,host_time,count1,count2,count3,count4,count5,count6,"
    "x_mm,y_mm,z_mm,flags,param_crc32"
)


def test_todays_six_joint_log_still_reads(tmp_path: Path) -> None:
    """A log in today's format (aacmm-log-2, six count columns, the paper's set in the
    sidecar), written here byte by byte: read as before, its points the paper's."""
    p = Params()
    enc = EncoderConfig()
    crc = param_set_crc32(ParamSet.from_core(p, enc))
    rng = np.random.default_rng(5)
    counts = rng.integers(0, 1 << 32, (4, 6))
    lines = [PAPER_LOG_HEADER]
    for i, c in enumerate(counts):
        x, y, z = fk(p.to_arm(), angles(enc, c))
        lines.append(
            f"{i},{1000 * i},{1.7e9 + i:.6f},{','.join(str(int(v)) for v in c)},"
            f"{x:.4f},{y:.4f},{z:.4f},1,0x{crc:08x}"
        )
    log_path = tmp_path / "old.csv"
    log_path.write_text("\n".join(lines) + "\n")
    side = {
        "format": "aacmm-log-2",
        "status": "complete",
        "samples": 4,
        "param_sets": [
            {
                "param_crc32": crc,
                "params": {
                    "theta_offset_rad": [0.0] * 6,
                    "alpha_rad": [math.pi / 2] * 6,
                    "d_mm": [300.0, 65.5, 792.7, 65.5, 883.2, 0.0],
                    "a_mm": [0.0] * 6,
                    "l_mm": 183.5,
                },
                "encoders": {
                    "counts_per_rev": [1 << 32] * 6,
                    "zero_offset_counts": [0] * 6,
                    "direction": [1] * 6,
                },
                "first_row": 0,
            }
        ],
    }
    (tmp_path / "old.csv.json").write_text(json.dumps(side))
    log = read_log(log_path)
    assert log.joints == 6 and log.param_set_of(0).params == Params()
    assert log.param_set_of(0).is_paper_shape
    ref = reference_points(p.to_arm(), enc, counts)
    assert np.abs(log.points_mm() - ref).max() < 1e-9
    s = run("summary", str(log_path), "--json")
    assert s.returncode == 0, s.stderr


def _sample(counts: tuple[int, ...], seq: int) -> Sample:
    return Sample(seq, 1000 * seq, counts, (0, 0, 0), 1, params=0)


def _session(tmp_path: Path, name: str, arm: Arm, joints: int, k: int = 3) -> Path:
    plan = load_plan("probe-calibration")
    folder = tmp_path / name
    w = SessionWriter.create(folder, plan, joints=joints)
    w.set_param_set(ParamSetRecord.from_device(ParamSet.from_arm(arm)))
    w.begin_run("capture")
    rng = np.random.default_rng(9)
    for i in range(k):
        w.record(_sample(tuple(int(c) for c in rng.integers(0, 1 << 32, joints)), i), 1.7e9 + i)
    w.close("interrupted")
    return folder


def test_todays_six_joint_session_still_reads(tmp_path: Path) -> None:
    """A session in today's format: the sidecar without ``joints``, points.csv with
    today's header (checked here literally; the link temperatures since issue 27, a
    session without them: tests/host/test_device_temps.py)."""
    folder = _session(tmp_path, "old", Arm.paper(), 6)
    side = json.loads((folder / "session.json").read_text())
    del side["joints"]  # what sessions held before arms of other joint counts
    (folder / "session.json").write_text(json.dumps(side))
    head = (folder / "points.csv").read_text().splitlines()[0]
    assert head == (
        "slot,step_index,step_id,procedure,artefact,position_index,end,articulation_index,"
        "point_index,seq,device_time_us,host_time,button,count1,count2,count3,count4,count5,"
        "count6,temp1_c,temp2_c,temp3_c,temp4_c,temp5_c,temp6_c,x_mm,y_mm,z_mm,flags,"
        "param_crc32"
    )
    s = read_session(folder)
    assert s.joints == 6 and len(s) == 3 and s.param_set_of(0).params == Params()
    ref = reference_points(Arm.paper(), EncoderConfig(), s.counts)
    assert np.abs(s.points_mm() - ref).max() < 1e-9
    w = SessionWriter.resume(folder)  # and it continues as a six-joint session
    assert w.joints == 6


@pytest.mark.parametrize("name", ["commercial7", "microscribe5", "desk4"])
def test_session_of_an_arm_at_library_level(tmp_path: Path, name: str) -> None:
    arm = load_model(name).arm
    folder = _session(tmp_path, name, arm, arm.n_joints, k=5)
    s = read_session(folder)
    assert s.joints == arm.n_joints and s.param_set_of(0).arm == arm
    ref = reference_points(arm, EncoderConfig.default(arm.n_joints), s.counts)
    assert np.abs(s.points_mm() - ref).max() < 1e-9
    w = SessionWriter.resume(folder)
    assert w.joints == arm.n_joints and w.accepted == 5


# -------------------------------------------------------- mismatches: one line, nothing computed


def test_session_writer_refuses_a_set_of_another_arm(tmp_path: Path) -> None:
    w = SessionWriter.create(tmp_path / "s", load_plan("probe-calibration"), joints=5)
    seven = ParamSetRecord.from_device(ParamSet.from_arm(load_model("commercial7").arm))
    with pytest.raises(RecordError, match="arm of 7 joints; this session holds an arm of 5"):
        w.set_param_set(seven)
    w.close("interrupted")


def test_session_whose_counts_do_not_match_its_model(tmp_path: Path) -> None:
    """Points of a 5-axis arm, a 7-axis set in the sidecar: refused by the reader;
    ``aacmm summary`` and ``export`` say so in one line, exit 2, and write nothing."""
    five = load_model("microscribe5").arm
    folder = _session(tmp_path, "s", five, 5)
    side = json.loads((folder / "session.json").read_text())
    seven = ParamSetRecord.from_device(ParamSet.from_arm(load_model("commercial7").arm))
    side["param_sets"][0] = seven.to_json()
    side["joints"] = 7
    (folder / "session.json").write_text(json.dumps(side))
    with pytest.raises(RecordError, match=r"5 count columns, but session\.json says the arm has 7"):
        read_session(folder)
    side["joints"] = 5
    (folder / "session.json").write_text(json.dumps(side))
    with pytest.raises(RecordError, match="is an arm of 7 joints"):
        read_session(folder)
    one_error_line(run("summary", str(folder)), 2, "7 joints", "do not match")
    out = tmp_path / "e.csv"
    one_error_line(run("export", str(folder), "-o", str(out)), 2, "7 joints")
    assert not out.exists()


def test_log_whose_counts_do_not_match_its_model(tmp_path: Path) -> None:
    """Today's six-column log with a 7-axis set in its sidecar (CRC right): refused."""
    seven = ParamSetRecord.from_device(ParamSet.from_arm(load_model("commercial7").arm))
    log_path = tmp_path / "m.csv"
    log_path.write_text(PAPER_LOG_HEADER + "\n" + f"0,0,1.0,1,2,3,4,5,6,0,0,0,1,{seven.crc_hex}\n")
    entry = seven.to_json() | {"first_row": 0}
    (tmp_path / "m.csv.json").write_text(
        json.dumps({"format": "aacmm-log-2", "param_sets": [entry]})
    )
    with pytest.raises(RecordError, match=r"6 joint columns .* is an arm of 7 joints"):
        read_log(log_path)
    one_error_line(run("summary", str(log_path)), 2, "6 joint columns", "7 joints")


def test_recompute_with_a_model_of_another_arm_is_refused(tmp_path: Path) -> None:
    five = load_model("microscribe5").arm
    s = read_session(_session(tmp_path, "s", five, 5))
    with pytest.raises(RecordError, match="arm of 5 joints; the model given is an arm of 6"):
        s.points_mm(Params())
    desk = load_model("desk4").arm
    with pytest.raises(RecordError, match="an arm of 4 joints"):
        s.points_mm(desk)
    # same joint count, another shape (standard DH, no betas): also refused
    other = Arm.from_sequences(
        ["standard"] * 5, [0.0] * 5, [math.pi / 2] * 5, [100.0] * 5, [0.0] * 5
    )
    with pytest.raises(RecordError, match="another shape"):
        s.points_mm(other)
    moved = five.with_vector(five.to_vector() + 1e-3)  # same arm, other values: computed
    assert s.points_mm(moved).shape == (3, 3)


def test_sidecar_set_with_lists_of_the_wrong_length_is_refused(tmp_path: Path) -> None:
    seven = ParamSetRecord.from_device(ParamSet.from_arm(load_model("commercial7").arm))
    d = seven.to_json()
    d["encoders"]["direction"] = d["encoders"]["direction"][:6]
    with pytest.raises(RecordError, match=r"direction must be a list of 7 integers"):
        ParamSetRecord.from_json(d, "x")
    d = seven.to_json()
    d["params"]["convention"] = ["sideways"] * 7
    with pytest.raises(RecordError, match=r"convention\[0\] must be one of"):
        ParamSetRecord.from_json(d, "x")


def test_plain_file_of_poses_of_an_arm(tmp_path: Path) -> None:
    """A plain CSV of ``theta1..theta7`` (or counts) with a sidecar holding the arm's
    ``params``: read with that arm; without the sidecar: one line, nothing computed."""
    arm = load_model("commercial7").arm
    rec = ParamSetRecord.from_device(ParamSet.from_arm(arm))
    rng = np.random.default_rng(2)
    theta = rng.uniform(-3.0, 3.0, (12, 7))
    f = tmp_path / "p7.csv"
    f.write_text(
        ",".join(f"theta{i}" for i in range(1, 8))
        + "\n"
        + "".join(",".join(repr(float(v)) for v in row) + "\n" for row in theta)
    )
    with pytest.raises(RecordError, match="7 joint columns: a file of poses of an arm other"):
        read_log(f)
    (tmp_path / "p7.csv.json").write_text(json.dumps({"params": rec.to_json()["params"]}))
    log = read_log(f)
    assert log.joints == 7 and log.param_set_of(0).arm == arm and log.params_given
    ref = np.array([fk(arm, t) for t in theta])
    assert np.abs(log.points_mm() - ref).max() < 1e-9
    bad = rec.to_json()["params"] | {"d_mm": [1.0] * 6}
    (tmp_path / "p7.csv.json").write_text(json.dumps({"params": bad}))
    with pytest.raises(RecordError, match=r"d_mm must be a list of 7 numbers"):
        read_log(f)


def test_reconnect_to_an_arm_of_another_joint_count_ends_the_log(tmp_path: Path) -> None:
    """``aacmm log --reconnect``: the device comes back as a 5-axis arm under a 7-axis
    log: one line, exit 2, the rows so far kept and readable as the 7-axis arm's."""
    f7, _ = set_file(tmp_path, "commercial7")
    f5, _ = set_file(tmp_path, "microscribe5")
    link = tmp_path / "arm"
    out = tmp_path / "run.csv"
    args = ["log", str(out), "-r", "100", "-d", "6", "--reconnect", "-q", "-p", f"serial://{link}"]
    first = SimProcess(["--serial", "pty", "--quiet", "--param-set", str(f7)], link=link)
    try:
        logger = subprocess.Popen(
            [str(AACMM), *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=cli_env(),
        )
        end = time.monotonic() + 20
        while not (out.exists() and out.read_text().count("\n") > 51):  # header + 51 rows
            assert time.monotonic() < end, "no rows"
            time.sleep(0.05)
    finally:
        first.stop()
    time.sleep(1.0)
    with SimProcess(["--serial", "pty", "--quiet", "--param-set", str(f5)], link=link):
        _, err = logger.communicate(timeout=30)
    assert logger.returncode == 2, err
    lines = err.strip().splitlines()
    assert lines[-1].startswith("aacmm log: error: ") and "arm of 5 joints" in lines[-1], err
    assert "7 count columns" in lines[-1]
    log = read_log(out)
    assert log.joints == 7 and len(log.param_sets) == 1 and len(log) > 50
    assert log.meta["status"] == "error" and "arm of 5 joints" in log.meta["end_reason"]


def test_resume_on_a_device_of_another_arm_is_refused(tmp_path: Path) -> None:
    """``aacmm capture --resume`` of a 5-axis session on a 7-axis device: one line,
    exit 2, the session untouched."""
    folder = _session(tmp_path, "s5", load_model("microscribe5").arm, 5)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    f7, _ = set_file(tmp_path, "commercial7")
    with SimProcess(["--serial", "pty", "--quiet", "--param-set", str(f7)]) as sim:
        p = run("capture", "probe-calibration", "-o", str(folder), "--resume", "-p", sim.url)
    one_error_line(p, 2, "arm of 7 joints", "this session holds an arm of 5")
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
