"""``aacmm view`` and ``aacmm capture --view`` in a real headless browser (issue 28).

Debian's Chromium, driven by Playwright (tests/host/viewbrowser.py), opens the
page served by the real commands against the real simulator and its simulated
operator. Checked against what the device and the session files say, not
against the page's own numbers: the tip the page holds follows the operator
(each press's device point, from points.csv, within 2 mm of the frame the page
had for that device time), every captured point reaches the page within 1 s of
its press (the press's host time in points.csv), two pages at once see the same,
a browser that closes mid-capture costs the capture nothing, the offline view
of a session holds its N points (as records recomputes them) and a fit per step
(the sphere as aacmm verify fits it, seats recomputed here), the HTML reports
of verify and calibrate open with the network off; no page logs an error or
asks for anything outside its own server. Screenshots must not be blank; with
``AACMM_VIEW_FIGURES=docs/figures`` (``make view-figures``) they are the
figures of docs/view.md.
"""

from __future__ import annotations

import csv
import json
import math
import signal
import socket
import subprocess
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from aacmm import core
from aacmm.arm import Arm, Joint
from aacmm.records import read_session
from aacmm.view.arm import arm_pose, chain
from clihelp import AACMM, capture_scenario, cli_env, one_error_line, run, sim_fixture
from viewbrowser import Watched, figures_dir, launch, playwright

pytestmark = pytest.mark.timeout(300)

sim = sim_fixture("--motion", "walk")

SMALL_PLAN = """\
format = "aacmm-plan-1"
title = "View test: a seat and a sphere"

[probe]
ball_diameter_mm = 6.0

[artefacts.seat]
type = "cone"
location_mm = [650.0, -350.0, -250.0]

[artefacts.ball]
type = "sphere"
diameter_mm = 25.4
location_mm = [750.0, -200.0, -150.0]

[[steps]]
id = "seat"
procedure = "cone"
artefact = "seat"
articulations = 8

[[steps]]
id = "ball"
procedure = "sphere"
artefact = "ball"
points = 8
"""
SMALL_PLAN_POINTS = 16
SMALL_PLAN_SEAT = 8
#: the plan with a stability band (the page shows whether the links are within it)
BAND_PLAN = SMALL_PLAN + "\n[verification]\ntemperature_c = 20.0\ntemperature_band_c = 3.0\n"


class Proc:
    """A long-running ``aacmm`` command whose stdout lines are collected as they come."""

    def __init__(self, *args: str) -> None:
        self.p = subprocess.Popen(
            [str(AACMM), *args],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=cli_env(),
        )
        self.lines: list[str] = []
        self.err: list[str] = []
        self._t = [
            threading.Thread(target=self._read, args=(self.p.stdout, self.lines), daemon=True),
            threading.Thread(target=self._read, args=(self.p.stderr, self.err), daemon=True),
        ]
        for t in self._t:
            t.start()

    @staticmethod
    def _read(f: Any, out: list[str]) -> None:
        for line in f:
            out.append(line.rstrip("\n"))

    def wait_line(self, prefix: str, timeout: float = 30.0) -> str:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for ln in self.lines:
                if ln.startswith(prefix):
                    return ln
            if self.p.poll() is not None:
                break
            time.sleep(0.05)
        raise AssertionError(f"no line {prefix!r}: {self.lines} {self.err}")

    def stop(self, sig: int = signal.SIGINT, timeout: float = 20.0) -> int:
        if self.p.poll() is None:
            self.p.send_signal(sig)
        try:
            self.p.wait(timeout)
        except subprocess.TimeoutExpired:
            self.p.kill()
            self.p.wait()
        for t in self._t:
            t.join(5)
        return self.p.returncode


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# ---------------------------------------------------------------- the arm drawn


def test_drawn_chain_ends_at_the_cores_tip() -> None:
    """The links the view draws (numpy DH chain) end where the C core puts the tip."""
    rng = np.random.default_rng(28)
    params = core.Params(
        theta_offset_rad=tuple(rng.uniform(-0.01, 0.01, 6)),
        a_mm=tuple(rng.uniform(-1, 1, 6)),
        d_mm=tuple(np.array(core.Params().d_mm) + rng.uniform(-1, 1, 6)),
    )
    model = core.Model(params)
    for _ in range(50):
        th = rng.uniform(-math.pi, math.pi, 6)
        pose = arm_pose(params, th)
        np.testing.assert_allclose(pose.tip_mm, model.point(th), atol=1e-9)
        np.testing.assert_allclose(pose.path_mm[-1], pose.tip_mm, atol=0)
        assert len(pose.joints_mm) == 6
    # any number of joints: a planar 4-joint arm, every twist 0, lengths along x
    planar = Arm(joints=tuple(Joint(a_mm=100.0) for _ in range(4)), tip_mm=(0.0, 0.0, 10.0))
    p4 = chain(planar, [0.0, math.pi / 2, 0.0, 0.0])
    np.testing.assert_allclose(p4.tip_mm, [100.0, 300.0, 10.0], atol=1e-12)
    assert len(p4.joints_mm) == 4
    with pytest.raises(ValueError):
        chain(planar, [0.0] * 3)


def test_arm_chain_any_arm() -> None:
    """The drawn chain of any arm (4 to 7 joints, standard and modified DH, Hayati
    betas, a tip vector) ends where the C core puts the probe (aacmm.core.Model),
    and each joint axis is the z column the core turns about (the tip moves
    perpendicular to it when only that joint turns)."""
    rng = np.random.default_rng(28)
    for n in (4, 5, 6, 7):
        for _ in range(4):
            joints = []
            for i in range(n):
                conv = str(rng.choice(["standard", "modified"]))
                beta = float(rng.uniform(-0.01, 0.01)) if i > 0 and rng.random() < 0.4 else None
                joints.append(
                    Joint(
                        convention=conv,
                        theta_offset_rad=float(rng.uniform(-0.1, 0.1)),
                        alpha_rad=float(rng.choice([0.0, math.pi / 2, -math.pi / 2]))
                        + float(rng.uniform(-0.01, 0.01)),
                        d_mm=float(rng.uniform(-300, 300)),
                        a_mm=float(rng.uniform(-300, 300)),
                        beta_rad=beta,
                    )
                )
            arm = Arm(joints=tuple(joints), tip="xyz", tip_mm=tuple(rng.uniform(-100, 200, 3)))
            model = core.Model(arm)
            for _ in range(10):
                th = rng.uniform(-math.pi, math.pi, n)
                pose = chain(arm, th)
                np.testing.assert_allclose(pose.tip_mm, model.point(th), atol=1e-9)
                assert len(pose.joints_mm) == n
                j = int(rng.integers(n))
                dth = np.zeros(n)
                dth[j] = 1e-6
                step = model.point(th + dth) - model.point(th)
                assert abs(float(np.dot(step, pose.axes[j]))) < 1e-6 * np.linalg.norm(step) + 1e-12


# ---------------------------------------------------------------- live


def test_live_view_two_pages(sim: Any, tmp_path: Path) -> None:
    """``aacmm view --port`` on the simulator's random walk, two pages at once: both get
    frames, each frame's drawn chain ends at the device's tip, the tip moves; no console
    error, no outside request; a screenshot that is not blank."""
    view = Proc("view", "--port", sim.url, "--bind", "127.0.0.1:0", "--rate", "500")
    try:
        url = view.wait_line("http://")
        with playwright() as p:
            b = launch(p)
            a = Watched(b, url).open(url)
            c = Watched(b, url).open(url)
            time.sleep(3.0)
            for page in (a, c):
                st = page.state("{frames: s.frames, last: s.lastFrame, hist: s.history}")
                assert st["frames"] >= 10, st["frames"]
                f = st["last"]
                # the chain the page draws (host numpy FK) against the device's float tip,
                # and the C core from the frame's joint angles
                np.testing.assert_allclose(f["arm"]["path"][-1], f["tip"], atol=0.01)
                theta = np.radians(f["theta_deg"])
                np.testing.assert_allclose(core.Model().point(theta), f["tip"], atol=0.01)
                tips = np.array([h["tip"] for h in st["hist"]])
                assert np.ptp(tips, axis=0).max() > 1.0, "the tip does not follow the walk"
                assert len(f["arm"]["joints"]) == 6
            a.screenshot(figures_dir(tmp_path) / "view-live.png")
            a.clean()
            c.clean()
            b.close()
    finally:
        code = view.stop()
    assert code == 0, view.err
    # the device is free again: another command can open the port
    assert run("info", "--port", sim.url).returncode == 0


def test_capture_view(tmp_path: Path) -> None:
    """``aacmm capture --view`` with the simulated operator at a person's pace: two
    browsers, one closed mid-capture; tip within 2 mm of every press, every point on the
    page within 1 s of its press, the session complete with every point."""
    plan = tmp_path / "plan.toml"
    plan.write_text(BAND_PLAN)  # the simulated arm's links read 20 degC: within the band
    link, session = tmp_path / "arm", tmp_path / "s"
    total = SMALL_PLAN_POINTS
    with playwright() as p:
        # the browsers start first (a cold start takes seconds on a loaded machine)
        ba, bb = launch(p), launch(p)
        # the third seat point is first probed 5 mm off and undone (button 1)
        op = Proc(
            "sim", "--scenario", str(plan), "--truth", "random:7", "--link", str(link),
            "--misprobe", "seat:3:5",
        )  # fmt: skip
        cap: Proc | None = None
        try:
            op.wait_line("serial://")
            cap = Proc(
                "capture", str(plan), "-o", str(session), "--port", f"serial://{link}",
                "--view", "--bind", "127.0.0.1:0", "--no-keys",
            )  # fmt: skip
            url = cap.wait_line("view: ").split()[1]
            a, b = Watched(ba, url), Watched(bb, url)
            for w in (a, b):  # load both pages at once
                w.page.goto(url, wait_until="commit")
            for w in (a, b):  # up, and a first live frame drawn (the page warmed up)
                w.page.wait_for_function(
                    "window.aacmmView && window.aacmmView.state.liveAt", timeout=90_000
                )
            ready_ms = max(a.state("s.liveAt"), b.state("s.liveAt"))
            shot = False
            b_open = True
            deadline = time.monotonic() + 150
            while cap.p.poll() is None and time.monotonic() < deadline:
                n = a.state("s.capture ? s.capture.accepted : 0")
                if b_open and n >= total // 2:
                    # both pages show the same session before one browser goes away
                    sa = a.state("s.capture.points.map(p => p.slot)")
                    sb = b.state("s.capture ? s.capture.points.map(p => p.slot) : []")
                    assert sb == sa or abs(len(sb) - len(sa)) <= 1, (sa, sb)
                    assert b.state("s.frames") > 0
                    b.clean()
                    bb.close()  # the browser closes mid-capture
                    b_open = False
                if not shot and n >= 3:  # in the seat step: the articulation advice
                    a.screenshot(figures_dir(tmp_path) / "view-capture.png")
                    shot = True
                time.sleep(0.2)
            assert cap.p.wait(30) == 0, cap.err
            assert not b_open and shot, (b_open, shot)
            # the server said it went away (1001): the page stops, it does not retry
            a.page.wait_for_function("window.aacmmView.state.stopped", timeout=15_000)
            time.sleep(0.5)
            st = a.state("{cap: s.capture, seen: s.pointSeen, hist: s.history, ev: s.events}")
            band = a.page.inner_text("#temps-band")
            band_range = a.page.inner_text("#temps-range")
            a.clean()
            ba.close()
        finally:
            if cap is not None:
                cap.stop()
            op.stop(signal.SIGTERM)
    assert cap.err == [], cap.err  # nothing on stderr: no traceback, no warning
    assert band == "within the plan's 3 °C band about 20 °C", band
    assert band_range == "this capture so far: 20.00 .. 20.00 °C", band_range
    s = read_session(session)
    assert s.complete and len(s.points) == total and s.status == "complete"
    with (session / "points.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert st["cap"]["accepted"] == total
    # the mis-probed point, recorded then undone, as the page told it (if it came after
    # the page was up); the journal has the undo either way
    with (session / "events.csv").open(newline="") as f:
        undos = [r for r in csv.DictReader(f) if r["event"] == "undo"]
    assert [int(r["slot"]) for r in undos] == [2]
    if float(undos[0]["event_time"]) * 1000.0 > ready_ms + 500:
        kinds = [(e["kind"], e["slot"]) for e in st["ev"]]
        assert ("undone", 2) in kinds, kinds
    assert [p["slot"] for p in st["cap"]["points"]] == list(range(total))
    hist = st["hist"]
    t_us = np.array([h["t_us"] for h in hist], dtype=np.int64)
    tips = np.array([h["tip"] for h in hist])
    checked = 0
    for r in rows:
        press_ms = float(r["host_time"]) * 1000.0
        if press_ms < ready_ms:
            continue  # pressed before the pages were up
        seen = st["seen"][r["slot"]]
        assert seen - press_ms < 1000.0, (r["slot"], seen - press_ms)
        # the frames of the samples the device read while the operator held the probe in
        # place: from 120 ms before the press (the dwell) to 80 ms after (the hold)
        dt = t_us - int(r["device_time_us"])
        near = np.flatnonzero((dt >= -120_000) & (dt <= 80_000))
        device = np.array([float(r["x_mm"]), float(r["y_mm"]), float(r["z_mm"])])
        for k in near:
            assert np.linalg.norm(tips[k] - device) <= 2.0, (r["slot"], tips[k], device)
        checked += bool(near.size)
    assert checked >= total // 2, checked
    # each point's residual to its step's fit, as the page had it: the seat's points
    # against their centroid, recomputed here from the session
    pts = s.points_mm()
    seat = pts[:SMALL_PLAN_SEAT]
    d = np.linalg.norm(seat - seat.mean(axis=0), axis=1)
    page = [p["residual_mm"] for p in st["cap"]["points"][:SMALL_PLAN_SEAT]]
    np.testing.assert_allclose(page, d, atol=1e-6)


# ---------------------------------------------------------------- offline


@pytest.fixture(scope="module")
def iso_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("iso")
    session, _, _ = capture_scenario(folder, "iso10360-12", "random:7")
    return session


def test_offline_session_view(iso_session: Path, tmp_path: Path) -> None:
    """``aacmm view SESSION``: its N points as records recomputes them, a fit per step
    (the sphere as aacmm verify fits it), the verdict aacmm verify gives."""
    s = read_session(iso_session)
    n = len(s.points)
    rep_dir = tmp_path / "rep"
    verify = run("verify", str(iso_session), "--report", str(rep_dir), "-q")
    assert verify.returncode == 7, verify.stderr  # the random arm fails
    rep = json.loads((rep_dir / "report.json").read_text())
    view = Proc("view", str(iso_session), "--bind", "127.0.0.1:0")
    try:
        url = view.wait_line("http://")
        with playwright() as p:
            b = launch(p)
            w = Watched(b, url).open(url)
            st = w.state("{points: s.points, fits: s.fits, scene: s.scene}")
            w.screenshot(figures_dir(tmp_path) / "view-session.png")
            rows = w.page.locator("#steps-table tr[data-step]").count()
            vrows = w.page.locator("#verification-table tr").count() - 1
            w.clean()
            b.close()
    finally:
        assert view.stop() == 0
    assert len(st["points"]) == n == 90
    np.testing.assert_allclose([q["xyz"] for q in st["points"]], s.points_mm(), atol=1e-4)
    assert st["fits"] == len(s.plan.steps) == rows == 4
    steps = {x["id"]: x for x in st["scene"]["steps"]}
    # ball-centre sphere = the surface sphere aacmm verify reports + the probe ball
    d_page = 2.0 * steps["probing"]["feature"]["radius_mm"]
    d_verify = rep["steps"]["probing"]["diameter_mm"] + rep["probe_diameter_mm"]
    assert abs(d_page - d_verify) < 1e-6, (d_page, d_verify)
    lengths = steps["length500"]["feature"]["positions"]
    verify_len = [q["length_mm"] for q in rep["steps"]["length500"]["positions"]]
    np.testing.assert_allclose([q["length_mm"] for q in lengths], verify_len, atol=1e-9)
    v = st["scene"]["verification"]
    assert v["verdict"] == rep["verdict"] == "FAIL"
    assert [r["verdict"] for r in v["results"]] == [r["verdict"] for r in rep["results"]]
    assert vrows == len(rep["results"])


def test_reports_open_offline(iso_session: Path, tmp_path: Path) -> None:
    """``verify --report`` and ``calibrate --report`` write report.html beside the PDF:
    one file that opens with the network off (no request but itself) and shows the
    points, the results against the MPEs and the calibration residuals per step;
    ``aacmm view REPORT-DIR`` serves the same scene."""
    rep = tmp_path / "vrep"
    assert run("verify", str(iso_session), "--report", str(rep), "-q").returncode == 7
    assert (rep / "report.pdf").is_file() and (rep / "report.html").is_file()
    kin, _, _ = capture_scenario(tmp_path / "kin", "kinematic-calibration", "random:7")
    crep = tmp_path / "crep"
    cal = run(
        "calibrate", str(kin), "-o", str(tmp_path / "cal.toml"), "--report", str(crep),
        "--workspace", "0", "-q", timeout=240,
    )  # fmt: skip
    assert cal.returncode == 0, cal.stderr
    scene = json.loads((crep / "view.json").read_text())
    with playwright() as p:
        b = launch(p)
        reports = ((rep / "report.html", None), (crep / "report.html", "view-calibration.png"))
        for html, png in reports:
            file_url = html.resolve().as_uri()
            w = Watched(b, file_url, offline=True).open(file_url)
            st = w.state("{points: s.points.length, scene: s.scene}")
            if png:
                w.screenshot(figures_dir(tmp_path) / png)
            else:
                w.screenshot(tmp_path / "vrep.png")
            assert w.requests == [file_url], w.requests
            w.clean()
            if png is None:
                assert st["points"] == 90
                assert w.page.locator("#verification-table tr").count() > 4
            else:
                assert st["points"] == 135
                cal_rows = w.page.locator("#calibration-table tr").count() - 1
                assert cal_rows == len(scene["calibration"]["steps"]) == 6
        b.close()
    # the residuals per step are the calibration's own (report.json: rms before/after)
    prov = json.loads((crep / "report.json").read_text())
    after = np.concatenate([st["after_mm"] for st in scene["calibration"]["steps"]])
    rms_units = float(np.sqrt(np.mean(after**2)))
    assert rms_units < 0.05 and prov["result"]["residuals"]["rms_mm_after"] < 0.05
    # aacmm view REPORT-DIR: the scene of view.json
    view = Proc("view", str(crep), "--bind", "127.0.0.1:0")
    try:
        url = view.wait_line("http://")
        with urllib.request.urlopen(url + "scene.json", timeout=10) as r:
            served = json.loads(r.read())
    finally:
        assert view.stop() == 0
    assert served == scene
    # --html: the same page for a session, written to a file
    out = tmp_path / "s.html"
    p2 = run("view", str(iso_session), "--html", str(out))
    assert p2.returncode == 0 and out.stat().st_size > 1_000_000, p2.stderr
    again = run("view", str(iso_session), "--html", str(out))
    one_error_line(again, 2, "exists")


def test_log_view(sim: Any, tmp_path: Path) -> None:
    """``aacmm view LOG``: the tip's path from the log's counts."""
    log = tmp_path / "run.csv"
    assert run("log", str(log), "--port", sim.url, "-d", "1", "-r", "200").returncode == 0
    out = tmp_path / "log.html"
    assert run("view", str(log), "--html", str(out)).returncode == 0
    html = out.read_text()
    doc = html.split('id="aacmm-scene">', 1)[1].split("</script>", 1)[0]
    scene = json.loads(doc)
    assert scene["kind"] == "log" and len(scene["trail"]) >= 150
    with log.open(newline="") as f:
        first = next(csv.DictReader(f))
    np.testing.assert_allclose(
        scene["trail"][0], [float(first[k]) for k in ("x_mm", "y_mm", "z_mm")], atol=2e-3
    )


# ---------------------------------------------------------------- temperatures


def test_temperature_band_of_a_frame(tmp_path: Path) -> None:
    """The band the page shows: within it, a span wider than it, a link too far from the
    plan's temperature, a link without a reading, readings within it now that drifted
    out of it since the capture started; nothing without a plan or a band."""
    from aacmm.plans import load_plan
    from aacmm.view.live import temperature_band

    path = tmp_path / "band.toml"
    path.write_text(BAND_PLAN)
    plan = load_plan(path)
    ok = temperature_band([20.0, 21.5, 22.9, 20.0, 20.5, 21.0], plan)
    assert ok == {"band_c": 3.0, "ref_c": 20.0, "range_c": [20.0, 22.9], "problem": None}
    held = temperature_band([21.0] * 6, plan, (20.0, 22.9))
    assert held is not None and held["problem"] is None and held["range_c"] == [20.0, 22.9]
    drift = temperature_band([22.0] * 6, plan, (18.5, 19.0))
    assert drift is not None and drift["range_c"] == [18.5, 22.0]
    assert drift["problem"] == (
        "since the capture started, the links' temperature spans 18.5 .. 22 C, more than "
        "the plan's 3 C stability band"
    )
    span = temperature_band([18.5, 21.75, 20.0, 20.0, 20.0, 20.0], plan)
    assert span is not None and "spans 18.5 .. 21.75 C, more than the plan's 3 C" in str(
        span["problem"]
    )
    far = temperature_band([23.5] * 6, plan)
    assert far is not None and "23.5 C is 3.5 C from the plan's 20 C" in str(far["problem"])
    gone = temperature_band([20.0, None, 20.0, 20.0, 20.0, 20.0], plan)
    assert gone is not None and gone["problem"] == "link 2 gives no temperature"
    none = temperature_band([None] * 6, plan)
    assert none is not None and none["range_c"] is None
    assert none["problem"] == "link 1 gives no temperature"
    path.write_text(SMALL_PLAN)
    assert temperature_band([30.0] * 6, load_plan(path)) is None
    assert temperature_band([30.0] * 6, None) is None


def test_live_view_shows_the_link_temperatures(tmp_path: Path) -> None:
    """``aacmm view --port`` on a device that reads its link temperatures: the page's
    table holds the temperatures the simulator's sensors were given, link by link."""
    from aacmm.simulation.process import SimProcess

    given = ["20.00", "21.50", "22.00", "23.00", "24.25", "-5.50"]
    with SimProcess(["--serial", "pty", "--quiet", "--temperature", ",".join(given)]) as dev:
        view = Proc("view", "--port", dev.url, "--bind", "127.0.0.1:0")
        try:
            url = view.wait_line("http://")
            with playwright() as p:
                b = launch(p)
                page = Watched(b, url).open(url)
                page.page.wait_for_selector("#temps-table", timeout=30_000)
                rows = page.page.eval_on_selector_all(
                    "#temps-table tr", "rs => rs.map(r => r.innerText)"
                )
                assert page.page.query_selector("#temps-band") is None  # no plan, no band
                page.clean()
                b.close()
        finally:
            code = view.stop()
    assert code == 0, view.err
    want = [f"link {j}\t{t} °C" for j, t in enumerate(given, 1)]
    assert [r.replace("\n", "\t") for r in rows] == want, rows


# ---------------------------------------------------------------- bad input


def test_bad_input(sim: Any, iso_session: Path, tmp_path: Path) -> None:
    one_error_line(run("view", str(tmp_path / "nope")), 2, "no such session")
    (tmp_path / "empty").mkdir()
    one_error_line(run("view", str(tmp_path / "empty")), 2, "not a session")
    one_error_line(run("view", "--html", str(tmp_path / "x.html")), 2, "needs a SOURCE")
    one_error_line(run("view", str(iso_session), "--bind", "nonsense"), 2, "HOST:PORT")
    one_error_line(run("view", str(iso_session), "--bind", "0.0.0.0:0"), 2, "--allow-remote")
    one_error_line(run("view", "--port", sim.url, "--fps", "10"), 2, "--fps")
    # a busy port: another server listens there; nothing is opened
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        one_error_line(run("view", str(iso_session), "--bind", f"127.0.0.1:{port}"), 3, "in use")
        one_error_line(run("view", "--port", sim.url, "--bind", f"127.0.0.1:{port}"), 3, "in use")
        s2 = tmp_path / "s2"
        capture_busy = run(
            "capture", "probe-calibration", "-o", str(s2), "--port", sim.url, "--view",
            "--bind", f"127.0.0.1:{port}", "--no-keys",
        )  # fmt: skip
        one_error_line(capture_busy, 3, "in use")
        assert not (s2 / "session.json").exists()
    # the device busy: another view holds its port
    view = Proc("view", "--port", sim.url, "--bind", "127.0.0.1:0")
    try:
        view.wait_line("http://")
        one_error_line(run("view", "--port", sim.url, "--bind", "127.0.0.1:0"), 3, "busy")
    finally:
        assert view.stop(signal.SIGTERM) == 0
    # a remote bind only when asked, with a warning
    remote = Proc("view", str(iso_session), "--bind", "0.0.0.0:0", "--allow-remote")
    try:
        remote.wait_line("http://0.0.0.0:")
        assert any("warning" in e and "anyone" in e for e in remote.err), remote.err
    finally:
        assert remote.stop() == 0


def test_page_is_read_only(iso_session: Path) -> None:
    """Only GET: writes are refused (405), another site's page cannot open the push
    channel (403), a request naming another host is refused (421: DNS rebinding)."""
    port = free_port()
    view = Proc("view", str(iso_session), "--bind", f"127.0.0.1:{port}")
    try:
        url = view.wait_line("http://")
        for method in ("POST", "PUT", "DELETE"):
            req = urllib.request.Request(url + "scene.json", data=b"{}", method=method)
            with pytest.raises(urllib.error.HTTPError) as e:
                urllib.request.urlopen(req, timeout=10)
            assert e.value.code == 405
        req = urllib.request.Request(
            url + "ws",
            headers={
                "Origin": "http://evil.example",
                "Connection": "Upgrade",
                "Upgrade": "websocket",
                "Sec-WebSocket-Version": "13",
                "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==",
            },
        )
        with pytest.raises(urllib.error.HTTPError) as e:
            urllib.request.urlopen(req, timeout=10)
        assert e.value.code == 403
        req = urllib.request.Request(url, headers={"Host": f"evil.example:{port}"})
        with pytest.raises(urllib.error.HTTPError) as e:
            urllib.request.urlopen(req, timeout=10)
        assert e.value.code == 421
        with urllib.request.urlopen(url, timeout=10) as r:
            assert "default-src 'self'" in r.headers["Content-Security-Policy"]
    finally:
        assert view.stop() == 0
