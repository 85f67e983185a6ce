"""What a press costs in ``aacmm capture``; one JSON object per line on stdout.

``aacmm sim --scenario PLAN --fast`` plans every articulation first, then its
operator presses the whole plan as fast as the control channel goes (135 presses
in about 0.1 s): capture finds them queued and records them one after the other,
each made durable (fsync) before the next. The time from a press's arrival to its
journal entry is then its place in that queue times capture's cost per point, not
the device's answer time: this benchmark keeps the figures apart.

* ``capture.scenario``: ``aacmm capture kinematic-calibration`` (135 points)
  against the ``--fast`` operator. ``burst_ms``: first to last press arriving;
  ``per_point_ms``: median interval between journal entries while presses were
  queued (capture's cost per point: the parameter check, the durable write);
  ``wait_ms_median``/``wait_ms_max``: a press's arrival to its journal entry.
* ``capture.paced``: ``aacmm capture probe-calibration`` (30 points) against the
  plain simulator pressing every 0.1 s: nothing queues, ``wait_ms_*`` is the cost
  of one point.
* ``capture.info_rtt``: INFO round trips while the ``--fast`` operator presses
  (one per press received, as capture's parameter check does): the device answers
  at once.

Wall-clock figures; ``machine`` gives the load they were taken under (fsync time
depends on what else the disk does).
"""

from __future__ import annotations

import csv
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from aacmm.client import connect
from aacmm.errors import DeviceTimeoutError
from benchjson import emit

AACMM = Path(sys.executable).with_name("aacmm")


def ms(x: float) -> float:
    return round(1e3 * x, 2)


def start_sim(folder: Path, *args: str) -> tuple[subprocess.Popen[str], str]:
    """``aacmm sim ARGS --link folder/arm``; the process and its URL once ready."""
    env = {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}
    sim = subprocess.Popen(
        [str(AACMM), "sim", *args, "--link", str(folder / "arm")],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=env,
    )
    assert sim.stdout is not None
    url = sim.stdout.readline().strip()
    if not url.startswith("serial://"):
        sim.kill()
        raise SystemExit(f"bench-capture: the simulator did not start ({url!r})")
    return sim, url


def capture(folder: Path, plan: str, url: str) -> tuple[float, list[tuple[float, float]]]:
    """Run ``aacmm capture``; its wall time and (arrival, journal) time of every point."""
    session = folder / "s"
    t0 = time.perf_counter()
    p = subprocess.run(
        [str(AACMM), "capture", plan, "-o", str(session), "--port", url, "-q"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"bench-capture: aacmm capture failed: {p.stderr.strip()}")
    with (session / "events.csv").open(newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["event"] == "point"]
    return wall, [(float(r["host_time"]), float(r["event_time"])) for r in rows]


def figures(wall: float, points: list[tuple[float, float]]) -> dict[str, Any]:
    arrive = [a for a, _ in points]
    journal = [j for _, j in points]
    waits = [j - a for a, j in points]
    queued = [
        journal[k + 1] - journal[k] for k in range(len(points) - 1) if arrive[k + 1] <= journal[k]
    ]
    return {
        "points": len(points),
        "wall_s": round(wall, 2),
        "burst_ms": ms(arrive[-1] - arrive[0]),
        "per_point_ms": ms(statistics.median(queued)) if queued else None,
        "wait_ms_median": ms(statistics.median(waits)),
        "wait_ms_max": ms(max(waits)),
    }


def info_rtt(folder: Path, plan: str, presses: int) -> dict[str, Any]:
    sim, url = start_sim(folder, "--scenario", plan, "--truth", "random:7", "--fast")
    rtts: list[float] = []
    try:
        with connect(url, timeout=5.0) as c, c.stream(20):
            while len(rtts) < presses:
                try:
                    trig = c.wait_trigger(timeout=30.0)
                except DeviceTimeoutError:
                    break
                if trig.pressed:
                    t0 = time.perf_counter()
                    c.info()
                    rtts.append(time.perf_counter() - t0)
        sim.wait(30)
    finally:
        if sim.poll() is None:
            sim.kill()
    return {
        "requests": len(rtts),
        "median_ms": ms(statistics.median(rtts)),
        "p90_ms": ms(sorted(rtts)[int(0.9 * (len(rtts) - 1))]),
        "max_ms": ms(max(rtts)),
    }


def main() -> None:
    load1, load5, _ = os.getloadavg()
    emit(
        bench="machine",
        what="the conditions of this run (wall-clock figures scale with the load)",
        cpus=os.cpu_count(),
        loadavg_1min=round(load1, 2),
        loadavg_5min=round(load5, 2),
    )
    with tempfile.TemporaryDirectory(prefix="aacmm-bench-capture-") as tmp:
        folder = Path(tmp) / "scenario"
        folder.mkdir()
        plan = "kinematic-calibration"
        sim, url = start_sim(folder, "--scenario", plan, "--truth", "random:7", "--fast")
        try:
            wall, points = capture(folder, plan, url)
            sim.wait(30)
        finally:
            if sim.poll() is None:
                sim.kill()
        emit(bench="capture.scenario", plan=plan, **figures(wall, points))

        folder = Path(tmp) / "paced"
        folder.mkdir()
        plan = "probe-calibration"
        sim, url = start_sim(folder, "--button-every", "0.1", "--quiet")
        try:
            wall, points = capture(folder, plan, url)
        finally:
            sim.terminate()
            sim.wait(30)
        emit(bench="capture.paced", plan=plan, button_every_s=0.1, **figures(wall, points))

        folder = Path(tmp) / "info"
        folder.mkdir()
        emit(
            bench="capture.info_rtt",
            plan="probe-calibration",
            **info_rtt(folder, "probe-calibration", 30),
        )


if __name__ == "__main__":
    main()
