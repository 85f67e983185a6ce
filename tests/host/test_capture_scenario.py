"""Whole shipped plans through ``aacmm capture`` against the simulated operator
(``aacmm sim --scenario PLAN --truth random:SEED --fast``), the way a user runs them:
every press the operator made is a point of the session, in plan order, labelled
with the slot it was made for -- zero lost, zero mislabelled (issue 11)."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any

import pytest
from aacmm.plans import load_plan
from aacmm.records import read_session
from clihelp import AACMM, cli_env

pytestmark = pytest.mark.timeout(300)


def run_plan(tmp_path: Path, plan: str, seed: int) -> tuple[Any, dict[str, Any]]:
    link = tmp_path / "arm"
    report = tmp_path / "report.json"
    sim = subprocess.Popen(
        [str(AACMM), "sim", "--scenario", plan, "--truth", f"random:{seed}", "--fast",
         "--link", str(link), "--report", str(report)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=cli_env(),
    )  # fmt: skip
    try:
        assert sim.stdout is not None
        url = sim.stdout.readline().strip()
        assert url == f"serial://{link}", sim.communicate(timeout=10)[1]
        cap = subprocess.run(
            [str(AACMM), "capture", plan, "-o", str(tmp_path / "s"), "--port", url, "-q"],
            capture_output=True, text=True, env=cli_env(), timeout=280,
        )  # fmt: skip
        if cap.returncode != 0:
            sim.kill()
            raise AssertionError(cap.stderr + sim.communicate()[1])
        _, err = sim.communicate(timeout=60)
        assert sim.returncode == 0, err
    finally:
        if sim.poll() is None:
            sim.kill()
            sim.communicate()
    return read_session(tmp_path / "s"), json.loads(report.read_text())


@pytest.mark.parametrize(("plan", "seed"), [("iso10360-12", 7), ("kinematic-calibration", 8)])
def test_shipped_plan_end_to_end(tmp_path: Path, plan: str, seed: int) -> None:
    session, report = run_plan(tmp_path, plan, seed)
    slots = load_plan(plan).slots
    assert session.status == "complete" and len(session.points) == len(slots)
    presses = [p for p in report["presses"] if p["button"] == 0]
    # zero lost: one press per slot, and each became the point of its slot
    assert [p["slot"] for p in presses] == list(range(len(slots)))
    for k, (pt, press) in enumerate(zip(session.points, presses, strict=True)):
        assert (pt.slot, pt.step_id, pt.point_index) == (
            k,
            slots[k].step_id,
            slots[k].point_index,
        )
        assert pt.position_index == slots[k].position_index and pt.end == slots[k].end
        assert tuple(pt.counts) == tuple(press["counts"]), f"slot {k} mislabelled"
    # nothing ignored, nothing undone
    events = (tmp_path / "s" / "events.csv").read_text()
    assert ",ignored," not in events and ",undo," not in events
