"""The vcan session's ``vcan_iface`` fixture (tests/vcan/conftest.py), reused here."""

from __future__ import annotations

import importlib.util
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "aacmm_vcan_conftest", Path(__file__).resolve().parents[2] / "vcan" / "conftest.py"
)
assert _spec is not None and _spec.loader is not None
_shared = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_shared)
vcan_iface = _shared.vcan_iface
