"""Loopback: the host client against the real simulator (``aacmm-sim``) over a pty.

Needs ``build/sim/aacmm-sim`` (``make sim``; ``make test-loopback-pty`` builds
it). Never skipped: a missing simulator is a failure.

Covers every message type, parameter save and reload across a simulator
restart, a 1 kHz stream for 10 s checked by sequence number, garbage and torn
frames injected into the line, and ``compute``/``measure`` against the host's
double-precision reference (the C core through cffi, or numpy).
"""

from __future__ import annotations

import itertools
import json
import math
import os
import random
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import hostref
import numpy as np
import pytest
from aacmm.client import Client, connect
from aacmm.errors import DeviceError, OperationError
from aacmm.protocol import (
    PROTOCOL_VERSION,
    BuildFlags,
    Message,
    MsgType,
    ParamSet,
    Ping,
    Sample,
    SampleStatus,
    StorageState,
    encode_frame,
    encode_message,
)
from aacmm.protocol.status import Status
from aacmm.transport import SerialTransport
from simproc import REPO, Sim
from streamclock import schedule_drift_us, schedule_rate_hz

STREAM_SECONDS = float(os.environ.get("AACMM_LOOPBACK_STREAM_S", "10"))
FLOAT_PATH_BOUND_MM = 1e-3
RESULTS = REPO / "build" / "client" / "loopback-pty.json"


def _record(key: str, value: object) -> None:
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    data = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    data[key] = value
    RESULTS.write_text(json.dumps(data, indent=2) + "\n")


@pytest.fixture(scope="module")
def sim() -> Iterator[Sim]:
    s = Sim("--serial", "pty", "--motion", "static", "--seed", "7")
    yield s
    assert s.stop() == 0, s.stderr_lines


@pytest.fixture
def client(sim: Sim) -> Iterator[Client]:
    with connect(sim.serial_url, timeout=1.0, retries=2) as c:
        yield c
        # every test leaves the device on its defaults and idle
        c.restore_defaults()


def modified(p: ParamSet) -> ParamSet:
    return replace(
        p,
        theta_offset_rad=(0.001, -0.002, 0.003, 0.0, 0.0005, -0.0015),
        d_mm=(p.d_mm[0] + 0.5, *p.d_mm[1:5], 0.25),
        a_mm=(0.1, -0.2, 0.0, 0.05, 0.0, 0.0),
        l_mm=p.l_mm + 1.25,
    )


# ---------------------------------------------------------------- every message type


def test_ping_info(client: Client) -> None:
    assert client.ping() < 0.5
    info = client.handshake()
    assert info.protocol_version == PROTOCOL_VERSION
    assert info.build_flags & BuildFlags.SERIAL
    assert info.build_flags & BuildFlags.JACOBIAN
    assert info.max_body_bytes <= 512
    assert info.param_source == 0  # defaults (RAM-only storage)


def test_params_roundtrip(client: Client) -> None:
    defaults = client.get_params()
    new = modified(defaults)
    crc = client.set_params(new)
    assert client.get_params() == new
    assert client.info().param_crc32 == crc
    assert client.measure().status & SampleStatus.PARAMS_DEFAULT == 0
    crc_default = client.restore_defaults()
    assert client.get_params() == defaults
    assert client.info().param_crc32 == crc_default != crc
    assert client.measure().status & SampleStatus.PARAMS_DEFAULT


def test_param_set_to_core_reproduces_the_device(client: Client) -> None:
    """#14.9: ``ParamSet.to_core()`` gives the ``aacmm.core`` Params and
    EncoderConfig with which the host recomputes what the device computes,
    encoder configuration included (resolution, zero offset, direction)."""
    from aacmm import core

    ps = replace(
        modified(client.get_params()),
        counts_per_rev=(1 << 20, 1 << 18, 14400, 1 << 20, 1 << 16, 1 << 32),
        zero_offset_counts=(1000, 5, 77, 0, 60000, 123),
        direction=(1, -1, 1, -1, 1, 1),
    )
    client.set_params(ps)
    params, enc = ps.to_core()
    assert isinstance(params, core.Params) and isinstance(enc, core.EncoderConfig)
    assert ParamSet.from_core(params, enc) == ps
    model = core.Model(params)
    rng = random.Random(5)
    for _ in range(20):
        counts = [rng.randrange(c) for c in ps.counts_per_rev]
        r = client.compute(counts, jacobian=True)
        theta = core.counts_to_angles(np.array([counts], dtype=np.int64), enc)[0]
        point, jac = model.point_jacobian(theta)
        assert np.max(np.abs(np.array(r.point_mm) - point)) < FLOAT_PATH_BOUND_MM
        assert np.asarray(r.jacobian).shape == jac.shape == (3, 25)
        assert np.allclose(np.asarray(r.jacobian), jac, rtol=1e-4, atol=1e-3)
        # and the independent numpy chain, read straight from the ParamSet fields
        ref_p, _ = hostref.numpy_point_jacobian(ps, counts)
        assert np.max(np.abs(ref_p - point)) < 1e-9


def test_device_refuses_bad_params(client: Client) -> None:
    p = client.get_params()
    with pytest.raises(DeviceError) as ei:
        client.set_params(replace(p, d_mm=(1e6, *p.d_mm[1:])))
    assert ei.value.status in (Status.ERR_RANGE, Status.ERR_NOT_FINITE)
    assert ei.value.request_type == MsgType.SET_PARAMS_REQ
    assert client.get_params() == p


def test_unknown_request_type_gets_an_error_response(client: Client) -> None:
    assert isinstance(client.transport, SerialTransport)
    before = client.stats.stale_responses
    client.transport.send(bytes([PROTOCOL_VERSION, 0x3F, 0x42]))  # no pending request
    deadline = time.monotonic() + 2
    while client.stats.stale_responses == before and time.monotonic() < deadline:
        time.sleep(0.01)
    assert client.stats.stale_responses == before + 1  # the ERROR_RSP, matched to nothing
    client.ping()


def test_measure_and_compute_against_host_reference(client: Client) -> None:
    params = client.get_params()
    s = client.measure(jacobian=True)
    assert s.status & SampleStatus.POINT_VALID
    ref_p, ref_j = hostref.point_jacobian(params, s.counts)
    assert np.max(np.abs(np.array(s.point_mm) - ref_p)) < FLOAT_PATH_BOUND_MM
    assert s.jacobian is not None
    jac = np.asarray(s.jacobian)  # the codec gives the core's shape, (3, 25)
    assert jac.shape == ref_j.shape == (3, 25)
    assert np.allclose(jac, ref_j, rtol=1e-4, atol=1e-3)

    rng = random.Random(11)
    worst = 0.0
    for i in range(60):
        counts = [rng.randrange(2**32) for _ in range(6)]
        r = client.compute(counts, jacobian=i % 10 == 0)
        assert r.status & SampleStatus.POINT_VALID
        ref_p, ref_j = hostref.point_jacobian(params, counts)
        worst = max(worst, float(np.max(np.abs(np.array(r.point_mm) - ref_p))))
        if r.jacobian is not None:
            assert np.asarray(r.jacobian).shape == ref_j.shape
            assert np.allclose(np.asarray(r.jacobian), ref_j, rtol=1e-4, atol=1e-3)
    assert worst < FLOAT_PATH_BOUND_MM
    _record("compute_max_error_mm", worst)
    _record("host_reference", "aacmm.core (cffi)" if hostref.have_core() else "numpy")


def test_compute_uses_the_active_parameters(client: Client) -> None:
    new = modified(client.get_params())
    client.set_params(new)
    counts = [1 << 30, 3 << 29, 5 << 28, 7 << 27, 9 << 26, 11 << 25]
    r = client.compute(counts)
    ref_p, _ = hostref.point_jacobian(new, counts)
    assert np.max(np.abs(np.array(r.point_mm) - ref_p)) < FLOAT_PATH_BOUND_MM


def test_stream_start_stop_and_jacobian_content(
    client: Client, monkeypatch: pytest.MonkeyPatch
) -> None:
    with client.stream(100, jacobian=True) as samples:
        assert samples.accepted is not None
        assert samples.accepted.rate_hz == 100 and samples.accepted.jacobian
        got = [next(samples) for _ in range(20)]
    assert all(s.jacobian is not None and np.shape(s.jacobian) == (3, 25) for s in got)
    assert samples.stats.lost == samples.stats.duplicates == 0
    # Stopped: the device reads no sample after the stop. Samples it queued before
    # may still follow the stop's answer (answers do not wait behind queued samples,
    # docs/protocol.md), more of them when the host reads slowly: each one that
    # arrives now must have been read before the device clock read just after it.
    after_stop: list[int] = []
    forward = client.on_message

    def spy(msg: Message) -> None:
        if msg.type == MsgType.SAMPLE_EVT and isinstance(msg.payload, Sample):
            after_stop.append(msg.payload.timestamp_us)
        forward(msg)

    monkeypatch.setattr(client, "on_message", spy)
    stopped_us = client.measure().timestamp_us
    time.sleep(0.2)
    assert all(t < stopped_us for t in after_stop), (stopped_us, after_stop)
    client.ping()


def test_trigger_events() -> None:
    with Sim("--serial", "pty", "--motion", "static", "--button-every", "0.3") as sim:
        with connect(sim.serial_url, timeout=1.0) as c:
            first = c.wait_trigger(timeout=3.0)
            second = c.wait_trigger(timeout=3.0)
            assert {first.pressed, second.pressed} == {True, False}
            down = first if first.pressed else second
            assert down.button == 0
            assert down.sample.status & SampleStatus.POINT_VALID
            assert down.sample.status & SampleStatus.TRIGGER_DOWN
            assert down.sample.counts == c.measure().counts  # static pose


# ---------------------------------------------------------------- storage across restarts


def test_params_saved_and_reloaded_across_restart(tmp_path: Path) -> None:
    store = tmp_path / "arm.bin"
    args = ("--serial", "pty", "--motion", "static", "--storage", str(store))
    with Sim(*args) as sim, connect(sim.serial_url) as c:
        info = c.info()
        assert info.storage_state == StorageState.EMPTY and info.param_source == 0
        defaults = c.get_params()
        new = modified(defaults)
        crc = c.set_params(new)
        assert c.save_params() == crc
        c.restore_defaults()  # RAM only: the stored set stays
    assert store.exists()

    with Sim(*args) as sim, connect(sim.serial_url) as c:
        info = c.info()
        assert info.storage_state == StorageState.OK
        assert info.param_source == 1
        assert info.param_crc32 == crc
        assert c.get_params() == new
        assert c.measure().status & SampleStatus.PARAMS_DEFAULT == 0
        c.restore_defaults()
        assert c.get_params() == defaults

    with Sim(*args) as sim, connect(sim.serial_url) as c:
        assert c.get_params() == new  # restore_defaults did not touch storage


# ---------------------------------------------------------------- streaming at 1 kHz


def test_stream_1khz_no_lost_or_duplicated_samples(client: Client) -> None:
    n_want = int(STREAM_SECONDS * 1000) + 1
    seqs: list[int] = []
    stamps: list[int] = []
    t0 = time.monotonic()
    with client.stream(1000) as samples:
        assert samples.accepted is not None and samples.accepted.rate_hz == 1000
        for s in samples:
            seqs.append(s.seq)
            stamps.append(s.timestamp_us)
            if len(seqs) >= n_want:
                break
    wall = time.monotonic() - t0
    st = samples.stats
    diffs = np.array([(b - a) & 0xFFFFFFFF for a, b in itertools.pairwise(seqs)])
    drift_us = schedule_drift_us(seqs, stamps, 1000)  # late samples cannot move it
    rate = schedule_rate_hz(seqs, stamps, 1000)
    figures = {
        "samples": len(seqs),
        "device_span_s": round((stamps[-1] - stamps[0]) * 1e-6, 4),
        "schedule_drift_us": round(drift_us),
        "rate_hz_device_clock": round(rate, 3),
        "wall_s": round(wall, 3),
        "lost": st.lost,
        "duplicates": st.duplicates,
        "overruns": st.overruns,
        "host_dropped": st.dropped,
        "frame_errors": client.stats.frame_errors,
        "pty_spurious_wakeups": getattr(client.transport, "spurious_wakeups", 0),
    }
    _record("stream_1khz", figures)
    print("stream 1 kHz over the pty:", figures)
    assert np.all(diffs == 1), f"sequence gaps/duplicates at {np.nonzero(diffs != 1)[0][:10]}"
    assert (st.lost, st.duplicates, st.overruns, st.dropped) == (0, 0, 0, 0)
    assert abs(drift_us) < 1000, f"device clock gives {rate:.2f} Hz"
    assert all(b >= a for a, b in itertools.pairwise(stamps))  # device clock never goes back
    assert client.stats.frame_errors == 0


# ---------------------------------------------------------------- garbage on the line


def _garbage(rng: random.Random, valid: bytes) -> list[bytes]:
    return [
        bytes(rng.randrange(256) for _ in range(200)),  # random bytes, zeros included
        bytes(rng.randrange(1, 256) for _ in range(700)),  # oversize run without delimiter
        valid[: len(valid) // 2],  # torn frame
        b"\x00" + valid[1:-3] + b"\x55\x00",  # corrupted tail (CRC/COBS error)
        b"\x00\x00\x00",  # empty frames
        valid[: len(valid) - 2],  # frame cut short, no end delimiter
    ]


def test_garbage_on_the_line_device_resyncs(client: Client) -> None:
    assert isinstance(client.transport, SerialTransport)
    rng = random.Random(3)
    valid = encode_frame(encode_message(Message(MsgType.PING_REQ, 0x10, Ping(1))))
    for round_ in range(20):
        for chunk in _garbage(rng, valid):
            client.transport.write_raw(chunk)
        # the very next request is answered, no retry needed
        retries = client.stats.retries
        client.ping()
        client.info()
        assert client.stats.retries == retries, f"round {round_}: a request needed a retry"


def test_foreign_answer_with_the_same_seq_is_not_taken(client: Client) -> None:
    """A valid request from someone else, with the seq our next request will use:
    the device answers both; the client takes only the answer of the right type.

    The foreign frame goes out without its end delimiter, so the device reads it
    only when our request's leading delimiter arrives: both answers then come
    while our request waits."""
    assert isinstance(client.transport, SerialTransport)
    for _ in range(5):
        next_seq = (client._seq + 1) & 0xFF
        foreign = Message(MsgType.PING_REQ, next_seq, Ping(0xABCD))
        stale = client.stats.stale_responses
        client.transport.write_raw(encode_frame(encode_message(foreign))[:-1])
        s = client.measure()
        assert s.status & SampleStatus.POINT_VALID
        deadline = time.monotonic() + 1
        while client.stats.stale_responses == stale and time.monotonic() < deadline:
            time.sleep(0.01)
        assert client.stats.stale_responses == stale + 1
    assert client.stats.retries == 0


def test_garbage_while_streaming(client: Client) -> None:
    """Garbage on the line during a 1 kHz stream costs no sample: a sample can be
    missing only where the device itself dropped it and says so (OVERRUN on the next
    sample, and its loss counters), as it does when a loaded machine starves it or
    the host reader; a frame the garbage spoiled would be a gap the device never
    declared."""
    assert isinstance(client.transport, SerialTransport)
    rng = random.Random(4)
    valid = encode_frame(encode_message(Message(MsgType.PING_REQ, 0x11, Ping(2))))
    before = client.diagnostics()
    seqs: list[int] = []
    flags: list[int] = []
    with client.stream(1000) as samples:
        for i, s in enumerate(samples):
            seqs.append(s.seq)
            flags.append(s.status)
            if i % 100 == 50:
                for chunk in _garbage(rng, valid):
                    client.transport.write_raw(chunk)
                client.measure()
            if i >= 1000:
                break
    after = client.diagnostics()
    assert before is not None and after is not None
    assert samples.stats.duplicates == 0
    undeclared = [
        seqs[k]
        for k in range(1, len(seqs))
        if seqs[k] != seqs[k - 1] + 1 and not flags[k] & SampleStatus.OVERRUN
    ]
    assert not undeclared, f"gaps the device did not declare, before seq {undeclared}"
    declared = after.samples_dropped + after.samples_late
    declared -= before.samples_dropped + before.samples_late
    assert samples.stats.lost <= declared, (samples.stats, declared)
    assert client.stats.retries == 0


def test_link_lost_when_simulator_exits() -> None:
    sim = Sim("--serial", "pty", "--motion", "static")
    c = connect(sim.serial_url, timeout=1.0, retries=0)
    try:
        with c.stream(200) as samples:
            next(samples)
            assert sim.stop() == 0
            t0 = time.monotonic()
            with pytest.raises(OperationError):  # the pty hangs up: not a timeout
                while True:
                    next(samples)
            assert time.monotonic() - t0 < 1.0
        with pytest.raises(OperationError, match="link lost"):
            c.ping()
    finally:
        c.close()
        sim.kill()


def test_math_sanity_of_static_pose(client: Client) -> None:
    # --motion static is the documented pose (0.5, 0.6, -0.9, 0.4, 1.2, -0.3) rad
    s = client.measure()
    params = client.get_params()
    angles = hostref.counts_to_angles(params, s.counts)
    assert np.allclose(angles, [0.5, 0.6, -0.9, 0.4, 1.2, -0.3], atol=1e-6)
    assert math.isfinite(s.point_mm[0])
