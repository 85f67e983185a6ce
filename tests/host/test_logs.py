"""Logs through aacmm.records against the real simulator: a new stream holds only its own
samples (#15.1), the parameter set in force per row across a reconnect (#15.5), a logger
that lost samples does not call its run complete (#14.2), the rate while connected and the
gaps (#14.7), and ``capture --from-log``."""

from __future__ import annotations

import json
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from aacmm.plans import load_plan
from aacmm.records import read_session
from aacmm.records.logs import read_log, read_triggers
from aacmm.records.schema import LOG_COLUMNS
from aacmm.simulation.process import SimProcess
from clihelp import AACMM, cli_env, one_error_line, run

pytestmark = pytest.mark.timeout(180)


def start(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [str(AACMM), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=cli_env(),
    )


def wait_rows(csv: Path, n: int, timeout: float = 20.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if csv.exists() and csv.read_text().count("\n") > n:
            return
        time.sleep(0.05)
    raise AssertionError(f"{csv}: fewer than {n} rows after {timeout} s")


def test_new_stream_holds_only_its_own_samples(tmp_path: Path) -> None:
    """#15.1 repro, 20 times as reported (it failed 1-3 times in 30 before the fix): kill -9
    a 1 kHz logger, start another on the same port: its rows are its own stream's,
    seq 0, 1, 2, ... and exactly --count of them."""
    with SimProcess(["--serial", "pty", "--quiet"]) as sim:
        for i in range(20):
            old = start("log", str(tmp_path / f"old{i}.csv"), "-r", "1000", "-q", "-p", sim.url)
            wait_rows(tmp_path / f"old{i}.csv", 300)
            old.send_signal(signal.SIGKILL)
            old.communicate()
            new = tmp_path / f"new{i}.csv"
            p = run("log", str(new), "-r", "1000", "-n", "2000", "-q", "-p", sim.url)
            assert p.returncode == 0, p.stderr
            log = read_log(new)
            seq = log.column("seq", "int")
            assert seq.tolist() == list(range(2000)), (i, seq[:5].tolist())
            assert json.loads((tmp_path / f"new{i}.csv.json").read_text())["status"] == "complete"


def test_log_format_and_reader(tmp_path: Path) -> None:
    with SimProcess(["--serial", "pty", "--quiet", "--button-every", "0.1"]) as sim:
        out = tmp_path / "run.csv"
        p = run("log", str(out), "-r", "200", "-d", "2.6", "-p", sim.url)
        assert p.returncode == 0, p.stderr
    header = out.read_text().splitlines()[0].split(",")
    assert tuple(header) == LOG_COLUMNS
    log = read_log(out)
    meta = log.meta
    assert meta["format"] == "aacmm-log-2" and meta["status"] == "complete"
    assert [d["first_row"] for d in meta["param_sets"]] == [0]
    assert len(log.param_sets) == 1 and log.set_changes() == [(0, meta["param_crc32"])]
    dev = np.column_stack([log.column(c) for c in ("x_mm", "y_mm", "z_mm")])
    assert np.abs(log.points_mm() - dev).max() < 2e-3
    # the trigger file joins the sample file on seq and names the same set
    trig = read_triggers(log)
    assert trig and all(t.param_set.crc32 == meta["param_crc32"] for t in trig)
    seq = log.column("seq", "int").tolist()
    dev_t = dict(zip(seq, log.column("device_time_us", "int").tolist(), strict=True))
    joined = [t for t in trig if t.sample.seq in dev_t]
    assert len(joined) >= len(trig) - 1  # a press after the last sample has none to join
    for t in joined:  # the sample after the edge (#14.5), and never the trigger's own
        assert t.sample.timestamp_us <= dev_t[t.sample.seq]
        assert t.sample.status & 0x80  # TRIGGER_EVENT
    # --from-log labels the presses in plan order
    s_dir = tmp_path / "s"
    p = run("capture", "probe-calibration", "-o", str(s_dir), "--from-log", str(out))
    assert p.returncode == 0, p.stderr
    presses = [t for t in trig if t.pressed and t.button == 0]
    s = read_session(s_dir)
    n = min(30, len(presses))
    assert len(s) == n and s.meta["source"] == "from-log"
    assert [p.counts for p in s.points] == [t.sample.counts for t in presses[:n]]
    assert [p.slot for p in s.points] == [
        sl.index for sl in load_plan("probe-calibration").slots[:n]
    ]
    if n < 30:
        assert "continue with --resume" in p.stderr and s.status == "interrupted"


def test_lost_samples_make_the_run_incomplete(tmp_path: Path) -> None:
    """#14.2: the simulator frozen for 1.6 s at 1 kHz skips what it cannot catch up (> 1000
    samples): the
    logger counts the gap, says so, exits 1, and the sidecar says incomplete."""
    with SimProcess(["--serial", "pty", "--quiet"]) as sim:
        out = tmp_path / "run.csv"
        log = start("log", str(out), "-r", "1000", "-d", "4", "--stall", "3", "-p", sim.url)
        wait_rows(out, 100)
        sim.proc.send_signal(signal.SIGSTOP)
        time.sleep(1.6)
        sim.proc.send_signal(signal.SIGCONT)
        _, err = log.communicate(timeout=30)
    assert log.returncode == 1, err
    lines = err.strip().splitlines()
    assert lines[-1].startswith("aacmm log: error: ") and "samples lost" in lines[-1]
    meta = json.loads((tmp_path / "run.csv.json").read_text())
    assert meta["status"] == "incomplete" and meta["lost_samples"] > 0
    assert "samples lost" in meta["end_reason"]
    s = run("summary", str(out))
    assert s.returncode == 0 and "(incomplete)" in s.stdout


def test_reconnect_to_another_parameter_set(tmp_path: Path) -> None:
    """#15.5 and #14.7: a reconnect to a device with another set; every row is converted
    with its own set; mc --log (one set) refuses clearly; the summary gives the gap and
    the rate while connected."""
    store = tmp_path / "other.bin"
    params = tmp_path / "p.toml"
    with SimProcess(["--serial", "pty", "--quiet", "--storage", str(store)]) as sim:
        assert run("params", "get", "-o", str(params), "-p", sim.url).returncode == 0
        params.write_text(params.read_text().replace("l_mm = 183.5", "l_mm = 150.0"))
        assert run("params", "set", str(params), "--save", "-p", sim.url).returncode == 0
    link = tmp_path / "arm"
    out = tmp_path / "run.csv"
    first = SimProcess(["--serial", "pty", "--quiet"], link=link)
    try:
        url = f"serial://{link}"
        logger = start("log", str(out), "-r", "100", "-d", "6", "--reconnect", "-p", url)
        wait_rows(out, 80)
    finally:
        first.stop()
    time.sleep(1.0)
    with SimProcess(["--serial", "pty", "--quiet", "--storage", str(store)], link=link):
        stdout, err = logger.communicate(timeout=30)
    assert logger.returncode == 0, err
    assert "parameter set changed" in err
    log = read_log(out)
    changes = log.set_changes()
    assert len(changes) == 2 and changes[1][0] == log.gaps[0]["after_row"]
    dev = np.column_stack([log.column(c) for c in ("x_mm", "y_mm", "z_mm")])
    assert np.abs(log.points_mm() - dev).max() < 2e-3  # each row with its own set
    assert log.param_sets[changes[1][1]].params.l_mm == 150.0
    meta = log.meta
    assert meta["status"] == "incomplete" and "reconnect gaps" in meta["end_reason"]
    # the rate while connected is the stream's, not samples over the wall time
    assert "Hz while connected; 1 gap: " in stdout
    s = run("summary", str(out), "--json")
    d = json.loads(s.stdout)
    assert d["gaps"] == 1 and 95 < d["rate_hz"] < 105
    assert d["samples"] / d["duration_s"] < 90  # what the old summary reported
    assert len(d["param_sets"]) == 2
    p = run("mc", "--log", str(out), "-q")
    one_error_line(p, 2, "parameter set changes at row", "mc --log")


def test_presses_crc_columns_and_damage_noticed(tmp_path: Path) -> None:
    """Issue 29.7: `log` reported "triggers 12" for 6 presses (a press and its release
    are two rows); both CSVs write param_crc32 the same way (0x + 8 hex digits, as the
    sidecar's param_crc32_hex). Issue 29.6: a log cut short, a NaN point and a session
    with fewer points than its sidecar says were summarised as sound."""
    import csv
    import re

    with SimProcess(["--serial", "pty", "--quiet", "--button-every", "0.25"]) as sim:
        out = tmp_path / "run.csv"
        p = run("log", str(out), "-r", "100", "-d", "2.2", "-p", sim.url)
        assert p.returncode == 0, p.stderr
    meta = json.loads((tmp_path / "run.csv.json").read_text())
    with (tmp_path / "run.triggers.csv").open() as f:
        trows = list(csv.DictReader(f))
    presses = sum(r["pressed"] == "1" for r in trows)
    assert presses >= 3 and meta["presses"] == presses and meta["triggers"] == len(trows)
    assert f"presses {presses} ({len(trows)} button edges)" in p.stdout
    s = run("summary", str(out))
    assert s.returncode == 0 and f"presses {presses} ({len(trows)} button edges)" in s.stdout
    with out.open() as f:
        rows = list(csv.DictReader(f))
    crcs = {r["param_crc32"] for r in rows} | {r["param_crc32"] for r in trows}
    assert crcs == {meta["param_crc32_hex"]} and re.fullmatch(r"0x[0-9a-f]{8}", crcs.pop())

    # a log cut short: the sidecar says more samples than the file holds
    lines = out.read_text().splitlines(keepends=True)
    cut = tmp_path / "cut.csv"
    cut.write_text("".join(lines[: len(lines) // 2]))
    (tmp_path / "cut.csv.json").write_text(
        json.dumps({**meta, "csv": "cut.csv", "triggers_csv": "run.triggers.csv"})
    )
    s = run("summary", str(cut))
    one_error_line(s, 2, "cut.csv: damaged", f"counts {meta['samples']} samples", "cut short")
    assert s.stdout.startswith(f"log {cut} (complete, damaged)")
    # a NaN point: one line naming the file, line and column
    nan = tmp_path / "nan.csv"
    bad = lines[4].split(",")
    bad[9] = "nan"
    nan.write_text("".join(lines[:4]) + ",".join(bad) + "".join(lines[5:]))
    (tmp_path / "nan.csv.json").write_text(json.dumps({**meta, "csv": "nan.csv"}))
    s = run("summary", str(nan))
    one_error_line(s, 2, f"{nan}:5: x_mm: 'nan' is not a finite number")
    assert "nan .." not in s.stdout

    # a session whose points.csv lost rows: closed "complete" with 2 of 30 points
    ses = tmp_path / "s"
    p = run("capture", "probe-calibration", "-o", str(ses), "--from-log", str(out))
    assert p.returncode == 0, p.stderr
    pts = (ses / "points.csv").read_text().splitlines(keepends=True)
    (ses / "points.csv").write_text("".join(pts[:3]))
    side = json.loads((ses / "session.json").read_text())
    side["status"] = "complete"
    (ses / "session.json").write_text(json.dumps(side))
    s = run("summary", str(ses))
    line = one_error_line(s, 2, f"{ses}: damaged", "status complete, but points.csv holds 2")
    assert f"counts {side['accepted']} accepted points" in line
    assert s.stdout.startswith(f"session {ses} (complete, damaged): 2 of 30 points")


def test_a_log_written_with_protocol_version_1_still_reads(tmp_path: Path) -> None:
    """Issue 26: logs written before protocol version 2 name their parameter set by
    version 1's CRC (over its 278-byte six-joint layout). Such a log (made here from
    a new one: every CRC in its CSV and sidecar replaced by the version 1 CRC,
    computed in the test from the sidecar's values) reads, with the same points; a
    set that matches neither CRC is still refused as edited."""
    import struct
    import zlib

    with SimProcess(["--serial", "pty", "--quiet", "--motion", "static"]) as sim:
        out = tmp_path / "run.csv"
        p = run("log", str(out), "-r", "100", "-d", "0.6", "-p", sim.url)
        assert p.returncode == 0, p.stderr
    new = read_log(out)
    side = tmp_path / "run.csv.json"
    meta = json.loads(side.read_text())
    (ps,) = meta["param_sets"]
    k, e = ps["params"], ps["encoders"]
    v1 = zlib.crc32(
        struct.pack(
            "<25d6Q6I6b",
            *k["theta_offset_rad"],
            *k["alpha_rad"],
            *k["d_mm"],
            *k["a_mm"],
            k["l_mm"],
            *e["counts_per_rev"],
            *e["zero_offset_counts"],
            *e["direction"],
        )
    )
    v2_hex, v1_hex = f"0x{ps['param_crc32']:08x}", f"0x{v1:08x}"
    assert v1_hex != v2_hex
    text = side.read_text().replace(str(ps["param_crc32"]), str(v1)).replace(v2_hex, v1_hex)
    side.write_text(text)
    for f in (out, tmp_path / "run.triggers.csv"):
        if f.exists():
            f.write_text(f.read_text().replace(v2_hex, v1_hex))
    old = read_log(out)
    assert [c for _, c in old.set_changes()] == [v1]
    assert np.array_equal(old.points_mm(), new.points_mm())
    # an edited set matches neither CRC
    side.write_text(text.replace('"l_mm": 183.5', '"l_mm": 183.6'))
    with pytest.raises(Exception, match="does not match its CRC"):
        read_log(out)


def write_log(path: Path, rows: list[dict[str, str]], meta: dict[str, object]) -> None:
    """A log of ``rows`` (csv.DictReader's) at ``path`` with the sidecar ``meta`` names it in."""
    import csv

    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    (path.parent / f"{path.name}.json").write_text(json.dumps({**meta, "csv": path.name}))


def test_summary_gives_the_link_temperature_range(tmp_path: Path) -> None:
    """Issue 27 left-out: ``aacmm summary`` reports the range of the link temperatures
    of a log and of a session, overall and per link, counted from the file's own
    columns here; the logger's own summary (sidecar) says the same; a temperature that
    is not one (inf) is one line naming the file and line."""
    import csv

    temps = "20,21.5,22,23,24.25,25"
    sim_args = ["--serial", "pty", "--quiet", "--temperature", temps, "--button-every", "0.05"]
    with SimProcess(sim_args) as sim:
        out = tmp_path / "run.csv"
        p = run("log", str(out), "-r", "100", "--count", "400", "-p", sim.url)
        assert p.returncode == 0, p.stderr
    meta = json.loads((tmp_path / "run.csv.json").read_text())
    want = [float(t) for t in temps.split(",")]
    assert meta["temperature_c"]["links"] == [{"min": t, "max": t} for t in want]
    assert "temperatures 20.00 .. 25.00 C (all links read at 400 of 400 samples;" in p.stdout

    # vary link 2 and leave link 6 unread on one row: the summary follows the file
    with out.open() as f:
        rows = list(csv.DictReader(f))
    rows[10]["temp2_c"], rows[20]["temp2_c"], rows[30]["temp6_c"] = "19.25", "26.75", ""
    edited = tmp_path / "edited.csv"
    write_log(edited, rows, meta)
    cols = [f"temp{j}_c" for j in range(1, 7)]
    table = np.array([[float(r[c]) if r[c] else np.nan for c in cols] for r in rows])
    s = run("summary", str(edited), "--json")
    assert s.returncode == 0, s.stderr
    got = json.loads(s.stdout)["temperature_c"]
    assert got["rows_read"] == 399 and (got["min"], got["max"]) == (19.25, 26.75)
    for j, link in enumerate(got["links"]):
        col = table[:, j][np.isfinite(table[:, j])]
        assert (link["min"], link["max"]) == (col.min(), col.max())
    s = run("summary", str(edited))
    assert (
        "temperatures 19.25 .. 26.75 C (all links read at 399 of 400 samples; link 1 20.00; "
        "link 2 19.25 .. 26.75; link 3 22.00" in s.stdout
    ), s.stdout

    # a session taken from the log reports the range of its points
    ses = tmp_path / "s"
    p = run("capture", "probe-calibration", "-o", str(ses), "--from-log", str(out))
    assert p.returncode == 0, p.stderr
    s = run("summary", str(ses))
    assert s.returncode == 0, s.stderr
    assert "temperatures 20.00 .. 25.00 C (all links read at 30 of 30 points; link 1 20.00;" in (
        s.stdout
    )

    # inf is not a temperature: one line, exit 2
    rows[5]["temp3_c"] = "inf"
    bad = tmp_path / "bad.csv"
    write_log(bad, rows, meta)
    s = run("summary", str(bad))
    one_error_line(s, 2, f"{bad}:7: temp3_c: 'inf' is not a temperature in degC")
