"""`aacmm mc` for any arm (issue 26): `--model` computes another arm's coefficients
(checked against the numpy DH oracle of test_core_arm over the same poses, not the
C core), `--log` takes the arm from a 7-axis log's sidecar, and the refusals: a log
of another arm than --model (exit 10, one line), joints the arm does not have. The
paper's arm stays the default with its Table 2."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from aacmm.analysis import mc_poses
from aacmm.cli import main
from aacmm.commands.exitcodes import USAGE, WRONG_ARM
from aacmm.core import EncoderConfig
from aacmm.models import load_model, shipped_model_path
from aacmm.protocol import ParamSet
from aacmm.records import ParamSetRecord
from aacmm.records.schema import log_columns
from test_core_arm import oracle


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    rc = main(argv)
    out = capsys.readouterr()
    return rc, out.out, out.err


def _angles(enc: EncoderConfig, counts: np.ndarray) -> np.ndarray:
    """Readings in rad from counts (zero offset, wrap to a half turn, direction)."""
    cpr = np.array(enc.counts_per_rev, dtype=np.int64)
    delta = (counts.astype(np.int64) - np.array(enc.zero_offset_counts)) % cpr
    s = np.where(2 * delta < cpr, delta, delta - cpr)
    out: np.ndarray = np.array(enc.direction) * s * (2.0 * math.pi / cpr)
    return out


def _log(tmp_path: Path, name: str, rows: int = 300) -> tuple[Path, np.ndarray]:
    """An ``aacmm log`` CSV of the arm model ``name`` (format aacmm-log-2: N count
    columns, its parameter set in the sidecar), written here; and its joint angles."""
    arm = load_model(name).arm
    rec = ParamSetRecord.from_device(ParamSet.from_arm(arm))
    rng = np.random.default_rng(7)
    cpr = np.array(rec.encoders.counts_per_rev, dtype=np.int64)
    counts = (rng.random((rows, arm.n_joints)) * cpr).astype(np.int64)
    theta = _angles(rec.encoders, counts)
    lines = [",".join(log_columns(arm.n_joints))]
    for i, (c, t) in enumerate(zip(counts, theta, strict=True)):
        x, y, z = oracle(arm, t)[0]
        lines.append(
            f"{i},{1000 * i},{1.7e9 + i:.6f},{','.join(str(int(v)) for v in c)},"
            f"{x:.4f},{y:.4f},{z:.4f},1,{rec.crc_hex}"
        )
    path = tmp_path / f"{name}.csv"
    path.write_text("\n".join(lines) + "\n")
    side: dict[str, object] = {"format": "aacmm-log-2", "status": "complete", "samples": rows}
    side["param_sets"] = [rec.to_json() | {"first_row": 0}]
    (tmp_path / f"{name}.csv.json").write_text(json.dumps(side))
    return path, theta


def _coefficients(doc: dict[str, object], names: tuple[str, ...]) -> np.ndarray:
    c = doc["coefficients"]
    assert isinstance(c, dict) and list(c) == list(names)
    return np.array([[c[n][a]["mean_abs"] for n in names] for a in "xyz"])


def test_mc_model_of_a_seven_axis_arm(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    arm = load_model("commercial7").arm
    out_json, out_csv, out_png = tmp_path / "c.json", tmp_path / "c.csv", tmp_path / "c.png"
    argv = ["mc", "--model", "commercial7", "-n", "1500", "--seed", "5", "--threads", "2"]
    rc, out, err = _run(
        [*argv, "--json", str(out_json), "--csv", str(out_csv), "--png", str(out_png)], capsys
    )
    assert rc == 0, err
    assert "arm: commercial7 (7 joints, 31 parameters)" in out and "no comparison" in out
    assert "theta7" in out and "paper" not in out.split("\n", 2)[2]
    doc = json.loads(out_json.read_text())
    assert "table2" not in doc and doc["arm"]["model"] == "commercial7"
    # the poses: within the model's joint limits (its hinges' own ranges), each
    # joint drawn uniformly between its limits ([-180, 180) deg for a roll)
    model = load_model("commercial7")
    ranges = [
        (-math.pi, math.pi) if math.isinf(lo) else (lo, hi) for lo, hi in model.joint_limits_rad
    ]
    assert "uniform[-150, 150) deg" in out and "uniform[-115, 115) deg" in out
    js = [mc_poses.JointDistribution.uniform(lo, hi) for lo, hi in ranges]
    theta = mc_poses.draw_poses(1500, js, seed=5, count=7)
    assert all(model.within_limits(q) for q in theta)
    ref = np.abs(np.array([oracle(arm, q)[1] for q in theta])).mean(axis=0)
    assert np.allclose(_coefficients(doc, arm.param_names), ref, rtol=1e-9, atol=1e-9)
    rows = list(csv.DictReader(out_csv.open()))
    assert len(rows) == 3 * 31 and {r["paper"] for r in rows} == {""}
    assert {r["unit"] for r in rows if r["parameter"] == "theta7"} == {"mm/rad"}
    assert out_png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # a joint range of the seventh joint: its own, not the paper's six
    rc, _, err = _run([*argv, "--range", "7", "-90", "90", "-q"], capsys)
    assert rc == 0, err
    rc, _, err = _run(["mc", "-n", "10", "--range", "7", "-90", "90"], capsys)
    assert rc == USAGE and "1..6" in err and err.count("\n") == 1


def test_the_paper_arm_is_still_the_default(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    assert _run(["mc", "-n", "2000", "--seed", "3", "-q", "--json", str(a)], capsys)[0] == 0
    argv = ["mc", "--model", "gao2013", "-n", "2000", "--seed", "3", "--json", str(b)]
    rc, out, _ = _run(argv, capsys)
    assert rc == 0 and "paper" in out and "max |relative deviation| from the paper" in out
    da, db = json.loads(a.read_text()), json.loads(b.read_text())
    assert da["table2"] == db["table2"] and da["coefficients"] == db["coefficients"]
    assert "arm" not in da
    # a 6-axis model of the paper's shape but its own figures: no Table 2
    rc, out, _ = _run(["mc", "--model", "mpe2018", "-n", "500", "--seed", "3"], capsys)
    assert rc == 0 and "arm: mpe2018 (6 joints, 25 parameters)" in out
    assert "max |relative deviation|" not in out


def test_mc_log_of_a_seven_axis_arm(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    arm = load_model("commercial7").arm
    log, theta = _log(tmp_path, "commercial7")
    ref = np.abs(np.array([oracle(arm, q)[1] for q in theta])).mean(axis=0)
    for extra in ([], ["--model", "commercial7"]):
        out_json = tmp_path / f"l{len(extra)}.json"
        rc, out, err = _run(["mc", "--log", str(log), *extra, "--json", str(out_json)], capsys)
        assert rc == 0, err
        assert "31 parameters" in out and "Table 2" in out  # "... no comparison"
        doc = json.loads(out_json.read_text())
        assert doc["n"] == theta.shape[0] and "table2" not in doc
        assert np.allclose(_coefficients(doc, arm.param_names), ref, rtol=1e-9, atol=1e-9)
    # the log of a 7-axis arm against other models: one line, exit 10
    for other in ("gao2013", "microscribe5", "mpe2018"):
        rc, out, err = _run(["mc", "--log", str(log), "--model", other], capsys)
        assert rc == WRONG_ARM and out == ""
        assert err.count("\n") == 1 and "7 joints" in err and f"model {other}" in err


def test_mc_log_of_another_shape_than_the_model(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Same joint count, another shape: the 5-axis log (modified DH, beta3, tip
    vector) against a 5-joint model file of standard joints; and a plain file of
    poses without a sidecar against a model of another joint count."""
    log5, _ = _log(tmp_path, "microscribe5", rows=20)
    src = shipped_model_path("microscribe5").read_text()
    std = src.replace('convention = "modified"', 'convention = "standard"')
    assert std != src
    f = tmp_path / "std5.toml"
    f.write_text(std)
    rc, _, err = _run(["mc", "--log", str(log5), "--model", str(f)], capsys)
    assert rc == WRONG_ARM and err.count("\n") == 1, err
    plain = tmp_path / "poses.csv"
    plain.write_text("theta1,theta2,theta3,theta4,theta5,theta6\n0,1,2,3,1,0\n")
    rc, _, err = _run(["mc", "--log", str(plain), "--model", "commercial7"], capsys)
    assert rc == WRONG_ARM and "6 joint columns" in err and err.count("\n") == 1
    rc, out, err = _run(["mc", "--log", str(plain)], capsys)
    assert rc == 0 and "max |relative deviation| from the paper" in out
