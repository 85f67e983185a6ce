"""End-to-end tests of the ``aacmm`` command against the real simulator over a pty.

Every test runs the installed ``aacmm`` entry point as a subprocess and the
real ``aacmm-sim`` (``make sim``), and checks exit statuses, outputs and the
files written, including the failure cases: Ctrl-C, SIGTERM, kill -9 of the
logger, the device vanishing (with and without --reconnect), wrong port, busy
port, no answer, another protocol version and bad parameter files.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import threading
import time
import tomllib
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from aacmm.analysis.poselog import read_pose_log
from aacmm.commands import exitcodes
from aacmm.errors import AacmmError
from aacmm.protocol import (
    PROTOCOL_VERSION,
    Deframer,
    DeviceInfo,
    Message,
    MsgType,
    decode_message,
    encode_frame,
    encode_message,
)
from aacmm.records.schema import LOG_COLUMNS as COLUMNS
from aacmm.records.schema import TRIGGER_COLUMNS
from aacmm.simulation.process import SimProcess, find_simulator

pytestmark = pytest.mark.timeout(60)

AACMM = Path(sys.executable).with_name("aacmm")


def _sim_or_skip() -> None:
    try:
        find_simulator()
    except AacmmError as exc:
        pytest.fail(f"{exc} (the test-cli target builds it)")


def run(
    *args: str, timeout: float = 30, env: dict[str, str] | None = None, cwd: Path | None = None
) -> subprocess.CompletedProcess[str]:
    full_env = {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}
    full_env.update(env or {})
    return subprocess.run(
        [str(AACMM), *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=full_env,
        cwd=cwd,
    )


def one_error_line(p: subprocess.CompletedProcess[str], code: int, *words: str) -> None:
    """Exit status ``code``, exactly one line on stderr naming ``words``, no traceback."""
    assert p.returncode == code, (p.returncode, p.stdout, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    assert "Traceback" not in p.stderr
    assert lines[0].startswith("aacmm "), lines
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])


def wait_rows(proc: subprocess.Popen[str], path: Path, n: int, timeout: float = 15.0) -> None:
    """Wait until the logger ``proc`` has ``n`` rows in ``path``; fail at once, with
    its stderr, if it ends first."""
    end = time.monotonic() + timeout
    while csv_rows(path) < n:
        if proc.poll() is not None:
            err = proc.communicate()[1]
            raise AssertionError(f"the logger ended (exit {proc.returncode}): {err}")
        if time.monotonic() > end:
            raise AssertionError(f"{csv_rows(path)} of {n} rows after {timeout:g} s")
        time.sleep(0.05)


def csv_rows(path: Path) -> int:
    try:
        return max(0, path.read_text().count("\n") - 1)
    except FileNotFoundError:
        return 0


def start_log(*args: str) -> subprocess.Popen[str]:
    env = {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}
    return subprocess.Popen(
        [str(AACMM), "log", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def check_log(csv_path: Path, complete: bool = True) -> tuple[list[list[str]], dict[str, object]]:
    """Every line of the CSV is a whole row; the sidecar is valid; poselog reads it."""
    text = csv_path.read_text()
    assert text.endswith("\n")
    rows = list(csv.reader(text.splitlines()))
    assert tuple(rows[0]) == COLUMNS
    for r in rows[1:]:
        assert len(r) == len(COLUMNS), r
        [int(v) for v in r[0:2] + r[3:9] + r[12:13]]
        [float(v) for v in r[2:3] + r[9:12]]
    meta = json.loads(csv_path.with_name(csv_path.name + ".json").read_text())
    assert meta["format"] == "aacmm-log-2"
    assert meta["encoders"]["counts_per_rev"] == [1 << 32] * 6
    assert set(meta["params"]) == {"theta_offset_rad", "alpha_rad", "d_mm", "a_mm", "l_mm"}
    assert isinstance(meta["param_crc32"], int)
    assert meta["device"]["protocol_version"] == PROTOCOL_VERSION
    assert meta["start_time"]
    if complete:
        assert meta["end_time"] and meta["samples"] == len(rows) - 1
        assert isinstance(meta["lost_samples"], int)
    log = read_pose_log(csv_path)
    assert log.theta_rad.shape == (len(rows) - 1, 6)
    assert log.sidecar is not None
    return rows[1:], meta


@pytest.fixture(scope="module")
def sim() -> Iterator[SimProcess]:
    _sim_or_skip()
    with SimProcess(["--serial", "pty", "--quiet", "--button-every", "0.3", "--seed", "3"]) as s:
        yield s


@pytest.fixture
def fresh_sim(tmp_path: Path) -> Iterator[SimProcess]:
    _sim_or_skip()
    with SimProcess(["--serial", "pty", "--quiet"], link=tmp_path / "arm") as s:
        yield s


# ---------------------------------------------------------------- device commands


def test_info_measure_compute(sim: SimProcess) -> None:
    p = run("info", "--json", "--port", sim.url)
    assert p.returncode == 0, p.stderr
    info = json.loads(p.stdout)
    assert info["protocol_version"] == PROTOCOL_VERSION
    assert info["serial_number"] == 1 and info["param_crc32_hex"].startswith("0x")
    p = run("info", env={"AACMM_PORT": sim.url})  # the environment default
    assert p.returncode == 0 and f"protocol {PROTOCOL_VERSION}" in p.stdout, p.stderr
    assert "arm model   6 joints, 25 parameters" in p.stdout

    p = run("measure", "--jacobian", "--json", "--port", sim.url)
    assert p.returncode == 0, p.stderr
    m = json.loads(p.stdout)
    assert len(m["counts"]) == 6 and len(m["point_mm"]) == 3
    assert "POINT_VALID" in m["flag_names"]
    assert len(m["jacobian"]) == 3 and len(m["jacobian"][0]) == 25

    p = run("compute", *map(str, m["counts"]), "--json", "-j", "--port", sim.url)
    assert p.returncode == 0, p.stderr
    c = json.loads(p.stdout)
    # the device computes the point of the counts it measured (float core: ~1e-3 mm)
    assert all(abs(a - b) < 0.01 for a, b in zip(c["point_mm"], m["point_mm"], strict=True))
    assert len(c["jacobian"]) == 3
    p = run("compute", "0", "0", "0", "0", "0", "0", "--port", sim.url)
    assert p.returncode == 0 and "point" in p.stdout
    p = run("compute", "1", "2", "3", "--port", sim.url)
    assert p.returncode == 2 and "Traceback" not in p.stderr


def test_params_get_set_save_defaults(sim: SimProcess, tmp_path: Path) -> None:
    toml_file = tmp_path / "p.toml"
    p = run("params", "get", "-o", str(toml_file), "--port", sim.url)
    assert p.returncode == 0, p.stderr
    data = tomllib.loads(toml_file.read_text())
    assert data["l_mm"] == 183.5 and data["counts_per_rev"] == [1 << 32] * 6
    crc0 = data["param_crc32"]

    data["l_mm"] = 200.25
    data["zero_offset_counts"] = [1, 2, 3, 4, 5, 6]
    changed = tmp_path / "changed.json"
    changed.write_text(json.dumps(data))
    p = run("params", "set", str(changed), "--port", sim.url)
    assert p.returncode == 0, p.stderr
    assert "read back and identical" in p.stdout
    p = run("params", "get", "--format", "json", "--port", sim.url)
    got = json.loads(p.stdout)
    assert got["l_mm"] == 200.25 and got["zero_offset_counts"] == [1, 2, 3, 4, 5, 6]
    assert got["param_crc32"] != crc0

    p = run("params", "save", "--port", sim.url)
    assert p.returncode == 0 and "saved" in p.stdout, p.stderr
    p = run("params", "defaults", "--port", sim.url)
    assert p.returncode == 0 and f"0x{crc0:08x}" in p.stdout, p.stderr
    p = run("info", "--json", "--port", sim.url)
    assert json.loads(p.stdout)["param_crc32"] == crc0
    p = run("params", "set", str(changed), "--check")  # no device needed
    assert p.returncode == 0 and "valid" in p.stdout


def test_params_three_states_and_storage_report(tmp_path: Path) -> None:
    """#14.1: defaults / set, not saved / stored, in text and JSON; `params set`
    without --save says the set is lost at restart; `params save` warns about a
    store that does not survive power-off; info shows the storage slots."""
    _sim_or_skip()
    store = tmp_path / "arm.bin"
    with SimProcess(["--serial", "pty", "--quiet", "--storage", str(store)]) as s:
        info = json.loads(run("info", "--json", "--port", s.url).stdout)
        assert info["param_source_name"] == "defaults"
        diag = info["diagnostics"]
        assert diag["storage_kind_name"] == "file" and diag["storage_persistent"] is True
        assert diag["slot_state_names"] == ["erased", "erased"]
        assert diag["reset_cause_name"] == "power_on"
        data = tomllib.loads(run("params", "get", "--port", s.url).stdout)
        data["l_mm"] = 190.0
        pfile = tmp_path / "p.json"
        pfile.write_text(json.dumps(data))
        p = run("params", "set", str(pfile), "--port", s.url)
        assert p.returncode == 0, p.stderr
        assert "NOT saved: lost at restart" in p.stdout
        info = json.loads(run("info", "--json", "--port", s.url).stdout)
        assert info["param_source_name"] == "host"
        assert info["storage_state_name"] == "empty"
        text = run("info", "--port", s.url).stdout
        assert "set by the host, not saved: lost at restart" in text
        assert "from storage" not in text
        p = run("params", "save", "--port", s.url)
        assert p.returncode == 0 and p.stderr == "", p.stderr  # a file is persistent
        info = json.loads(run("info", "--json", "--port", s.url).stdout)
        assert info["param_source_name"] == "storage"
        assert info["diagnostics"]["slot_state_names"] == ["newest", "erased"]
        p = run("params", "set", str(pfile), "--port", s.url)
        assert "identical to the stored set" in p.stdout
        text = run("info", "--port", s.url).stdout
        assert "slot 0: newest record (generation 1); slot 1: erased" in text
        p = run("params", "defaults", "--port", s.url)
        assert "not saved: a restart loads the stored set" in p.stdout
    # RAM only: saving works but warns, and info says so
    with SimProcess(["--serial", "pty", "--quiet"]) as s:
        p = run("params", "save", "--port", s.url)
        assert p.returncode == 0, p.stderr
        assert "will not survive a power cycle" in p.stderr
        text = run("info", "--port", s.url).stdout
        assert "RAM (lost at every restart)" in text
        assert "the stored set (a restart loads it), but the store is lost at power-off" in text


BAD_PARAM_FILES = {
    "syntax.toml": ("l_mm = [", "not valid TOML"),
    "syntax.json": ("{", "not valid JSON"),
    "missing.toml": ("l_mm = 1.0\n", "missing"),
    "unknown.json": (None, "unknown key"),
    "angle.json": (None, "alpha_rad[0]"),
    "direction.json": (None, "direction[2]"),
    "zero.json": (None, "zero_offset_counts[1]"),
    "type.json": (None, "d_mm[0]"),
    "params.yaml": ("x: 1", "unknown format"),
    "absent.toml": (None, "cannot read"),
}


@pytest.mark.parametrize("name", sorted(BAD_PARAM_FILES))
def test_bad_parameter_files(sim: SimProcess, tmp_path: Path, name: str) -> None:
    good = json.loads(run("params", "get", "--format", "json", "--port", sim.url).stdout)
    crc_before = good["param_crc32"]
    text, words = BAD_PARAM_FILES[name]
    bad = dict(good)
    if name == "unknown.json":
        bad["l_mn"] = 1.0
    elif name == "angle.json":
        bad["alpha_rad"] = [7.0, *good["alpha_rad"][1:]]
    elif name == "direction.json":
        bad["direction"] = [1, 1, 0, 1, 1, 1]
    elif name == "zero.json":
        bad["counts_per_rev"] = [1000] * 6
        bad["zero_offset_counts"] = [0, 1000, 0, 0, 0, 0]
    elif name == "type.json":
        bad["d_mm"] = ["300", *good["d_mm"][1:]]
    path = tmp_path / name
    if name != "absent.toml":
        path.write_text(text if text is not None else json.dumps(bad))
    p = run("params", "set", str(path), "--port", sim.url)
    one_error_line(p, exitcodes.USAGE, name, words)
    after = json.loads(run("info", "--json", "--port", sim.url).stdout)
    assert after["param_crc32"] == crc_before  # nothing was sent


def test_device_error_is_status_1(tmp_path: Path) -> None:
    _sim_or_skip()
    with SimProcess(["--serial", "pty", "--quiet", "--encoder-bits", "16"]) as s:
        p = run("compute", "70000", "0", "0", "0", "0", "0", "--port", s.url)
        one_error_line(p, exitcodes.DEVICE, "ERR_RANGE")


# ---------------------------------------------------------------- logging


def test_log_count_files_and_mc(sim: SimProcess, tmp_path: Path) -> None:
    out = tmp_path / "run.csv"
    p = run("log", str(out), "--port", sim.url, "-r", "500", "-n", "600")
    assert p.returncode == 0, p.stderr
    assert "samples 600" in p.stdout and "extent x" in p.stdout
    assert "\r" not in p.stderr  # no status line off a terminal
    rows, meta = check_log(out)
    assert len(rows) == 600
    assert meta["status"] == "complete" and meta["end_reason"] == "count"
    assert meta["rate_hz"] == 500 and meta["reconnects"] == 0 and meta["gaps"] == []
    seqs = [int(r[0]) for r in rows]
    assert seqs == sorted(seqs)
    assert meta["lost_samples"] == seqs[-1] - seqs[0] + 1 - len(seqs)
    # probe button every 0.3 s: its captures in their own file
    trig = tmp_path / "run.triggers.csv"
    trows = list(csv.reader(trig.read_text().splitlines()))
    assert tuple(trows[0]) == TRIGGER_COLUMNS and len(trows) > 2
    assert {r[4] for r in trows[1:]} <= {"0", "1"} and meta["triggers"] == len(trows) - 1
    # the Monte Carlo analysis reads the log and its sidecar
    p = run("mc", "--log", str(out), "--json", str(tmp_path / "mc.json"))
    assert p.returncode == 0, p.stderr
    p = run("summary", str(out), "--json")
    s = json.loads(p.stdout)
    assert s["samples"] == 600 and s["status"] == "complete" and s["extent_mm"]["x"]["size"] > 0
    # an existing log is not overwritten without --force
    p = run("log", str(out), "--port", sim.url, "-n", "5")
    one_error_line(p, exitcodes.USAGE, "exists", "--force")
    p = run("log", str(out), "--port", sim.url, "-n", "5", "--force", "-q", "--no-triggers")
    assert p.returncode == 0 and p.stdout == "", p.stderr
    assert len(check_log(out)[0]) == 5


@pytest.mark.parametrize(
    ("sig", "limit", "code", "status"),
    [
        (signal.SIGINT, [], 0, "complete"),
        (signal.SIGTERM, [], 0, "complete"),
        (signal.SIGTERM, ["-d", "60"], exitcodes.INTERRUPTED, "interrupted"),
    ],
)
def test_log_stopped_by_signal(
    sim: SimProcess, tmp_path: Path, sig: int, limit: list[str], code: int, status: str
) -> None:
    out = tmp_path / "sig.csv"
    proc = start_log(str(out), "--port", sim.url, "-r", "200", *limit)
    try:
        wait_rows(proc, out, 60)
        proc.send_signal(sig)
        _stdout, stderr = proc.communicate(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == code, stderr
    assert "Traceback" not in stderr
    rows, meta = check_log(out)
    assert meta["status"] == status
    assert meta["end_reason"] == ("SIGINT" if sig == signal.SIGINT else "SIGTERM")
    assert len(rows) >= 60


def test_log_duration(sim: SimProcess, tmp_path: Path) -> None:
    out = tmp_path / "dur.csv"
    t0 = time.monotonic()
    p = run("log", str(out), "--port", sim.url, "-r", "1000", "-d", "1.5")
    assert p.returncode == 0, p.stderr
    assert time.monotonic() - t0 < 10
    rows, meta = check_log(out)
    assert meta["end_reason"] == "duration"
    assert 500 < len(rows) + meta["lost_samples"] <= 1600  # type: ignore[operator]


def test_log_killed_with_sigkill_is_parseable(fresh_sim: SimProcess, tmp_path: Path) -> None:
    out = tmp_path / "k9.csv"
    proc = start_log(str(out), "--port", fresh_sim.url, "-r", "1000")
    try:
        wait_rows(proc, out, 700)
        proc.kill()
        proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGKILL
    rows, meta = check_log(out, complete=False)  # every line whole, poselog reads it
    assert len(rows) >= 700
    assert meta["status"] == "running"  # the sidecar written at the start
    p = run("summary", str(out))
    assert p.returncode == 0 and f"samples {len(rows)}" in p.stdout, p.stderr
    # the device still streams into the pty nobody reads: the next command copes
    p = run("info", "--port", fresh_sim.url)
    assert p.returncode == 0, p.stderr
    p = run("log", str(tmp_path / "next.csv"), "--port", fresh_sim.url, "-n", "50", "-r", "500")
    assert p.returncode == 0, p.stderr


def test_log_device_vanishes(fresh_sim: SimProcess, tmp_path: Path) -> None:
    out = tmp_path / "gone.csv"
    proc = start_log(str(out), "--port", fresh_sim.url, "-r", "200")
    try:
        wait_rows(proc, out, 50)
        fresh_sim.kill()
        _stdout, stderr = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == exitcodes.LINK_LOST, stderr
    assert "Traceback" not in stderr
    err = [ln for ln in stderr.splitlines() if "error" in ln]
    assert len(err) == 1 and "link lost" in err[0] and "kept in" in err[0], stderr
    rows, meta = check_log(out)
    assert meta["status"] == "link_lost" and len(rows) >= 50


def test_log_reconnects_after_restart(tmp_path: Path) -> None:
    _sim_or_skip()
    link = tmp_path / "arm"
    out = tmp_path / "again.csv"
    sim1 = SimProcess(["--serial", "pty", "--quiet"], link=link)
    sim2: SimProcess | None = None
    proc = start_log(str(out), "--port", f"serial://{link}", "-r", "200", "--reconnect")
    try:
        wait_rows(proc, out, 50)
        sim1.kill()
        n_before = csv_rows(out)
        time.sleep(1.0)
        sim2 = SimProcess(["--serial", "pty", "--quiet"], link=link)
        wait_rows(proc, out, n_before + 100, timeout=20)
        proc.send_signal(signal.SIGINT)
        _stdout, stderr = proc.communicate(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
        sim1.stop()
        if sim2 is not None:
            sim2.stop()
    assert proc.returncode == 0, stderr
    assert "reconnected" in stderr and "Traceback" not in stderr
    rows, meta = check_log(out)
    assert meta["reconnects"] == 1 and meta["status"] == "incomplete"  # a bridged gap (#14.2)
    gaps = meta["gaps"]
    assert isinstance(gaps, list) and len(gaps) == 1
    gap = gaps[0]
    assert gap["end_time"] and gap["duration_s"] > 0.5
    assert 0 < gap["after_row"] < len(rows)
    # the new device counts from 0 again: the gap shows in the sequence numbers too
    assert int(rows[gap["after_row"]][0]) < int(rows[gap["after_row"] - 1][0])


def test_log_reconnect_gives_up(fresh_sim: SimProcess, tmp_path: Path) -> None:
    """The device and its port name vanish; another device opens meanwhile (it
    usually gets the pty number just freed): the logger must not reconnect to it."""
    out = tmp_path / "giveup.csv"
    proc = start_log(str(out), "--port", fresh_sim.url, "--reconnect", "--reconnect-timeout", "1.5")
    try:
        wait_rows(proc, out, 20)
        fresh_sim.kill()
        assert fresh_sim.link is not None and not os.path.lexists(fresh_sim.link)
        with SimProcess(["--serial", "pty", "--quiet"]):
            _stdout, stderr = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == exitcodes.LINK_LOST, stderr
    _, meta = check_log(out)
    assert meta["status"] == "link_lost" and meta["gaps"][0]["gave_up"] is True  # type: ignore[index]


def test_log_reconnect_takes_only_its_own_device(tmp_path: Path) -> None:
    """Another device answering at the port while the logger waits (another arm
    plugged in) is not taken: one warning, and the logger waits on for its own."""
    _sim_or_skip()
    link = tmp_path / "arm"
    out = tmp_path / "own.csv"
    own = SimProcess(["--serial", "pty", "--quiet", "--serial-number", "7"], link=link)
    url = f"serial://{link}"
    proc = start_log(str(out), "--port", url, "--reconnect", "--reconnect-timeout", "3")
    try:
        wait_rows(proc, out, 20)
        own.kill()
        with SimProcess(["--serial", "pty", "--quiet", "--serial-number", "8"], link=link):
            _stdout, stderr = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
        own.stop()
    assert proc.returncode == exitcodes.LINK_LOST, stderr
    warned = [ln for ln in stderr.splitlines() if "another device" in ln]
    assert len(warned) == 1 and "serial 8; this log's is 7" in warned[0], stderr
    _, meta = check_log(out)
    gap = meta["gaps"][0]  # type: ignore[index]
    assert gap["gave_up"] is True and "another device" in gap["last_error"]
    assert meta["reconnects"] == 0


def test_live_status_line_on_a_terminal(sim: SimProcess, tmp_path: Path) -> None:
    master, slave = os.openpty()
    out = tmp_path / "tty.csv"
    seen = bytearray()

    def reader() -> None:
        while True:
            try:
                chunk = os.read(master, 4096)
            except OSError:
                return
            if not chunk:
                return
            seen.extend(chunk)

    t = threading.Thread(target=reader, daemon=True)
    t.start()
    try:
        p = subprocess.run(
            [str(AACMM), "log", str(out), "--port", sim.url, "-r", "200", "-d", "1.2"],
            stdout=subprocess.PIPE,
            stderr=slave,
            text=True,
            timeout=30,
        )
        os.close(slave)
        t.join(5)
    finally:
        os.close(master)
    text = seen.decode(errors="replace")
    assert p.returncode == 0, text
    assert "samples" in text and "lost" in text and "\r" in text  # the live line
    assert "samples" in p.stdout  # the summary stays on stdout


# ---------------------------------------------------------------- failures to connect


def test_wrong_port_and_bad_urls(tmp_path: Path) -> None:
    one_error_line(run("info", "--port", "/dev/ttyNOPE0"), exitcodes.PORT, "/dev/ttyNOPE0")
    one_error_line(run("log", str(tmp_path / "x.csv"), "--port", "/dev/null"), exitcodes.PORT)
    one_error_line(run("info", "--port", "serial:///dev/x?speed=1"), exitcodes.USAGE, "URL")
    one_error_line(run("info", "--port", "bogus://x"), exitcodes.USAGE, "URL")
    one_error_line(run("measure"), exitcodes.USAGE, "AACMM_PORT")
    assert not (tmp_path / "x.csv").exists()


def test_busy_port(sim: SimProcess, tmp_path: Path) -> None:
    out = tmp_path / "busy.csv"
    proc = start_log(str(out), "--port", sim.url, "-r", "100")
    try:
        wait_rows(proc, out, 5)
        one_error_line(run("info", "--port", sim.url), exitcodes.PORT, "busy")
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0
    assert run("info", "--port", sim.url).returncode == 0  # free again


class PtyPeer:
    """A device on a pty that answers each request with ``answer(request)`` (or nothing)."""

    def __init__(self, answer: Callable[[Message], bytes | None]) -> None:
        self.master, self.slave = os.openpty()
        self.path = os.ttyname(self.slave)
        self.answer = answer
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        import select

        deframer = Deframer()
        while not self._stop.is_set():
            r, _, _ = select.select([self.master], [], [], 0.05)
            if not r:
                continue
            try:
                data = os.read(self.master, 4096)
            except OSError:
                return
            for body in deframer.feed(data):
                reply = self.answer(decode_message(body))
                if reply is not None:
                    os.write(self.master, encode_frame(reply))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2)
        os.close(self.master)
        os.close(self.slave)


def _info(req: Message, version: int) -> bytes:
    info = DeviceInfo(version, 9, 0, 0, 0, 0, 0, 1, 512, 7, 1)
    return encode_message(Message(MsgType.INFO_RSP, req.seq, info))


@pytest.mark.parametrize(
    "answer",
    [
        # the device's frames carry another version byte (the host drops them)
        lambda req: bytes([PROTOCOL_VERSION + 1]) + _info(req, PROTOCOL_VERSION + 1)[1:],
        # a device that frames like us but reports another version in its info
        lambda req: _info(req, PROTOCOL_VERSION + 1),
    ],
    ids=["version-byte", "info-field"],
)
def test_other_protocol_version(answer: Callable[[Message], bytes]) -> None:
    peer = PtyPeer(answer)
    try:
        p = run("info", "--port", peer.path, "--timeout", "0.3", "--retries", "0")
    finally:
        peer.close()
    one_error_line(p, exitcodes.VERSION, "protocol version")


def test_no_answer() -> None:
    peer = PtyPeer(lambda req: None)
    try:
        p = run("measure", "--port", peer.path, "--timeout", "0.3", "--retries", "1")
    finally:
        peer.close()
    one_error_line(p, exitcodes.TIMEOUT, "no answer")


def test_raw_needs_can(sim: SimProcess, tmp_path: Path) -> None:
    p = run("log", str(tmp_path / "r.csv"), "--raw", str(tmp_path / "r.blf"), "--port", sim.url)
    one_error_line(p, exitcodes.USAGE, "--raw")


# ---------------------------------------------------------------- aacmm sim


def test_sim_command(tmp_path: Path) -> None:
    _sim_or_skip()
    link = tmp_path / "arm"
    proc = subprocess.Popen(
        [
            *(str(AACMM), "sim", "--link", str(link), "--quiet", "--motion", "static"),
            *("--encoder", "ssi-gray", "--encoder-bits", "20", "--encoder-faults", "1000000"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        url = proc.stdout.readline().strip()
        assert url == f"serial://{link}"
        p = run("measure", "--json", "--port", url)
        assert p.returncode == 0, p.stderr
        joints = json.loads(run("info", "--json", "--port", url).stdout)["diagnostics"]["joints"]
        assert {(j["interface_name"], j["bits"]) for j in joints} == {("ssi_gray", 20)}
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0
    assert not link.exists()  # removed on exit
    p = run("sim", "--node", "99")  # the simulator refuses it (and prints its usage)
    assert p.returncode == exitcodes.USAGE and "Traceback" not in p.stderr
    assert p.stderr.strip().splitlines()[-1].startswith("aacmm sim: error:")
    p = run("sim", env={"AACMM_SIM": str(tmp_path / "nope")})
    one_error_line(p, exitcodes.PORT, "AACMM_SIM")


def test_sim_board_command() -> None:
    """`aacmm sim --board` runs the device firmware on an emulated Cortex-M4F and
    prints a URL the other commands take."""
    proc = subprocess.Popen(
        [str(AACMM), "sim", "--board", "mps2-an386"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        url = proc.stdout.readline().strip()
        assert url.startswith("socket://127.0.0.1:"), url
        p = run("info", "--json", "--port", url, timeout=60)
        assert p.returncode == 0, p.stderr
        assert json.loads(p.stdout)["build_flags"] is not None
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0
    p = run("sim", "--board", "pdp11")
    one_error_line(p, exitcodes.USAGE, "unknown board")
    p = run("sim", "--board", "microbit", "--motion", "static")
    one_error_line(p, exitcodes.USAGE, "--board")
