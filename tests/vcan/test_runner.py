"""Tests of tests/vcan/run-in-vcan.sh itself, run on the host (not inside it).

They force the VM path where it matters (AACMM_VCAN_MODE=vm), so on a host
with native vcan they still check the VM. Each VM boot costs ~6 s under TCG;
the suite boots five (three of them stop early).
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

RUNNER = Path(__file__).resolve().parent / "run-in-vcan.sh"
REPO = RUNNER.parent.parent.parent


def _env(tmp_path: Path | None = None, **extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("AACMM_VCAN")}
    if tmp_path is not None:
        # A private build dir under /tmp: unique job paths to look for, and the
        # runner's binding of /tmp entries into the VM gets exercised.
        env["AACMM_VCAN_BUILD"] = str(tmp_path / "build")
    env.update(extra)
    return env


def _qemu_pids(marker: str) -> list[int]:
    pids = []
    for p in Path("/proc").iterdir():
        if not p.name.isdigit():
            continue
        try:
            cmd = (p / "cmdline").read_bytes()
        except OSError:
            continue
        if b"qemu-system" in cmd and marker.encode() in cmd:
            pids.append(int(p.name))
    return pids


def _wait_no_qemu(marker: str, within: float = 10.0) -> list[int]:
    deadline = time.monotonic() + within
    while (left := _qemu_pids(marker)) and time.monotonic() < deadline:
        time.sleep(0.2)
    return left


def test_exit_status_output_cwd_env(tmp_path: Path) -> None:
    """One boot: exit 3 comes back as 3, with stdout, stderr, cwd, env, vcan0."""
    work = tmp_path / "work dir"
    work.mkdir()
    script = (
        'echo "out:$(pwd)"; echo "probe:$AACMM_PROBE"; echo "mode:$AACMM_VCAN"; '
        "echo to-stderr >&2; ip -br link show vcan0; seq 1 3000; exit 3"
    )
    r = subprocess.run(
        [str(RUNNER), "sh", "-c", script],
        cwd=work,
        env=_env(tmp_path, AACMM_PROBE="x y'z", AACMM_VCAN_MODE="vm"),
        capture_output=True,
        text=True,
        check=False,
        timeout=300,
    )
    assert r.returncode == 3, r.stderr
    lines = r.stdout.splitlines()
    assert f"out:{work}" in lines
    assert "probe:x y'z" in lines
    assert "mode:vm" in lines
    assert any(x.startswith("vcan0") and "UP" in x for x in lines)
    assert lines[-3000:] == [str(i) for i in range(1, 3001)], "output lost or mangled"
    assert "\r" not in r.stdout
    assert "to-stderr" in r.stderr and "to-stderr" not in r.stdout
    assert "exit 3" in r.stderr


def test_missing_command_fails_fast() -> None:
    t0 = time.monotonic()
    r = subprocess.run(
        [str(RUNNER), "no-such-command-aacmm"],
        env=_env(),
        capture_output=True,
        text=True,
        check=False,
        timeout=60,
    )
    assert r.returncode == 127
    assert "command not found: no-such-command-aacmm" in r.stderr
    assert time.monotonic() - t0 < 20


def test_missing_kernel_or_qemu_fails_clearly(tmp_path: Path) -> None:
    r = subprocess.run(
        [str(RUNNER), "true"],
        capture_output=True,
        text=True,
        check=False,
        timeout=60,
        env=_env(tmp_path, AACMM_VCAN_MODE="vm", AACMM_VCAN_BOOT_DIR=str(tmp_path)),
    )
    assert r.returncode == 125
    assert "no kernel for the VM" in r.stderr
    r = subprocess.run(
        [str(RUNNER), "true"],
        capture_output=True,
        text=True,
        check=False,
        timeout=60,
        env=_env(tmp_path, AACMM_VCAN_MODE="vm", AACMM_VCAN_QEMU="qemu-system-none-such"),
    )
    assert r.returncode == 125
    assert "qemu-system-none-such not found" in r.stderr


def test_module_load_failure_fails_clearly(tmp_path: Path) -> None:
    bogus = tmp_path / "bogus.ko"
    bogus.write_bytes(b"\x7fELF this is not a kernel module")
    r = subprocess.run(
        [str(RUNNER), "true"],
        capture_output=True,
        text=True,
        check=False,
        timeout=300,
        env=_env(tmp_path, AACMM_VCAN_MODE="vm", AACMM_VCAN_EXTRA_MODULES=str(bogus)),
    )
    assert r.returncode == 125, r.stderr
    assert "bogus" in r.stderr and "failed to load" in r.stderr


def test_vm_dying_without_report_is_a_failure(tmp_path: Path) -> None:
    """A guest kernel crash (forced here) must not pass: exit 125, with the panic shown."""
    r = subprocess.run(
        [str(RUNNER), "sh", "-c", "echo c > /proc/sysrq-trigger; sleep 60"],
        capture_output=True,
        text=True,
        check=False,
        timeout=300,
        env=_env(tmp_path, AACMM_VCAN_MODE="vm"),
    )
    assert r.returncode == 125, r.stderr
    assert "without reporting an exit status" in r.stderr
    assert "Kernel panic" in r.stderr or "sysrq" in r.stderr


def test_timeout_kills_qemu(tmp_path: Path) -> None:
    t0 = time.monotonic()
    r = subprocess.run(
        [str(RUNNER), "sleep", "600"],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
        env=_env(tmp_path, AACMM_VCAN_MODE="vm", AACMM_VCAN_TIMEOUT="4"),
    )
    assert r.returncode == 124, r.stderr
    assert "TIMEOUT" in r.stderr
    assert time.monotonic() - t0 < 30
    assert _wait_no_qemu(str(tmp_path)) == []


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_interrupt_leaves_no_qemu(tmp_path: Path, sig: signal.Signals) -> None:
    proc = subprocess.Popen(
        [str(RUNNER), "sleep", "600"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(tmp_path, AACMM_VCAN_MODE="vm"),
    )
    try:
        deadline = time.monotonic() + 30
        while not _qemu_pids(str(tmp_path)) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert _qemu_pids(str(tmp_path)), "QEMU never started"
        time.sleep(0.5)
        proc.send_signal(sig)  # only the runner: it has to stop QEMU itself
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + sig, err
    assert "interrupted" in err
    assert _wait_no_qemu(str(tmp_path)) == []
