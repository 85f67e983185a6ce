"""Guided capture over CAN (issue 11: "from a real or simulated arm"; a real arm
may well be on CAN), in the shared vcan session.

``aacmm sim --can IFACE --node N --scenario probe-calibration --truth random:SEED
--fast`` performs the plan while ``aacmm capture ... --port
socketcan://IFACE?node=N`` records it, the way a user runs them. The same checks
as over the serial link (tests/host/test_capture_scenario.py, the shared
``clihelp.check_scenario_capture``): the session complete, every press the point
of its slot (zero lost, zero mislabelled), nothing ignored or undone. Over CAN
also: the session names the SocketCAN link, and the device's own points (sample
frames at 0.1 um, docs/protocol.md) agree with the points recomputed from the
counts in double precision with the set in force, to the float build's accuracy.
Outside the runner (no vcan0) the test skips; inside it a missing interface fails.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from aacmm.records import read_session
from clihelp import capture_scenario, check_scenario_capture

NODE = 9
PLAN = "probe-calibration"
# float32 kinematics on the device (docs/simulator.md) plus the CAN point frames' 0.1 um step
DEVICE_POINT_TOL_MM = 1e-3 + 0.5e-4
pytestmark = pytest.mark.timeout(240)


def test_capture_over_can_labels_every_press(vcan_iface: str, tmp_path: Path) -> None:
    session_dir, report, _ = capture_scenario(
        tmp_path, PLAN, "random:5", timeout=200, can=(vcan_iface, NODE)
    )
    check_scenario_capture(session_dir, PLAN, report)
    session = read_session(session_dir)
    assert session.meta["port"] == f"socketcan://{vcan_iface}?node={NODE}"
    assert "socketcan" in str(session.meta["transport"]).lower(), session.meta["transport"]
    recomputed = session.points_mm()  # counts -> double core, with the set in force per row
    assert np.abs(session.device_points_mm - recomputed).max() <= DEVICE_POINT_TOL_MM
