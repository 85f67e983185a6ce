"""The simulator's parameter storage file: an honest start-up report and safe saves (#15.7).

Every storage state gets its own start-up line on stderr (docs/simulator.md
lists them) and the same facts in the device diagnostics (`DIAG_RSP`): which
slot was loaded and why the other was not, a short or long file, a damaged
newest record that leaves an older set in use. Saves go to a fresh FILE.tmp
opened with O_EXCL | O_NOFOLLOW (a planted symlink is never followed, its
target never written), which is fsynced, renamed over FILE, and the directory
fsynced (checked with strace); a stale FILE.tmp left by a cut save is removed
at start-up with a message.
"""

from __future__ import annotations

import os
import random
import shutil
import signal
import struct
import subprocess
import time
import zlib
from dataclasses import replace
from pathlib import Path

import pytest
from aacmm.client import connect
from aacmm.errors import DeviceError
from aacmm.protocol import ParamSource, SlotState
from simproc import SIM_BIN, Sim

pytestmark = pytest.mark.timeout(120)

SLOT = 512
RECORD = 294


def stderr_line(sim: Sim, prefix: str, containing: str = "") -> str:
    """The simulator's first stderr line starting with prefix and containing
    ``containing`` (waits for the reader thread, which may lag the simulator)."""
    end = time.monotonic() + 5.0
    while time.monotonic() < end:
        for line in sim.stderr_lines:
            if line.startswith(prefix) and containing in line:
                return line
        time.sleep(0.02)
    raise AssertionError(f"no {prefix!r} line on stderr: {sim.stderr_lines}")


def startup_line(sim: Sim) -> str:
    return stderr_line(sim, "aacmm-sim: storage")


def run_sim(store: Path | None, *extra: str) -> Sim:
    args = ["--serial", "pty", "--motion", "static", *extra]
    if store is not None:
        args += ["--storage", str(store)]
    return Sim(*args)


def save_sets(store: Path, n: int) -> list[int]:
    """Save n different parameter sets; return their CRCs."""
    crcs = []
    with run_sim(store) as sim, connect(sim.serial_url) as c:
        base = c.get_params()
        for i in range(n):
            c.set_params(replace(base, l_mm=base.l_mm + 1.0 + i))
            crcs.append(c.save_params())
    return crcs


def test_startup_report_for_every_storage_state(tmp_path: Path) -> None:
    with run_sim(None) as sim:
        assert startup_line(sim) == (
            "aacmm-sim: storage: none given (--storage FILE): a saved set lives in RAM until exit"
        )
    store = tmp_path / "arm.bin"
    with run_sim(store) as sim:
        assert startup_line(sim).endswith(
            "no file yet (the first save creates it); running on defaults"
        )

    crcs = save_sets(store, 2)
    with run_sim(store) as sim, connect(sim.serial_url) as c:
        assert startup_line(sim).endswith(
            "loaded slot 1 (generation 2); slot 0: older record, the fallback (generation 1)"
        )
        assert c.info().param_crc32 == crcs[1]

    # The newest record damaged: the older set is loaded, and that is said.
    good = store.read_bytes()
    damaged = bytearray(good)
    damaged[SLOT + 100] ^= 0x01
    store.write_bytes(bytes(damaged))
    with run_sim(store) as sim, connect(sim.serial_url) as c:
        line = startup_line(sim)
        assert "loaded slot 0 (generation 1); slot 1: rejected: CRC mismatch" in line
        assert (
            "(generation 2): it was newer, so the set in use may be older than the last save"
            in line
        )
        info, diag = c.info(), c.diagnostics()
        assert diag is not None
        assert info.param_crc32 == crcs[0] and info.param_source == ParamSource.STORAGE
        assert diag.slot_state == (SlotState.NEWEST, SlotState.BAD_CRC)
        assert diag.slot_generation == (1, 2) and diag.storage_bad_records == 1

    # The magic of the newest record overwritten: counted and named, not "empty".
    damaged = bytearray(good)
    damaged[SLOT : SLOT + 4] = b"XXXX"
    store.write_bytes(bytes(damaged))
    with run_sim(store) as sim, connect(sim.serial_url) as c:
        assert "slot 1: rejected: not a record (unrecognised data)" in startup_line(sim)
        diag = c.diagnostics()
        assert diag is not None and diag.storage_bad_records == 1

    cases = {
        b"AACM": "4 bytes, expected 1024 (the rest reads as erased); "
        "slot 0: rejected: incomplete record (a save cut after it began); slot 1: erased; "
        "no valid record, running on defaults",
        random.Random(7).randbytes(1024): "slot 0: rejected: not a record (unrecognised data); "
        "slot 1: rejected: not a record (unrecognised data); no valid record, running on defaults",
        b"\xff" * 1024: "slot 0: erased; slot 1: erased; no valid record, running on defaults",
        b"": "0 bytes, expected 1024 (the rest reads as erased); slot 0: erased; slot 1: erased; "
        "no valid record, running on defaults",
        good + b"\x00" * 976: "2000 bytes, expected 1024 (the rest is ignored); loaded slot 1",
    }
    for content, want in cases.items():
        store.write_bytes(content)
        with run_sim(store) as sim:
            line = startup_line(sim)
            assert line.startswith(f"aacmm-sim: storage {store}: {want}"), (len(content), line)

    # A foreign format version and a record with a bad length field.
    damaged = bytearray(good)
    damaged[4:6] = struct.pack("<H", 7)
    damaged[SLOT + 6 : SLOT + 8] = struct.pack("<H", 200)
    struct.pack_into("<I", damaged, SLOT + 290, zlib.crc32(bytes(damaged[SLOT : SLOT + 290])))
    store.write_bytes(bytes(damaged))
    with run_sim(store) as sim, connect(sim.serial_url) as c:
        assert startup_line(sim).endswith(
            "slot 0: rejected: record of another format version; "
            "slot 1: rejected: wrong payload length; no valid record, running on defaults"
        )
        assert c.info().param_source == ParamSource.DEFAULTS


def test_stale_tmp_removed_with_a_message(tmp_path: Path) -> None:
    store = tmp_path / "arm.bin"
    save_sets(store, 1)
    stale = tmp_path / "arm.bin.tmp"
    stale.write_bytes(b"half a save")
    with run_sim(store) as sim:
        assert stderr_line(sim, "aacmm-sim: storage").endswith(
            f"removed the stale {stale} (a save was cut)"
        )
        assert not stale.exists()
        loaded = stderr_line(sim, "aacmm-sim: storage", "loaded slot")
        assert "loaded slot 0 (generation 1)" in loaded


def test_planted_symlink_is_not_followed(tmp_path: Path) -> None:
    store = tmp_path / "arm.bin"
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    with run_sim(store) as sim, connect(sim.serial_url) as c:
        # planted after start-up, right before a save
        os.symlink(victim, tmp_path / "arm.bin.tmp")
        crc = c.save_params()
        assert c.info().param_crc32 == crc
    assert victim.read_text() == "precious\n"
    assert store.is_file() and not store.is_symlink() and store.stat().st_size == 1024
    assert not (tmp_path / "arm.bin.tmp").exists()
    assert any("found in the way of a save" in line for line in sim.stderr_lines)
    # a directory planted there: the save fails cleanly, the old file stays
    before = store.read_bytes()
    with run_sim(store) as sim, connect(sim.serial_url) as c:
        (tmp_path / "arm.bin.tmp").mkdir()
        with pytest.raises(DeviceError, match="ERR_STORAGE"):
            c.save_params()
    assert store.read_bytes() == before


def test_save_fsyncs_the_file_and_the_directory(tmp_path: Path) -> None:
    assert shutil.which("strace"), "strace is installed by scripts/setup.sh"
    store = tmp_path / "arm.bin"
    trace = tmp_path / "trace.txt"
    proc = subprocess.Popen(
        [
            "strace", "-f", "-y", "-qq", "-e", "trace=openat,fsync,rename", "-o", str(trace),
            str(SIM_BIN), "--serial", "pty", "--quiet", "--storage", str(store),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )  # fmt: skip
    try:
        assert proc.stdout is not None
        pty = proc.stdout.readline().split()[-1]
        assert proc.stdout.readline().strip() == "aacmm-sim: ready"
        with connect(f"serial://{pty}") as c:
            c.save_params()
    finally:
        # SIGTERM to the simulator (strace's child); strace then exits with it
        children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split()
        for child in children:
            os.kill(int(child), signal.SIGTERM)
        if not children:
            proc.kill()
        proc.wait(10)
    calls = [line.split(None, 1)[1] for line in trace.read_text().splitlines() if " " in line]
    tmp = f"{store}.tmp"
    i_open = next(i for i, c in enumerate(calls) if c.startswith("openat") and tmp in c)
    assert "O_EXCL" in calls[i_open] and "O_NOFOLLOW" in calls[i_open]
    i_fsync = next(i for i, c in enumerate(calls) if c.startswith("fsync(") and tmp in c)
    i_rename = next(i for i, c in enumerate(calls) if c.startswith("rename("))
    i_dir = next(i for i, c in enumerate(calls) if c.startswith("fsync(") and f"<{tmp_path}>" in c)
    assert i_open < i_fsync < i_rename < i_dir


def test_storage_that_is_not_a_file_is_refused(tmp_path: Path) -> None:
    """A directory as storage, or a stale FILE.tmp that cannot be removed: exit 2, one line."""
    for store, what in (
        (tmp_path, "is not a regular file"),
        (tmp_path / "arm.bin", "cannot remove the stale"),
    ):
        if what.startswith("cannot"):
            (tmp_path / "arm.bin.tmp").mkdir()
            (tmp_path / "arm.bin.tmp" / "x").write_text("x")
        p = subprocess.run(
            [str(SIM_BIN), "--serial", "pty", "--storage", str(store)],
            capture_output=True,
            text=True,
            timeout=10,
        )
        assert p.returncode == 2 and what in p.stderr, (p.returncode, p.stderr)
        assert len(p.stderr.strip().splitlines()) == 1
