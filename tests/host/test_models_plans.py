"""The plans of an arm model (its ``[plans]`` table, issue 26).

Every shipped model names a calibration and a verification plan that its nominal
arm reaches within its joint limits (``check_reach``, whose solutions are checked
against an independent forward kinematics in tests/host/test_plan_reach.py); the
paper's arm and a model without the table keep today's plans; ``aacmm model show``
lists them (text and JSON, against the model file read here with tomllib); the
table is validated (one line, FILE:LINE) and survives ``dumps_model``.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from aacmm.commands import exitcodes
from aacmm.models import (
    DEFAULT_CALIBRATION_PLAN,
    DEFAULT_VERIFICATION_PLAN,
    ModelError,
    dumps_model,
    load_model,
    loads_model,
    shipped_model_path,
    shipped_models,
)
from aacmm.plans import load_plan, shipped_plans
from aacmm.simulation.reach import check_reach

AACMM = Path(sys.executable).with_name("aacmm")


def _file_plans(name: str) -> tuple[str, str]:
    """The plans the model file itself names (tomllib), today's plans without a table."""
    data = tomllib.loads(shipped_model_path(name).read_text(encoding="utf-8"))
    table = data.get("plans", {})
    return (
        table.get("calibration", "kinematic-calibration"),
        table.get("verification", "arm-verification"),
    )


@pytest.mark.parametrize("name", sorted(shipped_models()))
def test_each_shipped_model_reaches_its_own_plans(name: str) -> None:
    model = load_model(name)
    assert (model.calibration_plan, model.verification_plan) == _file_plans(name)
    for spec in (model.calibration_plan, model.verification_plan):
        assert spec in shipped_plans()
        report = check_reach(load_plan(spec), model)
        assert report.items and report.unchecked == ()
        assert report.ok, [f"{i.number}: {i.label}: {i.reason}" for i in report.unreachable]


def test_the_paper_arm_keeps_todays_plans_and_small_arms_get_the_compact_ones() -> None:
    assert DEFAULT_CALIBRATION_PLAN == "kinematic-calibration"
    assert DEFAULT_VERIFICATION_PLAN == "arm-verification"
    paper = load_model("gao2013")
    assert (paper.calibration_plan, paper.verification_plan) == (
        "kinematic-calibration",
        "arm-verification",
    )
    assert "plans" not in tomllib.loads(shipped_model_path("gao2013").read_text())
    assert load_model("microscribe5").calibration_plan == "kinematic-calibration-compact"
    assert load_model("desk4").verification_plan == "arm-verification-compact4"
    # the paper's plans are out of the small arms' reach: that is why they have others
    for name in ("desk4", "microscribe5"):
        bad = check_reach(load_plan("kinematic-calibration"), load_model(name), tries=4)
        assert len(bad.unreachable) > len(bad.items) // 2


def _model_text(table: str) -> str:
    text = shipped_model_path("gao2013").read_text(encoding="utf-8")
    return text + "\n" + table


def test_the_plans_table_is_read_validated_and_written_back() -> None:
    m = loads_model(
        _model_text('[plans]\ncalibration = "kinematic-calibration-compact"\n'), "m.toml"
    )
    assert m.calibration_plan == "kinematic-calibration-compact"
    assert m.verification_plan == DEFAULT_VERIFICATION_PLAN  # each key optional
    m2 = loads_model(_model_text('[plans]\nverification = "plans/mine.toml"\n'), "m.toml")
    assert m2.verification_plan == "plans/mine.toml"  # a plan file, not checked here
    for mm in (m, m2, load_model("desk4")):
        back = loads_model(dumps_model(mm), "back")
        assert dataclasses.replace(back, file=mm.file) == mm
    assert "[plans]" not in dumps_model(load_model("gao2013"))
    lines = _model_text("").count("\n")
    cases = [
        (
            '[plans]\ncalibration = "no-such-plan"\n',
            lines + 2,
            "plans.calibration",
            "no shipped plan",
        ),
        ("[plans]\nverification = 3\n", lines + 2, "plans.verification", "must be a string"),
        ('[plans]\ncalib = "x"\n', lines + 2, "plans.calib", "unknown"),
    ]
    for table, line, field, words in cases:
        with pytest.raises(ModelError) as e:
            loads_model(_model_text(table), "m.toml")
        msg = str(e.value)
        assert len(msg.splitlines()) == 1
        assert msg.startswith(f"m.toml:{line}: {field}"), msg
        assert words in msg, msg
    # a top-level key comes before the tables
    top = 'plans = "kinematic-calibration"\n' + shipped_model_path("gao2013").read_text()
    for table, line, field, words in [(top, 1, "plans", "must be a table")]:
        with pytest.raises(ModelError) as e:
            loads_model(table, "m.toml")
        msg = str(e.value)
        assert len(msg.splitlines()) == 1
        assert msg.startswith(f"m.toml:{line}: {field}"), msg
        assert words in msg, msg


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(AACMM), *args], capture_output=True, text=True, timeout=60, check=False
    )


@pytest.mark.parametrize("name", ["gao2013", "desk4", "mpe2018"])
def test_model_show_lists_the_plans(name: str) -> None:
    cal, ver = _file_plans(name)
    r = _run("model", "show", name)
    assert r.returncode == exitcodes.OK, r.stderr
    assert f"plans: calibration {cal}, verification {ver}" in r.stdout.splitlines()
    r = _run("model", "show", name, "--json")
    assert r.returncode == exitcodes.OK, r.stderr
    assert json.loads(r.stdout)["plans"] == {"calibration": cal, "verification": ver}
