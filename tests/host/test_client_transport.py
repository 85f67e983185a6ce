"""Unit tests of the transports: URL syntax, serial framing, CAN sample frame decoding."""

from __future__ import annotations

import struct

import can
import pytest
from aacmm.errors import FrameError, InitError, OperationError
from aacmm.protocol import (
    PROTOCOL_VERSION,
    Message,
    MsgType,
    Ping,
    Sample,
    decode_message,
    encode_frame,
    encode_message,
    encode_sample_frames,
)
from aacmm.protocol.can import ID_TRIGGER, SampleAssembler
from aacmm.transport import (
    DEFAULT_BAUDRATE,
    CanTransport,
    SampleFrameDecoder,
    SerialTransport,
    TransportUrl,
    open_transport,
    parse_url,
)
from fakedevice import FakeDevice


@pytest.mark.parametrize(
    ("url", "want"),
    [
        ("serial:///dev/pts/3", TransportUrl("serial", "/dev/pts/3")),
        ("serial:///dev/ttyACM0?baud=115200", TransportUrl("serial", "/dev/ttyACM0", 115200)),
        ("serial://COM3?baudrate=9600", TransportUrl("serial", "COM3", 9600)),
        ("serial://socket://localhost:5000", TransportUrl("serial", "socket://localhost:5000")),
        ("serial://loop://?logging=debug", TransportUrl("serial", "loop://?logging=debug")),
        ("serial://rfc2217://h:7000", TransportUrl("serial", "rfc2217://h:7000")),
        ("socket://h:1", TransportUrl("serial", "socket://h:1")),
        ("loop://", TransportUrl("serial", "loop://")),
        ("/dev/ttyUSB0", TransportUrl("serial", "/dev/ttyUSB0")),
        ("COM4", TransportUrl("serial", "COM4")),
        ("socketcan://vcan0?node=1", TransportUrl("socketcan", "vcan0", node=1)),
        ("socketcan://can1", TransportUrl("socketcan", "can1", node=1)),
        ("SocketCAN://vcan0?node=15", TransportUrl("socketcan", "vcan0", node=15)),
        (
            "socketcan://vcan0?isotp=user",
            TransportUrl("socketcan", "vcan0", node=1, isotp="user"),
        ),
        (
            "virtual://bus7?node=0&isotp_timeout_ms=250",
            TransportUrl("virtual", "bus7", node=0, isotp_timeout_ms=250, isotp="user"),
        ),
    ],
)
def test_parse_url(url: str, want: TransportUrl) -> None:
    assert parse_url(url) == want
    assert parse_url(url).baudrate == want.baudrate


@pytest.mark.parametrize(
    "url",
    [
        "",
        "   ",
        "http://example.com",
        "serial://",
        "serial:///dev/x?speed=1",
        "serial:///dev/x?baud=fast",
        "serial:///dev/x?baud=0",
        "socketcan://",
        "socketcan://vcan0?node=16",
        "socketcan://vcan0?node=-1",
        "socketcan://vcan0?bitrate=500000",
        "virtual://x?isotp_timeout_ms=0",
        "virtual://x?isotp=kernel",
        "socketcan://vcan0?isotp=fast",
    ],
)
def test_parse_url_rejects(url: str) -> None:
    with pytest.raises(ValueError):
        parse_url(url)


def test_default_baudrate() -> None:
    assert parse_url("serial:///dev/x").baudrate == DEFAULT_BAUDRATE


# ---------------------------------------------------------------- serial


class Collect:
    def __init__(self) -> None:
        self.messages: list[Message] = []
        self.errors: list[FrameError] = []
        self.lost: list[BaseException] = []

    def on_message(self, msg: Message) -> None:
        self.messages.append(msg)

    def on_frame_error(self, err: FrameError) -> None:
        self.errors.append(err)

    def on_link_lost(self, err: BaseException) -> None:
        self.lost.append(err)


def test_serial_loop_roundtrip_in_any_chunking() -> None:
    t = open_transport("serial://loop://")
    assert isinstance(t, SerialTransport)
    sink = Collect()
    t.feed(b"")  # not started yet: feeding is still fine
    msgs = [Message(MsgType.PING_REQ, i, Ping(i * 1000)) for i in range(20)]
    stream = b"".join(encode_frame(encode_message(m)) for m in msgs)
    t._sink = sink
    for i in range(0, len(stream), 7):
        t.feed(stream[i : i + 7])
    assert sink.messages == msgs
    assert t.stats.messages_rx == 20
    t.close()


def test_serial_loop_reader_thread_and_errors() -> None:
    t = SerialTransport("loop://")
    sink = Collect()
    t.start(sink)
    body = encode_message(Message(MsgType.PING_REQ, 9, Ping(7)))
    t.write_raw(b"\x01\x02\x03")  # garbage: dropped at the next delimiter
    t.send(body)
    bad = bytearray(encode_frame(body))
    bad[5] ^= 0x40
    t.write_raw(bytes(bad))  # CRC error
    t.write_raw(encode_frame(bytes([PROTOCOL_VERSION, 0x77, 0])))  # unknown message type
    t.send(body)
    import time

    deadline = time.monotonic() + 5
    while len(sink.messages) < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    t.close()
    assert [m.payload for m in sink.messages] == [Ping(7), Ping(7)]
    assert len(sink.errors) == 3
    assert {e.status for e in sink.errors} == {-5, -8}
    assert t.stats.frame_errors == 3
    assert t.closed
    with pytest.raises(OperationError):
        t.send(body)


def test_serial_open_failure() -> None:
    with pytest.raises(InitError):
        SerialTransport("/dev/aacmm-nonexistent")
    with pytest.raises(ValueError):
        SerialTransport("")


# ---------------------------------------------------------------- CAN sample frames


def sample(seq: int, ts: int, status: int = 1) -> Sample:
    return Sample(
        seq=seq,
        timestamp_us=ts,
        counts=(1, 2**32 - 1, 3, 4000000, 5, 6),
        point_100nm=(-(2**31), 2**31 - 1, -12345),
        status=status,
    )


def feed_all(dec: SampleFrameDecoder, s: Sample, node: int) -> list[Message]:
    out: list[Message] = []
    for fr in encode_sample_frames(s, node):
        out += dec.feed(fr.arbitration_id, fr.data)
    return out


@pytest.mark.parametrize("node", [0, 1, 15])
def test_can_decoder_matches_dbc_encoding(node: int) -> None:
    dec = SampleFrameDecoder(node)
    ref = SampleAssembler(node)
    for i, seq in enumerate((0, 1, 255, 256, 2**32 - 1)):
        s = sample(seq, 1000 + i, status=0x1_0023)
        msgs = feed_all(dec, s, node)
        assert len(msgs) == 1 and msgs[0].type == MsgType.SAMPLE_EVT
        got = msgs[0].payload
        assert isinstance(got, Sample)
        for fr in encode_sample_frames(s, node):
            want = ref.feed(fr.arbitration_id, fr.data)
        assert got == want
        assert got.status == 0x0023 and got.jacobian is None
        assert msgs[0].seq == seq & 0xFF


def test_can_decoder_extends_the_timestamp() -> None:
    dec = SampleFrameDecoder(1)
    # steps below 2**31 us (36 min) between samples, across two wraps
    ts = [2**32 - 2000, 2**32 - 1000, 2**32 + 5, 2**32 + 2**31 - 7, 2**33 - 100, 2**33 + 9]
    out = []
    for i, t in enumerate(ts):
        (m,) = feed_all(dec, sample(i, t), 1)
        assert isinstance(m.payload, Sample)
        out.append(m.payload.timestamp_us)
    assert out == ts


def test_can_decoder_drops_incomplete_samples() -> None:
    dec = SampleFrameDecoder(2)
    frames = encode_sample_frames(sample(5, 10), 2)
    # header missing: the rest is dropped and counted once
    assert all(dec.feed(f.arbitration_id, f.data) == [] for f in frames[1:])
    assert dec.incomplete == 1
    # a frame missing in the middle
    for f in frames[:2] + frames[3:]:
        assert dec.feed(f.arbitration_id, f.data) == []
    assert dec.incomplete == 2
    # SeqTag mismatch
    bad = bytearray(frames[5].data)
    bad[6] ^= 1
    for f in frames[:5]:
        dec.feed(f.arbitration_id, f.data)
    assert dec.feed(frames[5].arbitration_id, bytes(bad)) == []
    assert dec.incomplete == 3
    # wrong DLC
    assert dec.feed(frames[0].arbitration_id, b"\x00") == []
    assert dec.bad_frames == 1
    # and a good one still comes through
    assert len(feed_all(dec, sample(6, 11), 2)) == 1


@pytest.mark.parametrize("trigger_first", [True, False])
def test_can_trigger_frame_pairs_with_its_sample(trigger_first: bool) -> None:
    dec = SampleFrameDecoder(1)
    s = sample(77, 1234)
    trig = (ID_TRIGGER + 1, struct.pack("<IBBH", 77, 0, 1, 0))
    out: list[Message] = []
    if trigger_first:
        out += dec.feed(*trig)
        assert out == []
    out += feed_all(dec, s, 1)
    if not trigger_first:
        out += dec.feed(*trig)
    types = [m.type for m in out]
    assert types == [MsgType.SAMPLE_EVT, MsgType.TRIGGER_EVT]
    tr = out[1].payload
    assert tr is not None and not isinstance(tr, Sample)
    assert getattr(tr, "pressed") is True  # noqa: B009
    assert getattr(tr, "sample") == out[0].payload  # noqa: B009


def test_can_trigger_without_sample_expires() -> None:
    dec = SampleFrameDecoder(1)
    dec.feed(ID_TRIGGER + 1, struct.pack("<IBBH", 9999, 0, 1, 0))
    for i in range(70):
        for m in feed_all(dec, sample(i, i), 1):
            assert m.type == MsgType.SAMPLE_EVT
    assert dec.triggers_unmatched == 1


def test_can_transport_routes_frames_and_ignores_others() -> None:
    bus = can.Bus(interface="virtual", channel="aacmm-route-test")
    t = CanTransport(bus, node_id=4)
    sink = Collect()
    t._sink = sink
    for fr in encode_sample_frames(sample(3, 4), 4):
        t.feed_frame(
            can.Message(arbitration_id=fr.arbitration_id, data=fr.data, is_extended_id=False)
        )
    t.feed_frame(can.Message(arbitration_id=0x100 + 5, data=bytes(8), is_extended_id=False))
    t.feed_frame(can.Message(arbitration_id=0x100 + 4, data=bytes(8), is_extended_id=True))
    assert [m.type for m in sink.messages] == [MsgType.SAMPLE_EVT]
    assert t.frames_foreign == 2
    t.close()


def test_fake_device_answers_codec_errors() -> None:
    dev = FakeDevice()
    (rsp,) = dev.handle(b"\x01\x77\x05")
    assert rsp.type == MsgType.ERROR_RSP and rsp.seq == 5
    assert decode_message(encode_message(rsp)) == rsp


# ---------------------------------------------------------------- host reference


def test_host_reference_numpy_matches_core() -> None:
    import hostref
    import numpy as np
    from fakedevice import DEFAULT_PARAMS

    if not hostref.have_core():
        pytest.fail("aacmm.core is not built (make setup builds it)")
    rng = np.random.default_rng(5)
    for _ in range(20):
        counts = [int(c) for c in rng.integers(0, 2**32, 6)]
        pc, jc = hostref.core_point_jacobian(DEFAULT_PARAMS, counts)
        pn, jn = hostref.numpy_point_jacobian(DEFAULT_PARAMS, counts)
        assert np.allclose(pc, pn, atol=1e-9)
        assert np.allclose(jc, jn, atol=1e-5)
