"""``aacmm calibrate`` on capture sessions written from a known truth (no device needed).

Sessions of the shipped plans are made with :func:`calib_synth.plan_session`
(inverse kinematics on the truth to each slot's nominal target, counts at
2^32 per revolution, written by :class:`aacmm.records.SessionWriter`). Most
runs call :func:`aacmm.cli.main` in-process; one runs the real command.
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from aacmm.cli import main
from aacmm.core import PARAM_NAMES, EncoderConfig, Model, Params
from aacmm.plans import load_plan
from aacmm.records import ParamSetRecord, SessionWriter
from aacmm.records.paramfile import load_param_file
from calib_synth import perturbed_truth, plan_session
from test_calibration import SINGLES, combo_cov, combos

pytestmark = pytest.mark.timeout(300)
SIGMA = 0.005


@pytest.fixture(scope="module")
def truth() -> Params:
    return perturbed_truth(np.random.default_rng(101))


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory, truth: Params) -> Path:
    d = tmp_path_factory.mktemp("calib") / "s1"
    plan_session(d, "kinematic-calibration", truth, 102, SIGMA)
    return d


def run(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(["calibrate", *args])
    out, err = capsys.readouterr()
    return code, out, err


def params_of(path: Path) -> Params:
    ps = load_param_file(path)  # what `aacmm params set` loads
    return Params(ps.theta_offset_rad, ps.alpha_rad, ps.d_mm, ps.a_mm, ps.l_mm)


def test_calibrate_a_session(
    session: Path, truth: Params, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out_file = tmp_path / "cal.toml"
    rep = tmp_path / "report"
    code, out, err = run(
        [str(session), "-o", str(out_file), "--report", str(rep), "--workspace", "20"], capsys
    )
    assert code == 0, err
    assert "Identifiability at the parameters in force" in out
    assert "rank 21 of 25" in out and "[theta1]" in out and "[tip]" in out
    assert "Before / after on the calibration data" in out
    assert "stage 1, evaluation" in err  # solver progress
    cal = params_of(out_file)
    prov = json.loads((tmp_path / "cal.provenance.json").read_text())
    cov = np.array(prov["result"]["covariance"])
    sd = np.sqrt(np.diag(combo_cov(cal, cov)))
    err_c = np.abs(combos(cal) - combos(truth))
    assert np.all(err_c <= 5 * sd), dict(zip([*SINGLES, "tx", "ty", "tz"], err_c / sd, strict=True))
    assert prov["format"] == "aacmm-calibration-1"
    assert prov["sessions"][0]["path"] == str(session)
    assert prov["sessions"][0]["param_crc32"].startswith("0x")
    assert prov["result"]["chi_square"]["verdict"] == "consistent"
    assert prov["result"]["identifiability"]["rank"] == 21
    assert len(prov["point_uncertainty"]["workspace_poses"]) == 20
    # the encoder configuration is carried over unchanged
    assert load_param_file(out_file).counts_per_rev == (1 << 32,) * 6
    names = sorted(p.name for p in rep.iterdir())
    assert "report.txt" in names and "spectrum.png" in names and "uncertainty.png" in names
    assert sum(n.startswith("residuals-step") for n in names) == 6  # 3 seats, 3 bars
    for n in names:
        if n.endswith(".png"):
            assert (rep / n).read_bytes()[:4] == b"\x89PNG"
    # an existing output is refused without --force, and nothing is overwritten
    before = out_file.read_bytes()
    code, _, err = run([str(session), "-o", str(out_file)], capsys)
    assert code == 2 and "exists" in err and len(err.strip().splitlines()) == 1
    assert out_file.read_bytes() == before
    code, _, err = run([str(session), "-o", str(out_file), "--force", "-q"], capsys)
    assert code == 0 and err == ""


def test_held_out_session_and_kfold(
    session: Path, truth: Params, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    held = tmp_path / "held"
    plan_session(held, "kinematic-calibration", truth, 103, SIGMA)
    code, out, err = run(
        [
            str(session),
            "-o",
            str(tmp_path / "c.toml"),
            "--validate",
            str(held),
            "--kfold",
            "3",
            "--workspace",
            "0",
            "-q",
        ],
        capsys,
    )
    assert code == 0, err
    assert "Held-out sessions (not used by the fit)" in out
    assert "3-fold cross-validation" in out
    prov = json.loads((tmp_path / "c.provenance.json").read_text())
    rows = {r["figure"]: r for r in prov["validation"]}
    assert rows["length_rms_mm"]["factor"] > 20 and rows["cone_rms_mm"]["factor"] > 20
    assert rows["length_rms_mm"]["after"] < 0.015


def test_probe_calibration_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    v = Params().to_vector()
    k = {n: i for i, n in enumerate(PARAM_NAMES)}
    v[[k["d6"], k["a6"], k["l"]]] += [0.2, -0.3, 0.5]
    truth = Params.from_vector(v)
    s = tmp_path / "probe"
    plan_session(s, "probe-calibration", truth, 104, SIGMA)
    code, out, err = run([str(s), "-o", str(tmp_path / "tip.toml"), "--probe", "-q"], capsys)
    assert code == 0, err
    assert "RMS pivot error" in out and "orientation spread" in out
    cal = params_of(tmp_path / "tip.toml")
    assert cal.theta_offset_rad[:5] == Params().theta_offset_rad[:5]
    assert abs(cal.l_mm - truth.l_mm) < 0.01 and abs(cal.d_mm[5] - truth.d_mm[5]) < 0.01


def test_the_real_command(session: Path, tmp_path: Path) -> None:
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "aacmm.cli",
            "calibrate",
            str(session),
            "-o",
            str(tmp_path / "p.toml"),
            "--workspace",
            "0",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert r.returncode == 0, r.stderr
    assert "wrote" in r.stdout and (tmp_path / "p.toml").exists()


# --------------------------------------------------------------------------- bad data


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("aacmm calibrate: error:"), err
    return lines[0]


def test_empty_session(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    w = SessionWriter.create(tmp_path / "empty", load_plan("kinematic-calibration"))
    w.close("interrupted", "test")
    code, _, err = run([str(tmp_path / "empty"), "-o", str(tmp_path / "x.toml")], capsys)
    assert code == 2 and "no points" in _one_line(err)
    assert not (tmp_path / "x.toml").exists()


def test_one_cone_point(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    plan_session(tmp_path / "one", "kinematic-calibration", Params(), 105, 0.0, limit=1)
    code, _, err = run([str(tmp_path / "one"), "-o", str(tmp_path / "x.toml")], capsys)
    assert code == 2 and "cone1" in _one_line(err) and "at least 2" in err


def test_other_parameter_set_or_encoders(
    session: Path, truth: Params, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    other_kin = ParamSetRecord.from_device(
        ParamSetRecord(0, Params(l_mm=183.0), EncoderConfig()).to_device()
    )
    s2 = tmp_path / "s2"
    plan_session(s2, "kinematic-calibration", truth, 106, SIGMA, in_force=other_kin)
    code, _, err = run([str(session), str(s2), "-o", str(tmp_path / "x.toml")], capsys)
    assert code == 2 and "parameter set" in _one_line(err) and str(s2) in err
    enc = EncoderConfig(zero_offset_counts=(7, 0, 0, 0, 0, 0))
    other_enc = ParamSetRecord.from_device(ParamSetRecord(0, Params(), enc).to_device())
    s3 = tmp_path / "s3"
    plan_session(s3, "kinematic-calibration", truth, 107, SIGMA, in_force=other_enc, limit=60)
    code, _, err = run(
        [str(session), "-o", str(tmp_path / "x.toml"), "--validate", str(s3)], capsys
    )
    assert code == 2 and "encoder configuration" in _one_line(err)


def _tamper(folder: Path, row: int, column: str, value: str) -> None:
    path = folder / "points.csv"
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
        cols = list(rows[0])
    rows[row][column] = value
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, cols, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)


@pytest.mark.parametrize(
    "column, value, match",
    [
        ("count3", "nan", "not an integer"),
        ("step_id", "cone9", "do not match point 6 of the plan"),
        ("count1", "-5", "outside"),
        ("param_crc32", "0x12345678", "not listed"),
    ],
)
def test_damaged_session(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], column: str, value: str, match: str
) -> None:
    s = tmp_path / "bad"
    plan_session(s, "kinematic-calibration", Params(), 108, 0.0, limit=40)
    _tamper(s, 5, column, value)
    code, _, err = run([str(s), "-o", str(tmp_path / "x.toml")], capsys)
    assert code == 2
    line = _one_line(err)
    assert "points.csv:7" in line and match in line, line


def test_bad_arguments(session: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for args, needle in (
        (["--sigma-um", "0"], "--sigma-um"),
        (["--kfold", "1"], "--kfold"),
        (["--free", "theta9"], "unknown parameter"),
        (["--probe", "--fix", "d1"], "--probe"),
    ):
        code, _, err = run([str(session), "-o", str(tmp_path / "x.toml"), *args], capsys)
        assert code == 2 and needle in _one_line(err), (args, err)
    code, _, err = run([str(session), "-o", str(tmp_path / "x.json")], capsys)
    assert code == 2 and ".toml" in _one_line(err)
    assert math.isfinite(Model().point(np.zeros(6))[2])


def test_observations_from_a_plan_design() -> None:
    """A design (a plan and poses, no data): the same mapping as for a session."""
    from aacmm.calibration import predicted_covariance
    from aacmm.calibration.sessions import SessionDataError, observations_from_plan
    from calib_synth import random_poses, reach

    plan = load_plan("kinematic-calibration")
    rng = np.random.default_rng(7)
    targets = np.array([s.target.tip_mm for s in plan.slots if s.target is not None])
    q = reach(Model(), targets, random_poses(rng, len(targets), (0.3, 1.4), (0.6, 1.8)), rng, 0.5)
    obs, used, unused = observations_from_plan(plan, q, SIGMA)
    assert used == ["cone1", "cone2", "cone3", "bar500", "bar750", "bar1000"] and unused == []
    kinds = sorted(type(c).__name__ for c in obs.constraints)
    assert kinds == ["Cone"] * 3 + ["LengthSet"] * 3
    cov, ident = predicted_covariance(obs)
    assert ident.rank == 21 and set(ident.held) == {"theta1", "d1", "theta6", "alpha6"}
    assert 0.0005 < np.sqrt(np.diag(cov))[12:].max() < 0.01
    with pytest.raises(SessionDataError, match="a seat needs at least 2"):
        observations_from_plan(plan, q[:1])
