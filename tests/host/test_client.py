"""Client unit tests against the in-process fake device (tests/host/fakedevice.py).

Every operation runs over both a real pyserial transport (``socket://`` to a
localhost fake) and python-can's ``virtual`` bus with a can-isotp peer.
"""

from __future__ import annotations

import math
import os
import threading
import time
from collections.abc import Iterator
from dataclasses import replace

import numpy as np
import pytest
from aacmm.client import Client, connect
from aacmm.errors import (
    AacmmError,
    DeviceError,
    DeviceTimeoutError,
    FrameError,
    InitError,
    OperationError,
)
from aacmm.protocol import (
    PROTOCOL_VERSION,
    ComputeRequest,
    MsgType,
    ParamSet,
    Ping,
    Sample,
    Trigger,
)
from aacmm.protocol.status import Status
from aacmm.transport import SerialTransport
from fakedevice import (
    DEFAULT_PARAMS,
    CanFakeDevice,
    FakeDevice,
    SerialFakeServer,
    fake_point,
    param_crc,
)

Fake = SerialFakeServer | CanFakeDevice


@pytest.fixture(params=["serial", "virtual"])
def fake(request: pytest.FixtureRequest) -> Iterator[Fake]:
    dev = FakeDevice(node_id=3)
    f: Fake = SerialFakeServer(dev) if request.param == "serial" else CanFakeDevice(dev)
    yield f
    f.close()


@pytest.fixture
def client(fake: Fake) -> Iterator[Client]:
    with connect(fake.url, timeout=0.5, retries=2) as c:
        yield c


@pytest.fixture
def serial_fake() -> Iterator[SerialFakeServer]:
    f = SerialFakeServer(FakeDevice())
    yield f
    f.close()


def other_params() -> ParamSet:
    return replace(
        DEFAULT_PARAMS,
        d_mm=(301.0, 65.5, 792.7, 65.5, 883.2, 0.25),
        l_mm=200.125,
        counts_per_rev=(1 << 20,) * 6,
        zero_offset_counts=(1, 2, 3, 4, 5, 6),
        direction=(1, -1, 1, -1, 1, -1),
    )


# ---------------------------------------------------------------- every operation


def test_ping_and_info(client: Client, fake: Fake) -> None:
    rtt = client.ping()
    assert 0 < rtt < 0.5
    info = client.info()
    assert info.protocol_version == PROTOCOL_VERSION == 4
    assert info.serial_number == 4242
    assert info.can_node_id == 3
    assert info.param_crc32 == param_crc(DEFAULT_PARAMS)
    assert client.device_info == info
    assert client.handshake() == info


def test_params_set_save_restore(client: Client, fake: Fake) -> None:
    assert client.get_params() == DEFAULT_PARAMS
    new = other_params()
    assert client.set_params(new) == param_crc(new)
    assert client.get_params() == new
    assert client.save_params() == param_crc(new)
    assert fake.device.stored == new
    assert client.restore_defaults() == param_crc(DEFAULT_PARAMS)
    assert client.get_params() == DEFAULT_PARAMS
    assert client.info().storage_state == 0


def test_measure(client: Client, fake: Fake) -> None:
    s = client.measure()
    assert s.counts == fake.device.counts
    assert s.point_100nm == fake_point(fake.device.counts)
    assert s.jacobian is None
    sj = client.measure(jacobian=True)
    assert sj.jacobian is not None and np.shape(sj.jacobian) == (3, 25)
    assert sj.seq == (s.seq + 1) & 0xFFFFFFFF


def test_compute(client: Client) -> None:
    counts = (10, 20, 30, 40, 50, 2**32 - 1)
    r = client.compute(counts)
    x, y, z = fake_point(counts)
    assert r.point_mm == pytest.approx((x * 1e-4, y * 1e-4, z * 1e-4))
    assert r.jacobian is None
    rj = client.compute(list(counts), jacobian=True)
    assert rj.jacobian is not None and np.shape(rj.jacobian) == (3, 25)


def test_stream_iterates_in_order_and_stops(client: Client, fake: Fake) -> None:
    got: list[Sample] = []
    with client.stream(200) as samples:
        assert samples.accepted is not None and samples.accepted.rate_hz == 200
        assert fake.device.stream_rate == 200
        for s in samples:
            got.append(s)
            if len(got) == 100:
                break
    assert fake.device.stream_rate == 0
    seqs = [s.seq for s in got]
    assert seqs == list(range(seqs[0], seqs[0] + 100))
    st = samples.stats
    assert st.lost == 0 and st.duplicates == 0 and st.dropped == 0
    assert not samples.active
    # samples that arrived before the stop are still readable, then the iterator ends
    rest = list(samples)
    assert all(s.seq == seqs[-1] + 1 + i for i, s in enumerate(rest))
    assert client.streaming is None
    # and a new stream can be opened afterwards
    with client.stream(100) as again:
        next(again)


def test_stream_1khz_no_loss(client: Client) -> None:
    with client.stream(1000) as samples:
        t0 = time.monotonic()
        for _ in samples:
            if time.monotonic() - t0 >= 0.5:
                break
    st = samples.stats
    assert st.received >= 100
    assert (st.lost, st.duplicates, st.dropped) == (0, 0, 0)


def test_stream_with_jacobian(client: Client) -> None:
    with client.stream(50, jacobian=True) as samples:
        s = next(samples)
    assert s.jacobian is not None and np.shape(s.jacobian) == (3, 25)


def test_stream_counts_gaps_and_duplicates(client: Client, fake: Fake) -> None:
    base = fake.device._sample_seq
    fake.device.faults.skip_seqs = {base + 5, base + 6, base + 20}
    fake.device.faults.dup_seqs = {base + 10}
    with client.stream(500) as samples:
        for s in samples:
            if s.seq >= base + 30:
                break
    assert samples.stats.lost == 3
    assert samples.stats.duplicates == 1


def test_stream_consumer_too_slow_drops_oldest(client: Client) -> None:
    with client.stream(1000, max_queue=10) as samples:
        end = time.monotonic() + 10.0  # a loaded machine may deliver 1 kHz late
        while samples.stats.dropped <= 100 and time.monotonic() < end:
            time.sleep(0.05)
        assert samples.pending() == 10
    assert samples.stats.dropped > 100


def test_trigger_events(client: Client, fake: Fake) -> None:
    seen: list[Trigger] = []
    client.add_trigger_callback(seen.append)
    client.ping()  # the fake serial server has accepted the connection
    fake.device.press(0, True)
    t = client.wait_trigger(timeout=2.0)
    assert t.button == 0 and t.pressed
    assert t.sample.counts == fake.device.counts
    fake.device.press(1, False)
    t2 = client.wait_trigger(timeout=2.0)
    assert t2.button == 1 and not t2.pressed
    assert seen == [t, t2]
    assert client.drain_triggers() == []
    with pytest.raises(DeviceTimeoutError):
        client.wait_trigger(timeout=0.05)


# ---------------------------------------------------------------- failures


def test_retry_after_lost_request(client: Client, fake: Fake) -> None:
    fake.device.faults.drop = 2
    assert client.info().serial_number == 4242
    assert client.stats.retries == 2
    assert client.stats.timeouts == 2
    assert len(fake.device.requests) == 3


def test_timeout_after_all_retries(client: Client, fake: Fake) -> None:
    fake.device.faults.drop = 10
    t0 = time.monotonic()
    with pytest.raises(DeviceTimeoutError):
        client.measure()
    assert 1.4 <= time.monotonic() - t0 < 3.0  # 3 attempts x 0.5 s
    assert len(fake.device.requests) == 3
    fake.device.faults.drop = 0
    assert client.measure().counts == fake.device.counts


@pytest.mark.parametrize("op", ["set", "save", "restore"])
def test_parameter_writes_are_not_retried(client: Client, fake: Fake, op: str) -> None:
    fake.device.faults.drop = 1
    with pytest.raises(DeviceTimeoutError):
        if op == "set":
            client.set_params(other_params())
        elif op == "save":
            client.save_params()
        else:
            client.restore_defaults()
    assert len(fake.device.requests) == 1
    assert client.stats.retries == 0


def test_device_error_response(client: Client, fake: Fake) -> None:
    fake.device.faults.error_for[MsgType.SAVE_PARAMS_REQ] = int(Status.ERR_STORAGE)
    with pytest.raises(DeviceError) as ei:
        client.save_params()
    assert ei.value.status == Status.ERR_STORAGE
    assert ei.value.request_type == MsgType.SAVE_PARAMS_REQ
    assert "ERR_STORAGE" in str(ei.value)
    assert isinstance(ei.value, AacmmError)


def test_busy_is_retried_for_idempotent_requests(client: Client, fake: Fake) -> None:
    fake.device.faults.busy = 1
    client.ping()
    assert client.stats.retries == 1
    fake.device.faults.busy = 1
    with pytest.raises(DeviceError) as ei:
        client.set_params(other_params())
    assert ei.value.status == Status.ERR_BUSY


def test_response_of_the_wrong_type_is_not_taken(client: Client, fake: Fake) -> None:
    fake.device.faults.wrong_type = 1  # a PING_RSP with the request's seq
    assert client.info().serial_number == 4242
    assert client.stats.stale_responses == 1
    assert client.stats.retries == 1


def test_ping_with_another_token_is_a_frame_error(client: Client, fake: Fake) -> None:
    fake.device.faults.bad_token = 1
    with pytest.raises(FrameError):
        client.ping()
    client.ping()


def test_explicit_retries_never_apply_to_parameter_writes(client: Client, fake: Fake) -> None:
    fake.device.faults.drop = 1
    with pytest.raises(DeviceTimeoutError):
        client.request(MsgType.SAVE_PARAMS_REQ, retries=5, timeout=0.2)
    assert len(fake.device.requests) == 1
    fake.device.faults.drop = 1
    assert client.request(MsgType.INFO_REQ, retries=1, timeout=0.2).type == MsgType.INFO_RSP


def test_stream_sample_timeout(client: Client) -> None:
    with client.stream(1, timeout=0.2) as samples:
        next(samples)  # the first sample comes at once
        with pytest.raises(DeviceTimeoutError):
            samples.get()
        assert samples.active


def test_stale_response_is_ignored(client: Client, fake: Fake) -> None:
    fake.device.faults.stale_first = 1
    assert client.get_params() == DEFAULT_PARAMS
    assert client.stats.stale_responses == 1


def test_bad_arguments_raise_value_or_type_error(client: Client, fake: Fake) -> None:
    with pytest.raises(ValueError):
        client.compute([1, 2, 3])
    with pytest.raises(ValueError):
        client.compute([0, 0, 0, 0, 0, 2**32])
    with pytest.raises(TypeError):
        client.compute([0.5, 0, 0, 0, 0, 0])  # type: ignore[list-item]
    with pytest.raises(ValueError):
        client.stream(0)
    with pytest.raises(ValueError):
        client.stream(1001)
    with pytest.raises(TypeError):
        client.measure(jacobian=1)  # type: ignore[arg-type]
    bad = replace(DEFAULT_PARAMS, l_mm=math.nan)
    with pytest.raises(ValueError):
        client.set_params(bad)
    with pytest.raises(ValueError):
        client.request(MsgType.SAMPLE_EVT)
    assert fake.device.requests == []


@pytest.mark.parametrize("bad", [math.inf, 1e10, math.nan, 0.0, -1.0, 3600.5])
def test_timeout_out_of_range_is_a_value_error(client: Client, fake: Fake, bad: float) -> None:
    """#15.3: inf or 1e10 ended in OverflowError deep in a wait; now ValueError up front."""
    with pytest.raises(ValueError, match=r"timeout must be in \(0, 3600\] seconds"):
        client.request(MsgType.PING_REQ, Ping(1), timeout=bad)
    if bad != 0.0:
        with pytest.raises(ValueError, match="timeout"):
            client.wait_trigger(timeout=bad)
    with pytest.raises(ValueError, match="timeout"):
        client.stream(10, timeout=bad)
    with pytest.raises(ValueError, match="timeout"):
        connect(fake.url, timeout=bad)
    assert fake.device.requests == []
    with client.stream(10) as s:
        if bad == 0.0:  # a poll ("do not wait") is fine for queued things
            try:
                s.get(timeout=0.0)
            except DeviceTimeoutError:
                pass  # nothing queued yet
        else:
            with pytest.raises(ValueError, match="timeout"):
                s.get(timeout=bad)
    assert client.request(MsgType.PING_REQ, Ping(1), timeout=3600).type == MsgType.PING_RSP


def test_second_stream_refused(client: Client) -> None:
    with client.stream(10):
        with pytest.raises(OperationError):
            client.stream(10)


def test_closed_client_refuses_requests(fake: Fake) -> None:
    c = connect(fake.url, timeout=0.5)
    c.close()
    c.close()
    assert c.closed
    with pytest.raises(OperationError):
        c.ping()


def test_concurrent_requests_from_threads(fake: Fake) -> None:
    """Requests from four threads at once: each gets its own answer. The client waits
    as long as a loaded machine may need (a timeout and retry would leave the late
    answer stale, which is not what is tested here), so any stale response is an
    answer given to the wrong request."""
    errors: list[BaseException] = []
    with connect(fake.url, timeout=30.0, retries=0) as client:

        def work() -> None:
            try:
                for _ in range(20):
                    client.ping()
                    client.measure()
            except BaseException as exc:  # pragma: no cover - reported below
                errors.append(exc)

        threads = [threading.Thread(target=work) for _ in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    assert errors == []
    assert client.stats.timeouts == 0
    assert client.stats.stale_responses == 0


# ---------------------------------------------------------------- serial specifics


def test_serial_garbage_is_dropped_and_counted(serial_fake: SerialFakeServer) -> None:
    with connect(serial_fake.url, timeout=0.5) as c:
        serial_fake.garbage_before_response = b"\x17\x42\x00\x99\x98\x97\x00" + bytes(range(1, 60))
        for _ in range(10):
            c.ping()
        assert c.stats.frame_errors >= 10
        assert isinstance(c.transport, SerialTransport)
        assert c.transport.deframer.stats.frames_ok >= 10


def test_serial_torn_request_then_device_resyncs(serial_fake: SerialFakeServer) -> None:
    with connect(serial_fake.url, timeout=0.5) as c:
        assert isinstance(c.transport, SerialTransport)
        c.transport.write_raw(b"\x00\x05\x01\x02\x03")  # torn frame, no end delimiter
        c.ping()
        assert c.stats.retries == 0


def test_serial_link_lost_fails_fast(serial_fake: SerialFakeServer) -> None:
    c = connect(serial_fake.url, timeout=2.0, retries=0)
    try:
        with c.stream(100) as samples:
            next(samples)
            serial_fake.drop_connection()
            t0 = time.monotonic()
            with pytest.raises(OperationError):
                while True:
                    next(samples)
            assert time.monotonic() - t0 < 1.5
        with pytest.raises(OperationError):
            c.ping()
    finally:
        c.close()


# ---------------------------------------------------------------- connect / URLs


def test_connect_uses_environment(
    serial_fake: SerialFakeServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("AACMM_PORT", serial_fake.url)
    with connect(handshake=True) as c:
        assert c.device_info is not None


def test_connect_without_url(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("AACMM_PORT", raising=False)
    with pytest.raises(ValueError, match="AACMM_PORT"):
        connect()


@pytest.mark.parametrize(
    "url",
    [
        "serial:///dev/aacmm-no-such-port",
        "/dev/aacmm-no-such-port",
        "socket://127.0.0.1:1",
        "socketcan://aacmmnosuch0?node=1",
    ],
)
def test_connect_init_errors(url: str) -> None:
    with pytest.raises(InitError):
        connect(url)


def test_handshake_timeout(serial_fake: SerialFakeServer) -> None:
    serial_fake.device.faults.drop = 100
    with pytest.raises(DeviceTimeoutError):
        connect(serial_fake.url, timeout=0.1, retries=0, handshake=True)


def test_env_var_not_needed_when_url_given(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AACMM_PORT", "bogus://x")
    with pytest.raises(InitError):
        connect("serial:///dev/aacmm-no-such-port")
    assert os.environ["AACMM_PORT"] == "bogus://x"


# ------------------------------------------------------------------ link temperatures (issue 27)


def test_measure_stream_and_compute_with_temperatures(client: Client, fake: Fake) -> None:
    """The wire carries the link temperatures both ways: samples of a device with
    sensors (measure, stream, trigger), COMPUTE_REQ's temperatures rounded to 0.01 degC
    half away from zero; a device without sensors refuses the content."""
    from aacmm.client.devstate import has_temperatures, temperature_text
    from aacmm.client.options import wire_temperatures
    from aacmm.errors import DeviceError

    dev = fake.device
    assert not has_temperatures(client.info())
    with pytest.raises(DeviceError, match="ERR_UNSUPPORTED"):
        client.measure(temperatures=True)
    assert temperature_text(client.info(), None).startswith("no sensors")
    dev.temps = (2000, 2001, -150, 8500, -32768, 2800)
    assert has_temperatures(client.info())
    s = client.measure(temperatures=True)
    assert s.temp == dev.temps and client.measure().temp is None
    with client.stream(100, temperatures=True) as st:
        got = [next(st) for _ in range(5)]
        dev.press(0)
        trig = client.wait_trigger(2.0)
    if isinstance(fake, SerialFakeServer):  # CAN sample frames carry no temperatures
        assert all(x.temp == dev.temps for x in got) and trig.sample.temp == dev.temps
    r = client.compute(dev.counts, temperatures_c=[28.0, 20.125, -0.005, 85.0, -40.0, 19.994])
    assert r.temperatures
    req = dev.requests[-1].payload
    assert isinstance(req, ComputeRequest) and req.temp == (2800, 2013, -1, 8500, -4000, 1999)
    assert not client.compute(dev.counts).temperatures
    req = dev.requests[-1].payload
    assert isinstance(req, ComputeRequest) and req.temp is None
    for bad in ([28.0] * 5, [90.0] * 6, [float("nan")] * 6):
        with pytest.raises(ValueError):
            wire_temperatures(bad, 6)
