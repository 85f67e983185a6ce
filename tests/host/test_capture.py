"""``aacmm capture`` against the real simulator over a pty: a full plan, kill -9 and
--resume, undo, Ctrl-C, a parameter change between runs, bad input."""

from __future__ import annotations

import os
import pty
import signal
import subprocess
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
from aacmm.plans import load_plan
from aacmm.records import read_session
from aacmm.simulation.process import SimProcess
from clihelp import AACMM, cli_env, one_error_line, read_only_dir, run

pytestmark = pytest.mark.timeout(120)

PLAN = "probe-calibration"  # 30 cone points


@pytest.fixture(name="sim")
def _sim() -> Iterator[SimProcess]:
    """A fresh simulator pressing the button every 0.1 s (each test its own device)."""
    with SimProcess(["--serial", "pty", "--quiet", "--button-every", "0.1"]) as s:
        yield s


class Capture:
    """``aacmm capture`` as a subprocess, its stdout collected line by line."""

    def __init__(self, *args: str, stdin: int | None = None) -> None:
        self.proc = subprocess.Popen(
            [str(AACMM), "capture", *args],
            stdin=stdin if stdin is not None else subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=cli_env(),
        )
        self.lines: list[str] = []
        self.err: list[str] = []
        self._cond = threading.Condition()
        self._eof = False
        self._threads = [
            threading.Thread(target=self._read, daemon=True),
            threading.Thread(target=self._read_err, daemon=True),
        ]
        for t in self._threads:
            t.start()

    def _read_err(self) -> None:
        assert self.proc.stderr is not None
        self.err.extend(self.proc.stderr)

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            with self._cond:
                self.lines.append(line.rstrip("\n"))
                self._cond.notify_all()
        with self._cond:
            self._eof = True
            self._cond.notify_all()

    def wait_for(self, text: str, timeout: float = 30.0) -> None:
        """Wait for a line containing ``text``."""
        self.wait_until(lambda: self.has(text), timeout, text)

    def wait_until(self, pred: Callable[[], bool], timeout: float = 30.0, what: str = "") -> None:
        """Wait until ``pred()`` (checked whenever a line comes) holds; fail at once
        when capture has ended without it."""
        end = time.monotonic() + timeout
        with self._cond:
            while not pred():
                left = end - time.monotonic()
                assert left > 0 and not self._eof, (what, self.lines[-5:])
                self._cond.wait(left)

    def has(self, text: str) -> bool:
        with self._cond:
            return any(text in line for line in self.lines)

    def acknowledged(self) -> int:
        with self._cond:
            return sum(1 for line in self.lines if line.lstrip().startswith("recorded "))

    def finish(self, timeout: float = 60) -> tuple[int, str]:
        code = self.proc.wait(timeout)
        for t in self._threads:
            t.join(5)
        return code, "".join(self.err)


def check_session(folder: Path, n: int) -> None:
    """n points, in plan order, each recomputed from its counts = the device's point."""
    s = read_session(folder)
    plan = load_plan(PLAN)
    assert len(s) == n
    assert [p.slot for p in s.points] == list(range(n))
    assert [p.articulation_index for p in s.points] == [
        sl.articulation_index for sl in plan.slots[:n]
    ]
    # device (float build, 0.1 um output) vs double-precision recompute from the raw counts
    assert np.abs(s.points_mm() - s.device_points_mm).max() < 2e-3
    seqs = [p.device_time_us for p in s.points]
    assert seqs == sorted(seqs)


class Operated:
    """A simulator whose encoders and buttons the test sets through its control
    channel: a press happens only when the test makes it, with counts it chose."""

    def __init__(self, seed: int, n: int) -> None:
        from aacmm.simulation.control import ControlChannel

        self.chan, fd = ControlChannel.pair()
        try:
            self.sim = SimProcess(
                ["--serial", "pty", "--quiet", "--control", str(fd)], pass_fds=[fd]
            )
        finally:
            self.chan.child_started()
        self.chan.hello()
        rng = np.random.default_rng(seed)
        self.poses = [tuple(int(c) for c in rng.integers(0, 1 << 32, 6)) for _ in range(n)]

    def press(self, counts: tuple[int, ...], button: int = 0) -> None:
        self.chan.set_counts(counts)
        self.chan.press(button)
        self.chan.release(button)

    def __enter__(self) -> Operated:
        return self

    def __exit__(self, *exc: object) -> None:
        self.chan.close()
        self.sim.stop()


def test_full_plan(sim: SimProcess, tmp_path: Path) -> None:
    out = tmp_path / "s1"
    cap = Capture(PLAN, "-o", str(out), "--port", sim.url)
    code, err = cap.finish()
    assert code == 0, err
    assert cap.lines[-1] == f"complete: 30 points in {out}"
    assert cap.acknowledged() == 30
    assert "[1/30] step 1/1, cone seat, articulation 1 of 30: seat the probe" in cap.lines
    check_session(out, 30)
    s = read_session(out)
    assert s.status == "complete" and s.complete
    assert s.device is not None and s.device["serial_number"] == 1
    progress = (out / "progress.json").read_text()
    assert '"next_slot": 30' in progress and '"complete": true' in progress
    summary = run("summary", str(out))
    assert summary.returncode == 0, summary.stderr
    assert summary.stdout.splitlines()[:2] == [
        f"session {out} (complete): 30 of 30 points",
        "plan probe-calibration: Probe calibration (pivot)",
    ]
    lines = summary.stdout.splitlines()
    assert lines[-2].split() == ["pivot", "cone", "30", "of", "30"]
    # the simulator's sensors read 20 degC on every link, at every point
    links = "; ".join(f"link {j} 20.00" for j in range(1, 7))
    assert lines[-1] == f"temperatures 20.00 C (all links read at 30 of 30 points; {links})"


def test_kill9_then_resume_loses_no_acknowledged_point(sim: SimProcess, tmp_path: Path) -> None:
    out = tmp_path / "s"
    cap = Capture(PLAN, "-o", str(out), "--port", sim.url)
    cap.wait_for("recorded 8/30")
    time.sleep(0.27)  # somewhere between two presses, or inside one
    cap.proc.kill()
    cap.finish()
    acked = cap.acknowledged()  # every line printed before the kill, read to the end
    s = read_session(out)
    # every acknowledged point is there; at most one more (durable, not yet printed)
    assert acked <= len(s) <= acked + 1
    assert s.status == "running"  # what a killed capture leaves
    cap = Capture(PLAN, "-o", str(out), "--port", sim.url, "--resume")
    code, err = cap.finish()
    assert code == 0, err
    assert f"(resumed, {len(s)} points so far)" in cap.lines[0]
    check_session(out, 30)
    runs = read_session(out).meta["runs"]
    assert [r["kind"] for r in runs] == ["capture", "resume"]
    assert runs[1]["first_slot"] == len(s)


def test_undo_key_and_ctrl_c(tmp_path: Path) -> None:
    """Key u on the terminal undoes the last point even while presses keep coming
    (capture reads the keyboard after every event, not only in a pause between them),
    and Ctrl-C stops with the points kept. The test is the operator (:class:`Operated`),
    so the outcome does not depend on how fast either side runs."""
    out = tmp_path / "s"
    master, slave = pty.openpty()
    try:
        with Operated(seed=12, n=30) as op:
            pressed: list[tuple[int, ...]] = []

            def press() -> None:
                op.press(op.poses[len(pressed)])
                pressed.append(op.poses[len(pressed)])

            cap = Capture(PLAN, "-o", str(out), "--port", op.sim.url, stdin=slave)
            assert op.chan.wait_stream(True, timeout=30), cap.lines
            for _ in range(5):
                press()
            cap.wait_for("recorded 5/30")
            os.write(master, b"u")
            # back to back, without waiting for capture, until the key is taken
            while len(pressed) < 29 and not cap.has("  undone "):
                press()
            cap.wait_for("  undone ")
            undone = [line for line in cap.lines if line.startswith("  undone ")]
            assert len(undone) == 1
            k = int(undone[0].split()[1].split("/")[0])  # "  undone K/30: ..."
            # taken while presses were still coming (a key used to wait for a 50 ms pause)
            assert 5 <= k < len(pressed), (k, len(pressed))
            press()
            cap.wait_until(lambda: cap.acknowledged() == len(pressed))
            cap.proc.send_signal(signal.SIGINT)
            code, err = cap.finish()
    finally:
        os.close(master)
        os.close(slave)
    assert code == 130, err
    assert "continue with --resume" in err
    s = read_session(out)
    assert s.status == "interrupted"
    assert [p.counts for p in s.points] == pressed[: k - 1] + pressed[k:]
    check_session(out, len(pressed) - 1)
    events = (out / "events.csv").read_text().splitlines()
    assert sum(1 for e in events if ",undo," in e) == 1


def test_parameter_set_changes_between_runs(sim: SimProcess, tmp_path: Path) -> None:
    """15.5: a session resumed on a device with another set records both, per row."""
    out = tmp_path / "s"
    cap = Capture(PLAN, "-o", str(out), "--port", sim.url)
    cap.wait_for("recorded 4/30")
    cap.proc.send_signal(signal.SIGTERM)
    assert cap.finish()[0] == 130
    n1 = len(read_session(out))
    params = tmp_path / "p.toml"
    assert run("params", "get", "-o", str(params), "--port", sim.url).returncode == 0
    text = params.read_text().replace("l_mm = 183.5", "l_mm = 150.0")
    params.write_text(text)
    assert run("params", "set", str(params), "--port", sim.url).returncode == 0
    cap = Capture(PLAN, "-o", str(out), "--port", sim.url, "--resume")
    assert cap.finish()[0] == 0
    s = read_session(out)
    crcs = [p.param_set.crc32 for p in s.points]
    assert (
        len(set(crcs)) == 2 and crcs[:n1] == [crcs[0]] * n1 and crcs[n1:] == [crcs[-1]] * (30 - n1)
    )
    assert s.param_sets[crcs[-1]].params.l_mm == 150.0
    # each row recomputed with its own set agrees with the device; the first set would not
    check_session(out, 30)
    with pytest.raises(ValueError, match="parameter set changes at row"):
        s.single_params("a one-set analysis")


def test_bad_input(sim: SimProcess, tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('format = "aacmm-plan-1"\n[[steps]]\nprocedure = "cone"\nartefact = "x"\n')
    p = run("capture", str(bad), "-o", str(tmp_path / "s"), "--port", sim.url)
    one_error_line(p, 2, "bad.toml:4: steps[0].artefact: unknown artefact 'x'")
    assert not (tmp_path / "s").exists()
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("")
    p = run("capture", PLAN, "-o", str(tmp_path / "full"), "--port", sim.url)
    one_error_line(p, 2, "exists", "--resume")
    p = run("capture", PLAN, "-o", str(tmp_path / "none"), "--resume", "--port", sim.url)
    one_error_line(p, 2, "no session to resume")
    p = run("capture", "iso10360-12", "-o", str(tmp_path / "full"), "--resume", "--port", sim.url)
    one_error_line(p, 2)


def test_operator_on_the_control_channel(tmp_path: Path) -> None:
    """The device's encoders set through the simulator's control channel: each press
    carries known counts, so every recorded point is checked against what was pressed
    (none lost, none mislabelled); button 1 undoes, and a press made while capture is
    not yet listening is not taken."""
    with Operated(seed=11, n=40) as op:
        poses = op.poses
        op.press(poses[39])  # nobody listening yet: must not become a point
        out = tmp_path / "s"
        cap = Capture(PLAN, "-o", str(out), "--port", op.sim.url)
        assert op.chan.wait_stream(True, timeout=30), cap.lines
        taken: list[tuple[int, ...]] = []
        for k in range(33):
            op.press(poses[k])
            taken.append(poses[k])
            cap.wait_for(f"recorded {len(taken)}/30")
            if k in (4, 20):  # undo the point just taken
                op.press(poses[38], button=1)
                cap.wait_for(f"undone {len(taken)}/30")
                taken.pop()
            if len(taken) == 30:
                break
        code, err = cap.finish()
    assert code == 0, err
    s = read_session(out)
    assert [p.counts for p in s.points] == taken
    check_session(out, 30)
    events = (out / "events.csv").read_text()
    assert events.count(",undo,") == 2
    assert poses[39] not in [p.counts for p in s.points]  # pressed before capture listened


def _count(cap: Capture, text: str) -> int:
    with cap._cond:
        return sum(1 for line in cap.lines if text in line)


def test_last_point_undo_confirm_kill9_resume(tmp_path: Path) -> None:
    """On a terminal the end of the plan waits for a confirmation, so the last point
    can be undone too (button 1, key u); kill -9 while waiting leaves every point on
    disk (status running) and --resume waits for the confirmation again (Enter)."""
    out = tmp_path / "s"
    master, slave = pty.openpty()
    try:
        with Operated(seed=13, n=33) as op:
            poses = op.poses
            cap = Capture(PLAN, "-o", str(out), "--port", op.sim.url, stdin=slave)
            assert op.chan.wait_stream(True, timeout=30), cap.lines
            for k in range(30):
                op.press(poses[k])
            cap.wait_for("plan complete: press the button or Enter to finish")
            assert cap.acknowledged() == 30 and cap.proc.poll() is None
            s = read_session(out)
            assert s.complete and s.status == "running"  # taken, not yet confirmed
            op.press(poses[32], button=1)  # the second button undoes the last point
            cap.wait_for("  undone 30/30: ")
            assert len(read_session(out)) == 29
            cap.wait_until(lambda: cap.lines[-1].startswith("[30/30] "), what="prompt 30 again")
            op.press(poses[30])
            cap.wait_until(lambda: _count(cap, "plan complete:") == 2, what="complete again")
            cap.proc.kill()  # kill -9 while waiting for the confirmation
            cap.finish()
            s = read_session(out)
            assert s.status == "running" and s.complete
            assert [p.counts for p in s.points] == [*poses[:29], poses[30]]

            starts = op.chan.starts()
            cap = Capture(PLAN, "-o", str(out), "--port", op.sim.url, "--resume", stdin=slave)
            assert op.chan.wait_stream(after_starts=starts, timeout=30), cap.lines
            cap.wait_for("plan complete: press the button or Enter to finish")
            os.write(master, b"u")  # the key undoes the last point too
            cap.wait_for("  undone 30/30: ")
            op.press(poses[31])
            cap.wait_until(lambda: _count(cap, "plan complete:") == 2, what="complete again")
            os.write(master, b"\n")  # Enter confirms
            code, err = cap.finish()
            # a confirmed session is complete: resuming it ends at once
            again = run("capture", PLAN, "-o", str(out), "--resume", "--port", op.sim.url)
    finally:
        os.close(master)
        os.close(slave)
    assert code == 0, err
    assert cap.lines[-1] == f"complete: 30 points in {out}"
    s = read_session(out)
    assert s.status == "complete"
    assert [p.counts for p in s.points] == [*poses[:29], poses[31]]
    check_session(out, 30)
    runs = s.meta["runs"]
    assert [r["kind"] for r in runs] == ["capture", "resume", "resume"]
    assert runs[1]["end_reason"] == "confirmed by key Enter"
    assert runs[2]["end_reason"] == "already complete"
    events = [line.split(",") for line in (out / "events.csv").read_text().splitlines()[1:]]
    kinds = [e[1] for e in events]
    assert kinds.count("undo") == 2 and kinds.count("confirm") == 1
    assert kinds[-4:] == ["confirm", "end", "run", "end"] and events[-4][-1] == "key Enter"
    assert kinds.count("point") == 32  # 30, one re-taken in each run
    progress = (out / "progress.json").read_text()
    assert '"complete": true' in progress and '"status": "complete"' in progress
    assert again.returncode == 0 and again.stdout == f"session {out} is complete (30 points)\n"


def test_confirm_end_by_button_and_sigterm(tmp_path: Path) -> None:
    """--confirm-end without a terminal: only the buttons; SIGTERM while waiting keeps
    every point (interrupted, exit 130), and button 0 confirms after --resume.
    Without it (no terminal) a session ends at its last point (test_full_plan)."""
    out = tmp_path / "s"
    with Operated(seed=14, n=31) as op:
        poses = op.poses
        cap = Capture(PLAN, "-o", str(out), "--port", op.sim.url, "--confirm-end")
        assert op.chan.wait_stream(True, timeout=30), cap.lines
        for k in range(30):
            op.press(poses[k])
        cap.wait_for("plan complete: press the button to finish, button 1 to undo")
        cap.proc.send_signal(signal.SIGTERM)
        code, err = cap.finish()
        assert code == 130, err
        assert "all 30 points kept" in err and "the end not confirmed" in err
        s = read_session(out)
        assert s.status == "interrupted" and s.complete
        starts = op.chan.starts()
        cap = Capture(PLAN, "-o", str(out), "--port", op.sim.url, "--resume", "--confirm-end")
        assert op.chan.wait_stream(after_starts=starts, timeout=30), cap.lines
        cap.wait_for("plan complete:")
        op.press(poses[30])  # button 0: finish (its counts are no point)
        code, err = cap.finish()
    assert code == 0, err
    s = read_session(out)
    assert s.status == "complete" and [p.counts for p in s.points] == poses[:30]
    assert s.meta["runs"][-1]["end_reason"] == "confirmed by button 0"
    events = (out / "events.csv").read_text().splitlines()
    assert sum(1 for e in events if ",confirm," in e) == 1


STEPS_PLAN = """\
format = "aacmm-plan-1"
[artefacts.seatA]
type = "cone"
[artefacts.seatB]
type = "cone"
[artefacts.bar]
type = "ballbar"
length_mm = 500.0
[[steps]]
id = "first"
procedure = "cone"
artefact = "seatA"
articulations = 2
note = "Turn the wrist between presses."
[[steps]]
id = "second"
procedure = "cone"
artefact = "seatB"
articulations = 2
[[steps]]
id = "third"
procedure = "length"
artefact = "bar"
positions = 1
"""


def test_every_step_is_announced(sim: SimProcess, tmp_path: Path) -> None:
    """Issue 29.7: capture announced only the steps that have a note."""
    plan = tmp_path / "three.toml"
    plan.write_text(STEPS_PLAN)
    cap = Capture(str(plan), "-o", str(tmp_path / "s"), "--port", sim.url)
    code, err = cap.finish()
    assert code == 0, err
    steps = [line for line in cap.lines if line.startswith("step ")]
    assert steps == [
        "step 1/3 first: 2 points on cone seat seatA. Turn the wrist between presses.",
        "step 2/3 second: 2 points on cone seat seatB",
        "step 3/3 third: 2 points on ball bar bar",
    ], cap.lines


def test_read_only_session_folder_refused_before_the_device(tmp_path: Path) -> None:
    """Issue 29.5: `capture -o RO/new` opened the device, then failed with a raw
    "[Errno 30] Read-only file system", exit 1. Now: one line, exit 2, before any
    port is opened (this port does not exist: opening it would be exit 3)."""
    ro, wrap = read_only_dir(tmp_path)
    for extra in ([], ["--from-log", str(tmp_path / "x.csv")]):
        (tmp_path / "x.csv").write_text("")
        p = subprocess.run(
            [*wrap, str(AACMM), "capture", PLAN, "-o", str(ro / "new"),
             "--port", "serial:///nonexistent/port", *extra],
            capture_output=True, text=True, timeout=60, env=cli_env(),
        )  # fmt: skip
        one_error_line(p, 2, f"{ro / 'new'}: cannot create a file in {ro}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ro", "x.csv"]
