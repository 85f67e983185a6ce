"""Whole shipped plans through ``aacmm capture`` against the simulated operator
(``aacmm sim --scenario PLAN --truth random:SEED --fast``), the way a user runs them:
every press the operator made is a point of the session, in plan order, labelled
with the slot it was made for -- zero lost, zero mislabelled (issue 11) -- and each
step's articulations really differ: the spread of every joint angle per step, from
the session's own counts and encoder configuration (not the simulator's report). The
same capture over SocketCAN: tests/sim/vcan/test_capture_scenario_can.py."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from aacmm.plans import load_plan
from clihelp import capture_scenario, check_scenario_capture

pytestmark = pytest.mark.timeout(300)


#: Lower bounds (deg) on every joint's spread, rolls (joints 1, 3, 5) and hinges (2, 4,
#: 6), in the steps whose articulations must differ (docs/simulator.md, "Articulations"):
#: a cone seat is probed in articulations chosen as far apart as the seat allows (25
#: here), an articulated-location step from five clearly different articulations. The
#: measured spreads (docs/simulator.md) are at least twice these.
SPREAD_MIN_DEG = {"cone": (180.0, 60.0), "articulation": (120.0, 45.0)}


def joint_angles_deg(session: Path) -> tuple[list[str], np.ndarray]:
    """Per point of ``session/points.csv``: its step id and its six joint angles (deg),
    from the raw counts and the encoder configuration of the parameter set the row
    names in ``session.json`` (docs/kinematics.md, "Encoders"): the signed count
    ``(reading - zero) mod cpr`` taken into [-cpr/2, cpr/2), times the direction,
    times 360/cpr."""
    meta = json.loads((session / "session.json").read_text())
    encoders = {ps["param_crc32_hex"]: ps["encoders"] for ps in meta["param_sets"]}
    steps: list[str] = []
    angles: list[list[float]] = []
    with (session / "points.csv").open(newline="") as f:
        for row in csv.DictReader(f):
            enc = encoders[row["param_crc32"]]
            joint = []
            for j in range(6):
                cpr = int(enc["counts_per_rev"][j])
                delta = (int(row[f"count{j + 1}"]) - int(enc["zero_offset_counts"][j])) % cpr
                signed = delta if 2 * delta < cpr else delta - cpr
                joint.append(int(enc["direction"][j]) * signed * 360.0 / cpr)
            steps.append(row["step_id"])
            angles.append(joint)
    return steps, np.array(angles)


def spread_deg(angles: np.ndarray) -> float:
    """max - min of angles on the circle (deg): the shortest arc holding them all,
    so a roll that crosses +-180 deg is not counted as a whole turn."""
    a = np.sort(np.mod(angles, 360.0))
    if a.size < 2:
        return 0.0
    gaps = np.diff(np.append(a, a[0] + 360.0))
    return float(360.0 - gaps.max())


def check_step_spreads(session: Path, plan: str, report: dict[str, Any]) -> None:
    steps, angles = joint_angles_deg(session)
    by_id = {st.id: st for st in load_plan(plan).steps}
    for step_id in dict.fromkeys(steps):
        rows = [i for i, s in enumerate(steps) if s == step_id]
        spread = [spread_deg(angles[rows, j]) for j in range(6)]
        procedure = by_id[step_id].procedure
        text = ", ".join(f"{v:.0f}" for v in spread)
        print(f"measured: {plan} {step_id} ({procedure}, {len(rows)} points): "
              f"joint spread {text} deg")  # fmt: skip
        if procedure in SPREAD_MIN_DEG:
            roll_min, hinge_min = SPREAD_MIN_DEG[procedure]
            assert min(spread[0::2]) >= roll_min, (step_id, spread)
            assert min(spread[1::2]) >= hinge_min, (step_id, spread)
        # the operator's own figure (true angles): the same to the encoder's eccentricity
        # and noise, so the angles above really are the arm's
        assert np.allclose(spread, report["joint_spread_deg"][step_id], atol=0.05), step_id


@pytest.mark.parametrize(("plan", "seed"), [("iso10360-12", 7), ("kinematic-calibration", 8)])
def test_shipped_plan_end_to_end(tmp_path: Path, plan: str, seed: int) -> None:
    session, report, _ = capture_scenario(tmp_path, plan, f"random:{seed}")
    check_scenario_capture(session, plan, report)
    check_step_spreads(session, plan, report)
