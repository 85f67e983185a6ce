"""The vcan session's ``vcan_iface`` fixture (tests/vcan/conftest.py), reused here;
the simulation tests' helpers (tests/sim/simctl.py) and the CLI tests' helpers
(tests/host/clihelp.py) importable."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/sim: simctl
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host"))  # clihelp

_spec = importlib.util.spec_from_file_location(
    "aacmm_vcan_conftest", Path(__file__).resolve().parents[2] / "vcan" / "conftest.py"
)
assert _spec is not None and _spec.loader is not None
_shared = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_shared)
vcan_iface = _shared.vcan_iface
