"""The live view's cost and its page's latency; one JSON object per line on stdout.

``aacmm view --port URL --rate 1000`` against the simulator (``aacmm sim``,
random walk), a 1 kHz device stream; the page open in Debian's headless
Chromium (Playwright, tests/host/viewbrowser.py).

* ``view.cpu``: the view process's CPU (all threads, /proc/PID/stat) over
  ``seconds`` of steady streaming, as a share of one core (goal <= 10 %), with
  no page and with one page open, at 1 kHz and at the default 200 Hz;
  ``frames_made_per_s`` the frames the feed made (``--fps``; goal >= 30),
  ``frames_sent_per_s`` those the page took (one batch in flight: a page that
  draws slowly takes fewer, each the newest sample).
* ``view.client_baseline``: the same stream read by ``aacmm.client`` alone, in a
  process that does nothing else (drains its queue every 5 ms as the view does):
  the part of ``view.cpu`` that is the client's receive path, not the view.
* ``view.latency``: per frame the page drew, from the host reading the sample to
  the page having drawn it (p50, p95 (goal <= 100 ms), max); ``frames_per_s``
  received and ``draws_per_s`` drawn by the page; ``draw_js_p50_ms`` the part of
  a draw in plotly's JavaScript (``Plotly.restyle``), the rest being WebGL and
  compositing; ``sample_to_page_*``: from the host reading the sample to the
  page receiving its frame (the server's and the socket's share). The page draws with WebGL,
  here on SwiftShader (no GPU): drawing is most of the latency, and the page
  skips to the newest frame when it falls behind, so the latency stays bounded.

``machine`` gives the load the figures were taken under.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from benchjson import emit

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "host"))
AACMM = Path(sys.executable).with_name("aacmm")
SECONDS = float(os.environ.get("BENCH_VIEW_SECONDS", "10"))
TICK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK  # utime + stime


def start(*args: str) -> tuple[subprocess.Popen[str], str]:
    p = subprocess.Popen(
        [str(AACMM), *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env={k: v for k, v in os.environ.items() if k != "AACMM_PORT"},
    )
    assert p.stdout is not None
    line = p.stdout.readline().strip()
    if not line:
        p.kill()
        raise SystemExit(f"bench-view: aacmm {' '.join(args)} printed nothing")
    return p, line


def stop(p: subprocess.Popen[str]) -> None:
    if p.poll() is None:
        p.send_signal(signal.SIGINT)
        try:
            p.wait(15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def measure_cpu(pid: int, seconds: float) -> tuple[float, float]:
    c0, t0 = cpu_s(pid), time.monotonic()
    time.sleep(seconds)
    return cpu_s(pid) - c0, time.monotonic() - t0


def client_baseline(url: str, rate: int, seconds: float) -> float:
    """CPU share (%) of a process that only reads the stream with aacmm.client."""
    code = (
        "import sys, time\n"
        "from aacmm.client import connect\n"
        "from aacmm.errors import DeviceTimeoutError\n"
        "with connect(sys.argv[1]) as c, c.stream(int(sys.argv[2])) as st:\n"
        "    time.sleep(1.0)\n"
        "    t0, c0 = time.monotonic(), time.process_time()\n"
        "    while time.monotonic() - t0 < float(sys.argv[3]):\n"
        "        time.sleep(0.005)\n"
        "        try:\n"
        "            while True: st.get(timeout=0.0)\n"
        "        except DeviceTimeoutError: pass\n"
        "    print(100 * (time.process_time() - c0) / (time.monotonic() - t0))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, url, str(rate), str(seconds)],
        capture_output=True, text=True, timeout=seconds + 30, check=True,
    )  # fmt: skip
    return float(out.stdout.strip())


def main() -> None:
    from viewbrowser import Watched, launch, playwright

    load1, load5, _ = os.getloadavg()
    emit(bench="machine", cpus=os.cpu_count(), loadavg_1min=round(load1, 2),
         loadavg_5min=round(load5, 2))  # fmt: skip
    with playwright() as pw:
        browser = launch(pw)
        sim, url = start("sim", "--motion", "walk")
        view = None
        try:
            for rate in (1000, 200):
                pct = client_baseline(url, rate, SECONDS)
                emit(bench="view.client_baseline", rate_hz=rate, seconds=SECONDS,
                     cpu_percent_of_core=round(pct, 2))  # fmt: skip
            view, page_url = start("view", "--port", url, "--bind", "127.0.0.1:0")
            time.sleep(2.0)
            cpu, wall = measure_cpu(view.pid, SECONDS)
            emit(bench="view.cpu", rate_hz=200, pages=0, seconds=round(wall, 1),
                 cpu_percent_of_core=round(100 * cpu / wall, 2), goal_percent=10)  # fmt: skip
            stop(view)
            view, page_url = start("view", "--port", url, "--rate", "1000", "--bind",
                                   "127.0.0.1:0")  # fmt: skip
            time.sleep(2.0)
            cpu, wall = measure_cpu(view.pid, SECONDS)
            emit(bench="view.cpu", rate_hz=1000, pages=0, seconds=round(wall, 1),
                 cpu_percent_of_core=round(100 * cpu / wall, 2), goal_percent=10)  # fmt: skip
            w = Watched(browser, page_url).open(page_url)
            time.sleep(2.0)
            before: dict[str, Any] = w.state(
                "{frames: s.frames, renders: s.renders, made: s.lastFrame.frame}"
            )
            cpu, wall = measure_cpu(view.pid, SECONDS)
            after: dict[str, Any] = w.state(
                "{frames: s.frames, renders: s.renders, lat: s.latencies, js: s.drawJs, "
                "hist: s.history, made: s.lastFrame.frame}"
            )
            n_draws = after["renders"] - before["renders"]
            lat = np.array(after["lat"][-n_draws:]) if n_draws > 0 else np.array([np.nan])
            js = np.array(after["js"][-n_draws:]) if n_draws > 0 else np.array([np.nan])
            n_frames = after["frames"] - before["frames"]
            hist = after["hist"][-n_frames:]
            wire = np.array([h["recv_ms"] - h["host_ms"] for h in hist] or [np.nan])
            emit(bench="view.cpu", rate_hz=1000, pages=1, seconds=round(wall, 1),
                 cpu_percent_of_core=round(100 * cpu / wall, 2), goal_percent=10,
                 frames_made_per_s=round((after["made"] - before["made"]) / wall, 1),
                 frames_sent_per_s=round((after["frames"] - before["frames"]) / wall, 1),
                 )  # fmt: skip
            emit(bench="view.latency", rate_hz=1000, draws=int(n_draws),
                 p50_ms=round(float(np.percentile(lat, 50)), 1),
                 p95_ms=round(float(np.percentile(lat, 95)), 1),
                 max_ms=round(float(lat.max()), 1), goal_p95_ms=100,
                 frames_per_s=round((after["frames"] - before["frames"]) / wall, 1),
                 draws_per_s=round(n_draws / wall, 1),
                 draw_js_p50_ms=round(float(np.percentile(js, 50)), 1),
                 sample_to_page_p50_ms=round(float(np.percentile(wire, 50)), 1),
                 sample_to_page_p95_ms=round(float(np.percentile(wire, 95)), 1),
                 viewport=f"{w.page.viewport_size['width']}x{w.page.viewport_size['height']}",
                 webgl="SwiftShader (software)")  # fmt: skip
            w.clean()
        finally:
            if view is not None:
                stop(view)
            stop(sim)
            browser.close()


if __name__ == "__main__":
    main()
