"""Issue 27, item 2 (host side): the device's link temperatures in sessions, and what
verify and calibrate make of them.

- a session's points carry the device's link temperatures (``temp1_c .. tempN_c``,
  empty for a link without a reading); a session written before them (no columns)
  reads as before, and a resumed one keeps its columns;
- ``aacmm verify --params`` on a session whose samples read 28 degC on every link
  (nothing stated) gives the thermal study's compensated figure (the same as the
  session stated at 28 degC, tests/host/test_thermal_verify.py), and reports the range
  it read; readings that differ from a stated ``capture --temperature`` by more than
  1 degC win, with one warning; a thermal model and a point without readings nor a
  statement is refused in one line;
- a session taken with the data-sheet CTE in the device's parameter set (its thermal
  block): ``aacmm verify`` without ``--params`` recomputes each point at its readings,
  the study's compensated figure;
- calibrate's per-pose temperature is the mean of the device's link readings; ``aacmm
  calibrate`` estimates the link CTEs from sessions read at 15 and 25 degC as from the
  same sessions stated at capture.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
from aacmm.core import EncoderConfig, Params
from aacmm.protocol import Sample
from thermal_study import CASES, aluminium_truth, calibrated, compensation, run, sessions

T_WARM_C = 28.0


def _e_uni(out: str) -> float:
    doc = json.loads(out)
    (res,) = [r for r in doc["results"] if r["key"] == "e_uni"]
    return abs(float(res["value_mm"]))


@pytest.fixture(scope="module")
def warm(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, float]:
    """Arm 2 of the thermal study at 28 degC, with its 20 degC calibration in force,
    written three ways: read by the device (2800 on every link), read and stated at
    20 degC (a wrong statement), read with link 3 missing, and read at 20 .. 30 degC
    along the arm with link 4 missing; the parameter file with
    the data-sheet CTE; the study's compensated |E_Uni|."""
    from aacmm.plans import load_plan
    from aacmm.records.paramfile import dump_param_set
    from gate_study import Sampled, record, write_session

    seed = 2
    truth = aluminium_truth(seed)
    cal = calibrated(truth, 1000 + seed)
    plan = load_plan("arm-verification")
    counts = sessions(plan, truth, 2000 + seed, (20.0, T_WARM_C))[T_WARM_C].counts
    folder = tmp_path_factory.mktemp("devtemps")
    in_force = record(cal)
    read = (2800,) * 6
    write_session(folder / "read", Sampled(plan, counts, in_force), serial=7, temp=read)
    write_session(
        folder / "read-stated20",
        Sampled(plan, counts, in_force),
        serial=7,
        temp=read,
        temperature_c=20.0,
    )
    missing = (2800, 2800, -32768, 2800, 2800, 2800)
    write_session(folder / "missing", Sampled(plan, counts, in_force), serial=7, temp=missing)
    graded = (2000, 2200, 2400, -32768, 2800, 3000)
    write_session(folder / "graded", Sampled(plan, counts, in_force), serial=7, temp=graded)
    params = folder / "cal.toml"
    params.write_text(dump_param_set(in_force.to_device(), "toml", errmodel=compensation()))
    return folder, params, run(seed).e_uni[CASES[2]]


def test_session_columns_round_trip(warm: tuple[Path, Path, float]) -> None:
    from aacmm.records import read_session

    folder, _, _ = warm
    s = read_session(folder / "read")
    header = (folder / "read" / "points.csv").read_text().splitlines()[0].split(",")
    assert header[header.index("count6") + 1 : header.index("x_mm")] == [
        f"temp{i}_c" for i in range(1, 7)
    ]
    assert s.device_temp_c is not None and s.device_temp_c.shape == (len(s), 6)
    assert np.all(s.device_temp_c == 28.0) and s.points[0].temp_c == (28.0,) * 6
    m = read_session(folder / "missing")
    assert m.points[0].temp_c == (28.0, 28.0, None, 28.0, 28.0, 28.0)
    assert m.device_temp_c is not None and np.isnan(m.device_temp_c[:, 2]).all()


def test_session_without_temperature_columns(tmp_path: Path) -> None:
    """A session written before device temperatures: read, and resumed with its columns."""
    from aacmm.plans import load_plan
    from aacmm.records import ParamSetRecord, SessionWriter, read_session
    from aacmm.records.session_format import point_columns

    plan = load_plan("probe-calibration")
    ps = ParamSetRecord.from_device(ParamSetRecord(0, Params(), EncoderConfig()).to_device())
    folder = tmp_path / "old"
    w = SessionWriter.create(folder, plan)
    w.begin_run("capture")
    w.set_param_set(ps)
    w.record(Sample(1, 1000, (1, 2, 3, 4, 5, 6), (0, 0, 0), 1, temp=(2000,) * 6), time.time())
    w.close("interrupted")
    # rewrite it as an old session: no temperature columns anywhere
    old_cols = point_columns(6, temps=False)
    lines = (folder / "points.csv").read_text().splitlines()
    row = lines[1].split(",")
    new_cols = lines[0].split(",")
    keep = [new_cols.index(c) for c in old_cols]
    (folder / "points.csv").write_text(
        ",".join(old_cols) + "\n" + ",".join(row[k] for k in keep) + "\n"
    )
    (folder / "events.csv").unlink()
    meta = json.loads((folder / "session.json").read_text())
    meta["columns"] = list(old_cols)
    (folder / "session.json").write_text(json.dumps(meta))
    s = read_session(folder)
    assert s.device_temp_c is None and s.points[0].temp_c is None
    w = SessionWriter.resume(folder, plan)
    assert not w.temps
    w.begin_run("resume")
    w.set_param_set(ps)
    w.record(Sample(2, 2000, (1, 2, 3, 4, 5, 6), (0, 0, 0), 1, temp=(2000,) * 6), time.time())
    w.close("interrupted")
    s = read_session(folder)
    assert len(s) == 2 and s.device_temp_c is None
    assert (folder / "points.csv").read_text().splitlines()[0] == ",".join(old_cols)


def test_verify_with_device_temperatures(
    warm: tuple[Path, Path, float], capsys: pytest.CaptureFixture[str]
) -> None:
    from aacmm.cli import main

    folder, params, expected = warm
    # read by the device, nothing stated: the study's compensated figure
    assert main(["verify", str(folder / "read"), "--params", str(params), "--json", "-"]) == 0
    out, err = capsys.readouterr()
    doc = json.loads(out)
    assert _e_uni(out) == pytest.approx(expected, abs=1e-9)
    n = doc["session"]["points"].split()[0]
    assert doc["session"]["temperature"] == f"28 C (read by the device at {n} of {n} points)"
    assert doc["session"]["temperature_range_c"] == [28.0, 28.0] and not err
    # without --params: reported, not compensated
    assert main(["verify", str(folder / "read")]) == 7
    out = capsys.readouterr().out
    assert f"28 C (read by the device at {n} of {n} points; not compensated: no --params" in out
    # readings win over a wrong statement, with one warning
    args = ["verify", str(folder / "read-stated20"), "--params", str(params), "--json", "-"]
    assert main(args) == 0
    out, err = capsys.readouterr()
    assert _e_uni(out) == pytest.approx(expected, abs=1e-9)
    (line,) = err.splitlines()
    assert "warning: the device's link temperatures differ from the stated ones" in line
    assert "by up to 8.0 C" in line and "the device's readings are used" in line
    # and over verify --temperature
    args = ["verify", str(folder / "read"), "--params", str(params), "--temperature", "20"]
    assert main([*args, "--json", "-"]) == 0
    out, err = capsys.readouterr()
    assert _e_uni(out) == pytest.approx(expected, abs=1e-9)
    assert "(--temperature) by up to 8.0 C" in err
    # a link without a reading, nothing stated: refused in one line
    code = main(["verify", str(folder / "missing"), "--params", str(params)])
    out, err = capsys.readouterr()
    assert code == 2 and not out and len(err.splitlines()) == 1
    assert "point 1 has a link whose temperature the device did not read" in err
    # ... unless stated: --temperature fills the missing link
    args = ["verify", str(folder / "missing"), "--params", str(params), "--temperature", "28"]
    assert main([*args, "--json", "-"]) == 0
    out, _ = capsys.readouterr()
    assert _e_uni(out) == pytest.approx(expected, abs=1e-9)


def test_per_point_temperatures() -> None:
    from aacmm.records.measured import per_point_temperatures

    nan = np.nan
    dev = np.array([[21.0, 21.0, 23.0], [nan, nan, nan], [30.0, nan, 30.0]])
    temps, full, warning = per_point_temperatures([21.5, 22.0, None], dev, 3)
    assert full == 1
    np.testing.assert_array_equal(temps[0], [21.0, 21.0, 23.0])
    np.testing.assert_array_equal(temps[1], [22.0, 22.0, 22.0])
    assert temps[2, 0] == 30.0 and np.isnan(temps[2, 1])
    assert warning is not None and "by up to 1.5 C at 1 of 3 points (first: point 1" in warning
    _, _, quiet = per_point_temperatures([21.5, 22.0, None], dev[:, :2], 2)
    assert quiet is None  # within 1 degC: no warning


def test_calibration_takes_each_links_reading(warm: tuple[Path, Path, float]) -> None:
    """Each link at the device's reading of it; a link whose sensor did not answer at
    the mean of the point's other links (nothing stated)."""
    from aacmm.calibration.sessions import (
        link_temperature_warning,
        load_sessions,
        stated_link_temperatures,
    )
    from aacmm.records import read_session

    folder, _, _ = warm
    s = read_session(folder / "missing")
    t = stated_link_temperatures(s)
    assert t is not None and t.shape == (len(s), 6) and np.all(t == 28.0)  # five read
    g = stated_link_temperatures(read_session(folder / "graded"))
    assert g is not None
    np.testing.assert_allclose(g, np.broadcast_to([20.0, 22.0, 24.0, 24.8, 28.0, 30.0], g.shape))
    assert link_temperature_warning(s) is None
    assert link_temperature_warning(read_session(folder / "read-stated20")) is not None
    data = load_sessions([folder / "read-stated20"], 0.005, temperatures=True)
    assert data.observations.temp_c is not None and np.all(data.observations.temp_c == 28.0)
    assert len(data.temperature_warnings) == 1 and not data.unstated_temperature


def test_verify_with_the_device_thermal_block(
    warm: tuple[Path, Path, float], capsys: pytest.CaptureFixture[str]
) -> None:
    """The session taken with the data-sheet CTEs in the device's parameter set (its
    thermal block, applied by the device at its readings): verify without --params
    recomputes each point at its own link temperatures, the study's compensated figure."""
    from aacmm.cli import main
    from aacmm.plans import load_plan
    from aacmm.protocol.errwire import with_error_model
    from aacmm.records import ParamSetRecord, read_session
    from gate_study import Sampled, write_session

    folder, _, expected = warm
    cal_set = read_session(folder / "read").param_set_of(0)
    thermal = ParamSetRecord.from_device(with_error_model(cal_set.to_device(), compensation()))
    assert thermal.thermal and thermal.crc32 != cal_set.crc32
    plan = load_plan("arm-verification")
    counts = np.asarray(read_session(folder / "read").counts, dtype=np.int64)
    s = write_session(
        folder / "device-comp", Sampled(plan, counts, thermal), serial=7, temp=(2800,) * 6
    )
    assert read_session(s).param_set_of(0).thermal  # the sidecar keeps the thermal block
    assert main(["verify", str(s), "--json", "-"]) == 0
    out = capsys.readouterr().out
    assert _e_uni(out) == pytest.approx(expected, abs=1e-9)
    assert "compensated by the thermal block of the parameter set in force" in out


def test_calibrate_thermal_from_device_readings(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two kinematic-calibration sessions of aluminium arm 3 at 15 and 25 degC whose
    samples carry the device's readings (nothing stated): ``aacmm calibrate`` (--thermal
    auto) estimates the link CTEs, the same as from the same sessions with the
    temperatures stated at capture instead (tests/host/test_calibration_thermal.py)."""
    from aacmm.cli import main
    from aacmm.plans import load_plan
    from aacmm.records.paramfile import load_param_file_errmodel
    from gate_study import Sampled, record, write_session

    truth = aluminium_truth(3)
    plan = load_plan("kinematic-calibration")
    files: dict[str, list[str]] = {"read": [], "stated": []}
    for k, t in enumerate((15.0, 25.0)):
        counts = sessions(plan, truth, 1003 + 100 * k, (t,))[t].counts
        sampled = Sampled(plan, counts, record(Params()))
        read = write_session(tmp_path / f"read{k}", sampled, 7, temp=(round(t * 100),) * 6)
        stated = write_session(tmp_path / f"stated{k}", sampled, 7, temperature_c=t)
        files["read"].append(str(read))
        files["stated"].append(str(stated))
    cte = {}
    for kind, paths in files.items():
        out = tmp_path / f"cal-{kind}.toml"
        assert main(["calibrate", *paths, "-o", str(out), "-q"]) == 0
        text = capsys.readouterr().out
        assert "link CTEs estimated from link temperatures spanning 10.0 degC" in text
        cte[kind] = load_param_file_errmodel(out)[2].cte_per_k
    assert cte["read"] == pytest.approx(cte["stated"], rel=1e-12, abs=1e-15)
    assert all(20e-6 < a < 26e-6 for a in cte["read"][1:])  # aluminium (link 1: held)
