"""Helpers shared by the CLI tests of the host suites: run the installed
``aacmm`` command, check a one-line error, and a simulator fixture."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from aacmm.errors import AacmmError
from aacmm.simulation.process import SimProcess, find_simulator

AACMM = Path(sys.executable).with_name("aacmm")


def cli_env() -> dict[str, str]:
    """The environment without ``$AACMM_PORT`` (each test names its port)."""
    return {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}


def run(
    *args: str, timeout: float = 60, cwd: Path | None = None
) -> subprocess.CompletedProcess[str]:
    """Run ``aacmm ARGS`` to the end; output captured as text."""
    return subprocess.run(
        [str(AACMM), *args], capture_output=True, text=True, timeout=timeout, env=cli_env(), cwd=cwd
    )


def one_error_line(p: subprocess.CompletedProcess[str], code: int, *words: str) -> str:
    """Exit status ``code`` and exactly one line on stderr naming ``words``."""
    assert p.returncode == code, (p.returncode, p.stdout, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    assert lines[0].startswith("aacmm "), lines
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])
    return lines[0]


def read_only_dir(tmp_path: Path) -> tuple[Path, list[str]]:
    """A folder that takes no new file, and the command prefix under which it is so:
    as root (who ignores permission bits) a read-only tmpfs mounted on it in a mount
    namespace of the command's own (``unshare -m``: nothing changes outside it); else
    a folder without write permission and no prefix. The folder is empty."""
    ro = tmp_path / "ro"
    ro.mkdir()
    if os.geteuid() != 0:
        ro.chmod(0o555)
        return ro, []
    wrap = ["unshare", "-m", "sh", "-c", 'mount -t tmpfs -o ro tmpfs "$0" && exec "$@"', str(ro)]
    return ro, wrap


def capture_scenario(
    folder: Path,
    plan: str | Path,
    truth: str,
    params: Path | None = None,
    timeout: float = 280,
    can: tuple[str, int] | None = None,
    extra: tuple[str, ...] = (),
    sim_extra: tuple[str, ...] = (),
) -> tuple[Path, dict[str, Any], Path]:
    """A plan captured from the simulated operator, the way a user runs it:
    ``aacmm sim --scenario PLAN --truth TRUTH --fast`` and ``aacmm capture PLAN``
    into ``folder/s``; ``params``: a parameter file loaded into the device first;
    ``extra``: more options of ``aacmm capture``, ``sim_extra`` of ``aacmm sim``.
    The link is a pty (``serial://folder/arm``), or with ``can=(IFACE, NODE)``
    SocketCAN (``aacmm sim --can IFACE --node NODE``, ``socketcan://IFACE?node=NODE``).

    Returns the session folder, the simulator's report and the truth file it used;
    capture's stderr is in ``folder/capture.stderr``.
    """
    import json
    import subprocess

    folder.mkdir(exist_ok=True)
    link, report, truth_out = folder / "arm", folder / "sim.json", folder / "truth.toml"
    session = folder / "s"
    if can is None:
        link_args, want_url = ["--link", str(link)], f"serial://{link}"
    else:
        link_args = ["--can", can[0], "--node", str(can[1])]
        want_url = f"socketcan://{can[0]}?node={can[1]}"
    sim = subprocess.Popen(
        [str(AACMM), "sim", "--scenario", str(plan), "--truth", truth, "--fast",
         "--truth-out", str(truth_out), *link_args, "--report", str(report), *sim_extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=cli_env(),
    )  # fmt: skip
    try:
        assert sim.stdout is not None
        url = sim.stdout.readline().strip()
        assert url == want_url, sim.communicate(timeout=10)[1]
        if params is not None:
            p = run("params", "set", str(params), "--port", url)
            assert p.returncode == 0, p.stderr
        cap = run(
            "capture", str(plan), "-o", str(session), "--port", url, "-q", *extra, timeout=timeout
        )
        (folder / "capture.stderr").write_text(cap.stderr, encoding="utf-8")
        if cap.returncode != 0:
            sim.kill()
            raise AssertionError(cap.stderr + sim.communicate()[1])
        _, err = sim.communicate(timeout=60)
        assert sim.returncode == 0, err
    finally:
        if sim.poll() is None:
            sim.kill()
            sim.communicate()
    return session, json.loads(report.read_text()), truth_out


def check_scenario_capture(session_dir: Path, plan: str | Path, report: dict[str, Any]) -> None:
    """What a plan captured from the simulated operator must be (issue 11): the
    session complete, one point per slot in plan order, each labelled with its
    slot and holding the counts of the operator's press for that slot (zero lost,
    zero mislabelled), the press made at the slot's target, and no press ignored
    or undone (``events.csv``)."""
    import csv

    import numpy as np
    from aacmm.plans import load_plan
    from aacmm.records import read_session

    session = read_session(session_dir)
    want = load_plan(plan)
    slots = want.slots
    assert report["plan_sha256"] == want.sha256 == session.plan.sha256
    assert session.status == "complete" and len(session.points) == len(slots)
    assert report["points"] == len(slots)
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
        target = slots[k].target
        assert target is not None
        np.testing.assert_allclose(press["target_mm"], target.tip_mm, atol=1e-9)
    # nothing ignored, nothing undone: the journal holds one point event per slot
    with (session_dir / "events.csv").open(newline="") as f:
        events = [row["event"] for row in csv.DictReader(f)]
    assert "ignored" not in events and "undo" not in events, events
    assert events.count("point") == len(slots)


def sim_fixture(*args: str) -> Any:
    """A module-scoped ``sim`` fixture: one simulator on a pty (``make sim``
    builds it), with extra simulator options ``args``. Use in a test module as
    ``sim = sim_fixture()``."""

    @pytest.fixture(scope="module", name="sim")
    def _sim() -> Iterator[SimProcess]:
        try:
            find_simulator()
        except AacmmError as exc:
            pytest.fail(f"{exc} (the suite's make target builds it)")
        with SimProcess(["--serial", "pty", "--quiet", *args]) as s:
            yield s

    return _sim
