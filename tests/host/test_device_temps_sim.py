"""Issue 27, item 2, end to end on the simulator: the device's link temperatures and
its thermal block.

A simulated aluminium arm (``random_truth(2)`` with an all-aluminium thermal profile,
tests/host/thermal_study.py, written as a truth file) is captured through the
``arm-verification`` plan by the simulated operator (``aacmm sim --truth FILE
--scenario PLAN --fast``) three times, its device holding the arm's 20 degC
calibration (the study's ``calibrated``):

- at 28 degC (``aacmm sim --temperature 28``: the operator's poses solved on the warm
  true arm, the device's sensors told 28 degC over the control channel) with the
  calibration and the data-sheet CTE (23e-6 /K on every link, not the truth's own
  22..24e-6) as its thermal block (``aacmm params set``): the device compensates;
- the same at 28 degC without the thermal block: uncompensated;
- at 20 degC (the simulator's default reading), without it: the isothermal arm.

``aacmm verify`` (no ``--params``) of each: the compensated |E_Uni| passes its MPE and
is at least 5x below the uncompensated one, which fails it far beyond the isothermal
arm's (the thermal study's findings, now through the device). The device's own points
(float, at its readings) agree with the host's recomputation (double) to 2 um; the
uncompensated session verified with ``--params`` of the thermal file is the
compensated figure exactly (the same counts: the operator did the same at 28 degC).

And a sensor that stops answering during a capture (``temps ... -`` on the control
channel) gives TEMP_FAULT samples without a point: capture refuses the press in one
line naming the link, and takes the next one.
"""

from __future__ import annotations

import json
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from clihelp import AACMM, capture_scenario, cli_env, run
from thermal_study import aluminium_truth, calibrated, compensation

pytestmark = pytest.mark.timeout(300)
SEED = 2
PLAN = "arm-verification"


def _e_uni(doc: dict[str, Any]) -> tuple[float, bool]:
    (res,) = [r for r in doc["results"] if r["key"] == "e_uni"]
    return abs(float(res["value_mm"])), res["verdict"] == "PASS"


def _verify(session: Path, *extra: str) -> dict[str, Any]:
    p = run("verify", str(session), "--json", "-", *extra)
    assert p.returncode in (0, 7), p.stderr
    out: dict[str, Any] = json.loads(p.stdout)
    return out


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """The truth file, and the calibration's parameter files with and without the
    data-sheet CTE."""
    from aacmm.records.paramfile import dump_param_set
    from gate_study import record

    folder = tmp_path_factory.mktemp("devtemps-sim")
    truth = aluminium_truth(SEED)
    truth_file = folder / "truth.toml"
    truth_file.write_text(truth.dumps())
    cal = record(calibrated(truth, 1000 + SEED)).to_device()
    plain = folder / "cal.toml"
    plain.write_text(dump_param_set(cal, "toml"))
    thermal = folder / "cal-thermal.toml"
    thermal.write_text(dump_param_set(cal, "toml", errmodel=compensation()))
    return truth_file, plain, thermal


def test_verify_with_device_compensation(tmp_path: Path, files: tuple[Path, Path, Path]) -> None:
    from aacmm.records import read_session

    truth, plain, thermal = files
    warm = ("--temperature", "28")
    comp, _, _ = capture_scenario(tmp_path / "comp", PLAN, str(truth), thermal, sim_extra=warm)
    raw, _, _ = capture_scenario(tmp_path / "raw", PLAN, str(truth), plain, sim_extra=warm)
    iso, _, _ = capture_scenario(tmp_path / "iso", PLAN, str(truth), plain)
    s = read_session(comp)
    n = len(s)
    assert s.device_temp_c is not None and np.all(s.device_temp_c == 28.0)
    assert s.param_set_of(0).thermal
    # the device's float points at its readings against the host's double recomputation
    dev_err = float(np.abs(s.points_mm() - s.device_points_mm).max())
    assert dev_err < 2e-3, dev_err
    doc = {k: _verify(p) for k, p in (("comp", comp), ("raw", raw), ("iso", iso))}
    e = {k: _e_uni(d) for k, d in doc.items()}
    ratios = (e["comp"][0] / e["iso"][0], e["raw"][0] / e["iso"][0], e["raw"][0] / e["comp"][0])
    print(
        f"\n|E_Uni| 28 degC device-compensated {e['comp'][0] * 1e3:.1f} um, uncompensated "
        f"{e['raw'][0] * 1e3:.1f} um, 20 degC {e['iso'][0] * 1e3:.1f} um; compensated / "
        f"isothermal {ratios[0]:.2f}, uncompensated / isothermal {ratios[1]:.1f}, "
        f"uncompensated / compensated {ratios[2]:.1f}; device vs host points {dev_err * 1e3:.2f} um"
    )
    assert doc["comp"]["session"]["temperature"] == (
        f"28 C (read by the device at {n} of {n} points; compensated by the thermal block "
        f"of the parameter set in force, {s.param_set_of(0).crc_hex})"
    )
    assert e["comp"][1] and not e["raw"][1] and e["iso"][1]
    assert e["raw"][0] > 0.15 and e["raw"][0] > 8.0 * e["iso"][0]
    assert e["comp"][0] < e["raw"][0] / 5.0
    # the same counts at 28 degC: the host's --params compensation is the device's
    r = read_session(raw)
    assert np.array_equal(r.counts, s.counts) and r.device_temp_c is not None
    host = _e_uni(_verify(raw, "--params", str(thermal)))[0]
    assert host == pytest.approx(e["comp"][0], abs=1e-9)


def test_capture_refuses_a_temp_fault_sample(
    tmp_path: Path, files: tuple[Path, Path, Path]
) -> None:
    from aacmm.records import read_session
    from aacmm.simulation.control import ControlChannel
    from aacmm.simulation.process import SimProcess

    _, _, thermal = files
    chan, fd = ControlChannel.pair()
    try:
        with SimProcess(["--serial", "pty", "--quiet", "--control", str(fd)], pass_fds=[fd]) as sim:
            chan.child_started()
            chan.hello()
            url = sim.urls[0]
            p = run("params", "set", str(thermal), "--port", url)
            assert p.returncode == 0, p.stderr
            chan.set_counts([0, 1 << 29, 1 << 30, 1 << 28, 1 << 31, 0])
            chan.sync()
            session = tmp_path / "s"
            args = ["capture", "probe-calibration", "-o", str(session), "--port", url]
            cap = subprocess.Popen(
                [str(AACMM), *args, "--no-keys", "--no-confirm-end", "-q"],
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                env=cli_env(),
            )
            try:
                assert chan.wait_stream(True, timeout=30), "capture never listened"
                chan.set_temperatures([28.0] * 5 + [None])  # link 6's sensor stops answering
                chan.sync()
                chan.press(0)
                chan.release(0)
                chan.set_temperatures([28.0] * 6)
                chan.sync()
                chan.press(0)
                chan.release(0)
                deadline = time.monotonic() + 10
                while time.monotonic() < deadline:
                    progress = session / "progress.json"
                    if progress.exists() and json.loads(progress.read_text())["points"] == 1:
                        break
                    time.sleep(0.05)
            finally:
                cap.send_signal(signal.SIGINT)
                out, err = cap.communicate(timeout=30)
    finally:
        chan.close()
    refused = [line for line in out.splitlines() if "no point" in line]
    assert len(refused) == 1, (out, err)
    assert (
        refused[0]
        .strip()
        .startswith(
            "no point: the temperature of link 6 was not read (TEMP_FAULT; the device compensates"
        )
    )
    assert "(flags 0x8" in refused[0] and refused[0].endswith("press again")
    s = read_session(session)
    assert len(s) == 1 and s.points[0].temp_c == (28.0,) * 6
    events = (session / "events.csv").read_text()
    assert "no point: the temperature of link 6 was not read" in events


def test_log_records_the_device_temperatures(tmp_path: Path) -> None:
    """``aacmm log`` of a simulator whose sensors read 21.5 degC on every link and one
    without sensors: the rows carry 21.50 on every link, and nothing."""
    from aacmm.records.logs import read_log
    from aacmm.simulation.process import SimProcess

    for opts, want in ((["--temperature", "21.5"], 21.5), (["--no-temperature-sensors"], None)):
        out = tmp_path / f"run{len(opts)}.csv"
        with SimProcess(["--serial", "pty", "--quiet", *opts]) as sim:
            p = run("log", str(out), "-r", "200", "-n", "50", "-q", "-p", sim.urls[0])
        assert p.returncode == 0, p.stderr
        t = read_log(out).temperatures_c()
        assert t is not None and t.shape == (50, 6)
        if want is None:
            assert np.isnan(t).all()
        else:
            assert np.all(t == want)


def test_a_temperature_profile_reaches_the_session(
    tmp_path: Path, files: tuple[Path, Path, Path]
) -> None:
    """``aacmm sim --temperature 20,21,22,23,24,25:30:0.02`` (a gradient along the arm
    warming to 30 degC over 1.2 s): the captured points carry rising device readings,
    each link's its own, all at one point in the profile (the same fraction of the
    way from each link's start to 30 degC, to the sensors' 0.01 degC)."""
    from aacmm.records import read_session

    truth, _, _ = files
    start = np.array([20.0, 21.0, 22.0, 23.0, 24.0, 25.0])
    ramp = ("--temperature", "20,21,22,23,24,25:30:0.02")
    session, _, _ = capture_scenario(tmp_path, "probe-calibration", str(truth), sim_extra=ramp)
    t = read_session(session).device_temp_c
    assert t is not None and t.shape[1] == 6
    assert np.all(np.diff(t, axis=0) >= 0) and np.all(t[-1] > t[0])  # every link warms
    assert np.all((start <= t) & (t <= 30.0))
    frac = (t - start) / (30.0 - start)
    assert np.all(np.abs(frac - frac[:, :1]) <= 0.01 / (30.0 - start[-1]) + 1e-12), frac
    assert np.all(np.diff(t, axis=1) >= 0)  # the gradient holds until every link is at 30
