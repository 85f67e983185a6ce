"""pytest set-up for the board tests: the host loopback suite's helpers
(tests/host: hostref, simproc, test_loopback_pty) are importable."""

from __future__ import annotations

import sys
from pathlib import Path

_HOST_TESTS = Path(__file__).resolve().parents[1] / "host"
if str(_HOST_TESTS) not in sys.path:
    sys.path.insert(0, str(_HOST_TESTS))
