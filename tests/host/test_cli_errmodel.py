"""``aacmm params set/get`` and ``aacmm info`` with an error model (issue 27), end to end.

The real ``aacmm`` command against the real pty simulator (its float build):
a parameter file with an ``[errmodel]`` table (K = 2 encoder harmonics on
every joint) is sent with ``--save``, read back equal (``params get``, ``info``),
the device's measured and computed points agree with the host's corrected
points (:func:`aacmm.errmodel.points` of the file's error model, double
precision) within the float path's class, and the set survives a restart of
the simulator on the same storage file; a log records the set with its error
model and recomputes the device's points. A file with thermal expansion is
refused by a device without link temperature sensors in one line, exit 2, and
nothing reaches the device.
"""

from __future__ import annotations

import json
import random
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w
from aacmm import core
from aacmm.commands import exitcodes
from aacmm.errmodel import ErrorModel, points
from aacmm.records.logs import read_log
from aacmm.records.paramfile import param_set_from_mapping
from aacmm.simulation.process import SimProcess
from test_cli import _sim_or_skip, one_error_line, run

pytestmark = pytest.mark.timeout(90)

FLOAT_PATH_BOUND_MM = 1e-3  # the float build's class (tests/host/test_loopback_errmodel.py)
K2 = ",".join(["2"] * 6)


def harmonics_table(seed: int) -> dict[str, Any]:
    """K = 2 on every joint, up to 0.4 mrad, whole multiples of the wire's 1e-7 rad."""
    rng = random.Random(seed)

    def row() -> list[float]:
        return [rng.randint(-4000, 4000) * 1e-7 for _ in range(2)]

    return {"c_rad": [row() for _ in range(6)], "s_rad": [row() for _ in range(6)]}


def error_model_of(table: dict[str, Any]) -> ErrorModel:
    return ErrorModel(
        tuple(
            tuple(zip(c, s, strict=True))
            for c, s in zip(table["c_rad"], table["s_rad"], strict=True)
        )
    )


def params_get(url: str) -> dict[str, Any]:
    p = run("params", "get", "--format", "json", "--port", url)
    assert p.returncode == 0, p.stderr
    data: dict[str, Any] = json.loads(p.stdout)
    return data


def check_points(url: str, data: dict[str, Any]) -> tuple[float, float]:
    """Worst |device - host| over MEASURE and COMPUTE points (mm), and how far the
    correction moves the point (mm): the host's corrected point against DH only."""
    ps = param_set_from_mapping({k: v for k, v in data.items() if k != "errmodel"}, "get")
    arm, enc = ps.to_arm()
    model = core.Model(arm)
    em = error_model_of(data["errmodel"])
    rng = random.Random(5)
    worst = moved = 0.0
    for i in range(8):
        if i < 3:
            p = run("measure", "--json", "--port", url)
        else:
            counts = [rng.randrange(c) for c in enc.counts_per_rev]
            p = run("compute", *map(str, counts), "--json", "--port", url)
        assert p.returncode == 0, p.stderr
        m = json.loads(p.stdout)
        theta = core.counts_to_angles(np.array([m["counts"]], dtype=np.int64), enc)
        want = points(model, em, theta)[0]
        worst = max(worst, float(np.max(np.abs(np.array(m["point_mm"]) - want))))
        moved = max(moved, float(np.max(np.abs(want - model.point(theta[0])))))
    return worst, moved


def test_params_set_sends_the_error_model_and_it_survives_a_restart(tmp_path: Path) -> None:
    _sim_or_skip()
    store = tmp_path / "arm.bin"
    table = harmonics_table(3)
    with SimProcess(["--serial", "pty", "--quiet", "--storage", str(store)]) as s:
        data = params_get(s.url)
        assert "errmodel" not in data  # the defaults: DH only
        assert "error model none (DH only)" in run("info", "--port", s.url).stdout
        crc0 = data.pop("param_crc32")
        data["errmodel"] = table
        pfile = tmp_path / "cal.toml"
        pfile.write_text(tomli_w.dumps(data))
        p = run("params", "set", str(pfile), "--check")
        assert p.returncode == 0 and f"error model: encoder harmonics K per joint {K2}" in p.stdout
        p = run("params", "set", str(pfile), "--save", "--port", s.url)
        assert p.returncode == 0, p.stderr
        assert "read back and identical" in p.stdout and "saved" in p.stdout
        assert f"encoder harmonics K per joint {K2}" in p.stdout
        got = params_get(s.url)
        assert got["errmodel"] == table  # exactly the file's coefficients
        assert got["param_crc32"] != crc0
        info = json.loads(run("info", "--json", "--port", s.url).stdout)
        assert info["error_model"]["harmonics"] == [2] * 6
        assert info["param_source_name"] == "storage"
        assert (
            f"error model encoder harmonics K per joint {K2}" in run("info", "--port", s.url).stdout
        )
        worst, moved = check_points(s.url, got)
        assert worst < FLOAT_PATH_BOUND_MM, worst
        assert moved > 0.05, moved  # the correction matters far beyond the class
        # a file written by `params get` round-trips through `params set`
        back = tmp_path / "back.toml"
        p = run("params", "get", "-o", str(back), "--port", s.url)
        assert p.returncode == 0 and f"K per joint {K2}" in p.stderr, p.stderr
        assert tomllib.loads(back.read_text())["errmodel"] == table
        p = run("params", "set", str(back), "--port", s.url)
        assert p.returncode == 0 and "identical to the stored set" in p.stdout, p.stderr
    # a restart on the same storage loads the saved set with its error model
    with SimProcess(["--serial", "pty", "--quiet", "--storage", str(store)]) as s:
        info = json.loads(run("info", "--json", "--port", s.url).stdout)
        assert info["param_source_name"] == "storage"
        assert info["error_model"]["harmonics"] == [2] * 6
        again = params_get(s.url)
        assert again == got
        worst, _ = check_points(s.url, again)
        assert worst < FLOAT_PATH_BOUND_MM, worst
        # a log records the set with its error model; its recomputed points are the device's
        log = tmp_path / "run.csv"
        p = run("log", str(log), "--port", s.url, "-r", "200", "-n", "40")
        assert p.returncode == 0, p.stderr
        meta = json.loads(log.with_name("run.csv.json").read_text())
        assert meta["param_sets"][0]["errmodel"] == table and meta["errmodel"] == table
        rec = read_log(log)
        device = np.column_stack([rec.column(f"{c}_mm") for c in "xyz"])
        ps = rec.param_set_of(0)
        assert ps.errors == error_model_of(table)
        assert np.max(np.abs(rec.points_mm() - device)) < FLOAT_PATH_BOUND_MM
        dh_only = core.Model(ps.model).points(rec.angles_rad())
        assert np.max(np.abs(dh_only - device)) > 0.05
        # a file without [errmodel] replaces the error model: DH only again
        plain = tmp_path / "plain.json"
        plain.write_text(json.dumps({k: v for k, v in again.items() if k != "errmodel"}))
        p = run("params", "set", str(plain), "--port", s.url)
        assert p.returncode == 0, p.stderr
        assert "errmodel" not in params_get(s.url)


def test_thermal_expansion_is_refused_before_anything_is_sent(tmp_path: Path) -> None:
    _sim_or_skip()
    with SimProcess(["--serial", "pty", "--quiet", "--no-temperature-sensors"]) as s:
        data = params_get(s.url)
        crc0 = data.pop("param_crc32")
        data["errmodel"] = {
            **harmonics_table(4),
            "cte_per_k": [2.3e-5] * 6,
            "tref_c": [20.0] * 6,
        }
        pfile = tmp_path / "thermal.json"
        pfile.write_text(json.dumps(data))
        p = run("params", "set", str(pfile), "--port", s.url)
        one_error_line(p, exitcodes.USAGE, "thermal", "nothing sent")
        p = run("params", "set", str(pfile), "--check")  # a valid file, not for the device
        assert p.returncode == exitcodes.OK, p.stderr
        assert "thermal expansion CTE per link 23e-6 /K" in p.stdout
        assert "only a device that reads its link temperatures takes it" in p.stdout
        assert params_get(s.url)["param_crc32"] == crc0  # the device's set is unchanged
        # coefficients the wire cannot carry (> 3.2767 mrad): one line, nothing sent
        data["errmodel"] = harmonics_table(4)
        data["errmodel"]["c_rad"][2] = [4e-3, 0.0]
        pfile.write_text(json.dumps(data))
        p = run("params", "set", str(pfile), "--port", s.url)
        one_error_line(p, exitcodes.USAGE, "joint 3 c_1", "nothing sent")
        assert params_get(s.url)["param_crc32"] == crc0
