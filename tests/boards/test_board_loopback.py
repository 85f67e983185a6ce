"""The host client against the device application on the emulated ARM boards.

Each board's device image (``build/boards/<board>/fw.elf``: the device
application cross-compiled with the board's UART, clock, simulated arm and
RAM-backed storage) runs under QEMU (``aacmm.boards.start_board``: -icount
shift=0, UART on a TCP socket with nodelay) and the client talks to it over
pyserial's ``socket://`` URL, exactly as over USB-serial.

* The host loopback suite (``tests/host/test_loopback_pty.py``, written for
  the POSIX simulator over a pty) runs here unchanged against each board:
  its tests that need only a ``client`` are imported by name and get this
  module's ``client`` fixture (tests that start the simulator process with
  options -- static pose, button, storage file, restarts -- stay with the
  simulator).
* Golden vectors through ``compute``: encoder readings chosen on the host,
  double-precision references from the host's core; the float image
  (mps2-an386) is held to the single-precision bounds (1e-3 mm point, 2e-3
  Jacobian), the fixed image (micro:bit) to the fixed-point bounds (1e-4 mm
  point, 1e-4 Jacobian plus the float32 rounding of the Jacobian on the wire).
* Streaming without a lost, duplicated or overrun sample at rates the
  emulated UART sustains (200 Hz, and 100 Hz with the Jacobian).

Boards: ``$AACMM_BOARDS`` (comma-separated; default all). Measured figures
go to ``build/boards/loopback-<board>.json``.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import os
import random
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import hostref
import numpy as np
import pytest
import test_loopback_arms as arms
import test_loopback_pty as pty_suite
from aacmm.boards import BOARDS, default_image, start_board, stop_board
from aacmm.client import Client, connect
from aacmm.errors import DeviceError
from aacmm.protocol import BuildFlags, ParamSet, SampleStatus, Status
from streamclock import schedule_drift_us, schedule_rate_hz

REPO = Path(__file__).resolve().parents[2]
OUT = REPO / "build" / "boards"
SELECTED = [b for b in os.environ.get("AACMM_BOARDS", ",".join(BOARDS)).split(",") if b]

# The loopback suite's tests that run on any serial device with a fresh
# RAM-backed store.
REUSED = (
    "test_ping_info",
    "test_params_roundtrip",
    "test_device_refuses_bad_params",
    "test_unknown_request_type_gets_an_error_response",
    "test_measure_and_compute_against_host_reference",
    "test_compute_uses_the_active_parameters",
    "test_stream_start_stop_and_jacobian_content",
    "test_garbage_on_the_line_device_resyncs",
    "test_garbage_while_streaming",
)
_found: list[str] = []
for _name in REUSED:
    _fn: Callable[..., Any] | None = getattr(pty_suite, _name, None)
    if _fn is not None:
        globals()[_name] = _fn
        _found.append(_name)


def test_reused_loopback_tests_present() -> None:
    """The loopback suite still has the tests this module runs on the boards."""
    missing = sorted(set(REUSED) - set(_found))
    assert not missing, f"tests/host/test_loopback_pty.py no longer has {missing}"


@pytest.fixture(scope="module", params=SELECTED)
def board(request: pytest.FixtureRequest) -> Iterator[tuple[str, str]]:
    name: str = request.param
    proc, url = start_board(name, default_image(name))
    yield name, url
    stop_board(proc)


@pytest.fixture(autouse=True)
def _results_per_board(board: tuple[str, str], monkeypatch: pytest.MonkeyPatch) -> None:
    # The reused suite records its figures; keep them apart from the simulator's.
    monkeypatch.setattr(pty_suite, "RESULTS", OUT / f"loopback-{board[0]}.json")


@pytest.fixture
def client(board: tuple[str, str]) -> Iterator[Client]:
    with connect(board[1], timeout=2.0, retries=2) as c:
        yield c
        c.restore_defaults()


def _record(board: str, key: str, value: object) -> None:
    path = OUT / f"loopback-{board}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    data = json.loads(path.read_text()) if path.exists() else {}
    data[key] = value
    path.write_text(json.dumps(data, indent=2) + "\n")


# ---------------------------------------------------------------- the board itself


def test_board_identity(board: tuple[str, str], client: Client) -> None:
    info = client.handshake()
    fixed = BOARDS[board[0]].kinematics == "q"
    assert bool(info.build_flags & BuildFlags.KIN_FIXED) == fixed
    assert info.build_flags & BuildFlags.SERIAL and not info.build_flags & BuildFlags.CAN
    assert info.storage_state in (0, 1)  # RAM-backed store: blank (or written by a test)


# ---------------------------------------------------------------- link temperatures


def test_board_has_no_temperatures(board: tuple[str, str], client: Client) -> None:
    """Neither emulated board reads link temperatures (docs/boards.md): the
    MPS2 has no sensor, and the micro:bit's TEMP probe gets no conversion
    under QEMU (test_microbit_temp_probe_under_qemu). So INFO has no
    TEMPERATURES flag and a set with the thermal block is refused with
    ERR_UNSUPPORTED (never a point at lengths the device cannot know); the
    set in force is unchanged."""
    info = client.handshake()
    assert not info.build_flags & BuildFlags.TEMPERATURES
    before = client.get_params()
    thermal = dataclasses.replace(before, cte=(2300,) * before.joints, ref_temp=2000)
    with pytest.raises(DeviceError) as ei:
        client.set_params(thermal)
    assert ei.value.status == Status.ERR_UNSUPPORTED
    assert client.get_params() == before
    sample = client.measure()
    assert sample.status & SampleStatus.POINT_VALID


def test_microbit_temp_probe_under_qemu() -> None:
    """QEMU's microbit machine does not model the nRF51 TEMP peripheral: its
    registers lie in the SoC's unimplemented I/O region (-d unimp logs each
    access). The image's start-up probe starts a conversion (TASKS_START,
    0x4000C000), polls EVENTS_DATARDY (0x4000C100) for at most its bounded
    wait, gives up (TASKS_STOP, 0x4000C004) and never reads the TEMP register
    (0x4000C508); the device then has no read_temperatures."""
    log: list[str] = []
    proc, url = start_board("microbit", default_image("microbit"), log=log, extra=["-d", "unimp"])
    try:
        with connect(url, timeout=2.0, retries=2) as c:
            info = c.handshake()
            c.measure()
    finally:
        stop_board(proc)
    temp = [line for line in log if "nrf51_soc.io" in line and "offset 0x0000c" in line]
    starts = [x for x in temp if "write" in x and "offset 0x0000c000," in x]
    polls = [x for x in temp if "read" in x and "offset 0x0000c100)" in x]
    stops = [x for x in temp if "write" in x and "offset 0x0000c004," in x]
    assert len(starts) == 1 and len(stops) == 1, temp[:5]
    assert polls, "the probe polls EVENTS_DATARDY"
    assert not [x for x in temp if "offset 0x0000c508" in x], "TEMP never read"
    last_poll = max(i for i, x in enumerate(temp) if "read" in x and "offset 0x0000c100)" in x)
    assert temp.index(stops[0]) > last_poll, "stopped after the last poll"
    assert not info.build_flags & BuildFlags.TEMPERATURES


# ---------------------------------------------------------------- golden vectors via compute

Q = 1 << 30


def golden_counts(n: int, seed: int) -> list[list[int]]:
    edges = [
        [0] * 6,
        [Q] * 6,
        [2 * Q] * 6,
        [3 * Q] * 6,
        [(1 << 32) - 1] * 6,
        [0, Q, 2 * Q, 3 * Q, (1 << 32) - 1, 1],
        [0x80000001, 0x7FFFFFFF, 0x12345678, 0xFEDCBA98, 0x3FFFFFFF, 0xC0000001],
    ]
    rng = random.Random(seed)
    return edges + [[rng.randrange(1 << 32) for _ in range(6)] for _ in range(n - len(edges))]


def test_golden_vectors_via_compute(board: tuple[str, str], client: Client) -> None:
    fixed = BOARDS[board[0]].kinematics == "q"
    params = client.get_params()
    worst_p = worst_j = worst_j_beyond_wire = 0.0
    for counts in golden_counts(40, seed=8):
        r = client.compute(counts, jacobian=True)
        assert r.status & SampleStatus.POINT_VALID
        ref_p, ref_j = hostref.point_jacobian(params, counts)
        assert r.jacobian is not None
        jac = np.array(r.jacobian, dtype=np.float64).reshape(3, 25)
        ep = float(np.max(np.abs(np.array(r.point_mm) - ref_p)))
        ej = np.abs(jac - ref_j)
        # The wire carries the Jacobian as float32: half an ulp of each entry
        # is the transport's share, not the kinematics'.
        half_ulp = np.spacing(np.abs(ref_j).astype(np.float32)).astype(np.float64) / 2
        worst_p = max(worst_p, ep)
        worst_j = max(worst_j, float(np.max(ej)))
        worst_j_beyond_wire = max(worst_j_beyond_wire, float(np.max(ej - half_ulp)))
    figures = {
        "poses": 40,
        "point_max_mm": worst_p,
        "jacobian_max": worst_j,
        "jacobian_max_beyond_float32_wire": worst_j_beyond_wire,
        "path": "fixed" if fixed else "float",
    }
    _record(board[0], "golden_compute", figures)
    print(board[0], figures)
    if fixed:
        assert worst_p <= 1e-4
        assert worst_j_beyond_wire <= 1e-4
    else:
        assert worst_p <= 1e-3
        assert worst_j <= 2e-3


@pytest.mark.parametrize("make", [arms.arm7, arms.arm5], ids=["7-axis", "5-axis"])
def test_arm_models_via_compute(board: tuple[str, str], client: Client, make: Any) -> None:
    """Issue 26 over the wire on the boards: a 7-axis and a 5-axis arm (modified
    DH, betas, a tip vector; built with aacmm.arm.Arm in tests/host/test_loopback_arms.py)
    set on the device, its points and 3 x P Jacobians against aacmm.core in double
    precision, to the board path's bounds (those of the paper's arm above)."""
    fixed = BOARDS[board[0]].kinematics == "q"
    arm = make()
    enc = arms.encoders(arm)
    client.set_params(ParamSet.from_arm(arm, enc))
    info = client.info()
    assert (info.joints, info.params) == (arm.n_joints, arm.n_params)
    rng = random.Random(arm.n_joints)
    worst_p = worst_j = 0.0
    for _ in range(20):
        counts = tuple(rng.randrange(c) for c in enc.counts_per_rev)
        r = client.compute(counts, jacobian=True)
        assert r.status & SampleStatus.POINT_VALID and r.jacobian is not None
        ref_p, ref_j = arms.reference(arm, enc, counts)
        jac = np.array(r.jacobian, dtype=np.float64)
        assert jac.shape == (3, arm.n_params)
        half_ulp = np.spacing(np.abs(ref_j).astype(np.float32)).astype(np.float64) / 2
        worst_p = max(worst_p, float(np.max(np.abs(np.array(r.point_mm) - ref_p))))
        worst_j = max(worst_j, float(np.max(np.abs(jac - ref_j) - (half_ulp if fixed else 0.0))))
    _record(
        board[0], f"arm{arm.n_joints}_compute", {"point_max_mm": worst_p, "jacobian_max": worst_j}
    )
    if fixed:
        assert worst_p <= 1e-4 and worst_j <= 1e-4
    else:
        assert worst_p <= 1e-3 and worst_j <= 2e-3
    s = client.measure(jacobian=True)  # the board's simulated arm has 2^32-count encoders
    assert len(s.counts) == arm.n_joints and s.params == arm.n_params


# ---------------------------------------------------------------- streaming


@pytest.mark.parametrize(("rate", "jacobian", "n"), [(200, False, 600), (100, True, 150)])
def test_stream_no_lost_samples(
    board: tuple[str, str], client: Client, rate: int, jacobian: bool, n: int
) -> None:
    seqs: list[int] = []
    stamps: list[int] = []
    with client.stream(rate, jacobian=jacobian) as samples:
        assert samples.accepted is not None and samples.accepted.rate_hz == rate
        for s in samples:
            assert s.status & SampleStatus.POINT_VALID
            assert (s.jacobian is not None) == jacobian
            seqs.append(s.seq)
            stamps.append(s.timestamp_us)
            if len(seqs) >= n:
                break
    st = samples.stats
    diffs = np.array([(b - a) & 0xFFFFFFFF for a, b in itertools.pairwise(seqs)])
    span_s = (stamps[-1] - stamps[0]) * 1e-6
    drift_us = schedule_drift_us(seqs, stamps, rate)  # late samples cannot move it
    dev_rate = schedule_rate_hz(seqs, stamps, rate)
    _record(
        board[0],
        f"stream_{rate}hz{'_jacobian' if jacobian else ''}",
        {
            "samples": len(seqs),
            "device_span_s": round(span_s, 4),
            "schedule_drift_us": round(drift_us),
            "rate_hz_device_clock": round(dev_rate, 3),
            "lost": st.lost,
            "duplicates": st.duplicates,
            "overruns": st.overruns,
        },
    )
    assert np.all(diffs == 1), f"sequence gaps at {np.nonzero(diffs != 1)[0][:10]}"
    assert (st.lost, st.duplicates, st.overruns, st.dropped) == (0, 0, 0, 0)
    assert abs(drift_us) < 1e6 / rate, f"device clock gives {dev_rate:.2f} Hz"
    assert all(b >= a for a, b in itertools.pairwise(stamps))
    assert client.stats.frame_errors == 0


# ---------------------------------------------------------------- storage


def test_save_params_to_ram_storage(client: Client) -> None:
    new = pty_suite.modified(client.get_params())
    crc = client.set_params(new)
    assert client.save_params() == crc
    client.restore_defaults()
    assert client.get_params() != new
