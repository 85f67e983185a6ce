"""The CLI's file rules, end to end (issue 15 items 2, 3 and 9).

- Output files (15.9): every command refuses an existing output file unless
  ``--force`` (one line, exit status 2, the file untouched, nothing done),
  and writes atomically.
- Input files (15.2): a deeply nested TOML/JSON file ends in one line and
  exit status 2, never a traceback.
- ``--timeout`` (15.3): a value out of range ends in one line and exit status 2.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest
from aacmm.commands import exitcodes
from aacmm.commands.sim import SimProcess
from clihelp import one_error_line, run, sim_fixture

pytestmark = pytest.mark.timeout(120)
sim = sim_fixture("--seed", "5")

NOWHERE = "serial:///nonexistent/aacmm-port"


def no_temp_files(directory: Path) -> bool:
    return not [p for p in directory.iterdir() if p.name.endswith(".tmp")]


# ------------------------------------------------------------------ outputs (15.9)


def test_params_get_refuses_existing_output(sim: SimProcess, tmp_path: Path) -> None:
    out = tmp_path / "arm.toml"
    out.write_text("# mine\n")
    p = run("params", "get", "-o", str(out), "--port", sim.url)
    one_error_line(p, exitcodes.USAGE, str(out), "exists", "--force")
    assert out.read_text() == "# mine\n"
    # refused before the device is opened: a missing port would be status 3
    p = run("params", "get", "-o", str(out), "--port", NOWHERE)
    one_error_line(p, exitcodes.USAGE, "exists")
    p = run("params", "get", "-o", str(out), "--force", "--port", sim.url)
    assert p.returncode == 0, p.stderr
    assert "l_mm" in tomllib.loads(out.read_text())
    p = run("params", "get", "-o", str(tmp_path / "new.json"), "--port", sim.url)
    assert p.returncode == 0, p.stderr
    assert "l_mm" in json.loads((tmp_path / "new.json").read_text())
    assert no_temp_files(tmp_path)
    p = run("params", "get", "-o", str(tmp_path / "no" / "dir.toml"), "--port", sim.url)
    one_error_line(p, exitcodes.USAGE, "does not exist")


# ------------------------------------------------------------------ --timeout (15.3)


TIMEOUT_CASES = [(["info"], v) for v in ("inf", "1e10", "nan", "0", "-1", "3600.5")] + [
    (cmd, "inf") for cmd in (["measure"], ["params", "get"], ["params", "save"], ["log", "x.csv"])
]


@pytest.mark.parametrize(("command", "value"), TIMEOUT_CASES)
def test_timeout_out_of_range(
    sim: SimProcess, tmp_path: Path, command: list[str], value: str
) -> None:
    """inf and 1e10 ended in an OverflowError traceback (exit 1)."""
    p = run(*command, "--timeout", value, "--port", sim.url, cwd=tmp_path)
    one_error_line(p, exitcodes.USAGE, "--timeout must be in (0, 3600] seconds")
    assert list(tmp_path.iterdir()) == []  # the log wrote nothing


def test_timeout_at_the_maximum_works(sim: SimProcess) -> None:
    p = run("info", "--timeout", "3600", "--port", sim.url)
    assert p.returncode == 0, p.stderr
