"""Whole shipped plans through ``aacmm capture`` against the simulated operator
(``aacmm sim --scenario PLAN --truth random:SEED --fast``), the way a user runs them:
every press the operator made is a point of the session, in plan order, labelled
with the slot it was made for -- zero lost, zero mislabelled (issue 11)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from aacmm.plans import load_plan
from aacmm.records import read_session
from clihelp import capture_scenario

pytestmark = pytest.mark.timeout(300)


def run_plan(tmp_path: Path, plan: str, seed: int) -> tuple[Any, dict[str, Any]]:
    session, report, _ = capture_scenario(tmp_path, plan, f"random:{seed}")
    return read_session(session), report


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
