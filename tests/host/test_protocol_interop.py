"""C codec <-> Python codec interoperability, through a test-only shared library.

The library (tests/protocol/proto_shim.c, built by ``make protocol-shim``) is
the firmware's C codec with a flat byte interface. Here Hypothesis drives both
codecs with the same inputs: Python-encoded messages must decode in C and
re-encode to the same bytes, C frames must equal Python frames, both decoders
must give the same verdict and status for arbitrary bytes, and the C ISO-TP
endpoint must talk to the ``can-isotp`` package in both directions.
"""

from __future__ import annotations

import ctypes
import os
import subprocess
import time
from pathlib import Path

import isotp
import pytest
from aacmm import errors, protocol
from aacmm.protocol import Message, MsgType, framing, messages
from aacmm.protocol import can as pcan
from aacmm.protocol.status import Status
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_protocol import records, samples, st_message, unhex

ROOT = Path(__file__).resolve().parents[2]
SHIM_DEFAULT = ROOT / "build" / "protocol" / "libaacmm_proto_shim.so"

u8p = ctypes.POINTER(ctypes.c_uint8)
sizep = ctypes.POINTER(ctypes.c_size_t)
u32p = ctypes.POINTER(ctypes.c_uint32)


def _load_shim() -> ctypes.CDLL:
    path = Path(os.environ.get("AACMM_PROTO_SHIM", SHIM_DEFAULT))
    if "AACMM_PROTO_SHIM" not in os.environ:  # run outside make: build it first
        subprocess.run(
            ["make", "--no-print-directory", "-s", "protocol-shim"],
            cwd=ROOT,
            check=True,
        )
    lib = ctypes.CDLL(str(path))
    lib.shim_decode.argtypes = [ctypes.c_char_p, ctypes.c_size_t]
    lib.shim_reencode.argtypes = [
        ctypes.c_char_p,
        ctypes.c_size_t,
        u8p,
        ctypes.c_size_t,
        sizep,
    ]
    lib.shim_frame.argtypes = [
        ctypes.c_char_p,
        ctypes.c_size_t,
        u8p,
        ctypes.c_size_t,
        sizep,
    ]
    lib.shim_deframe.argtypes = [
        ctypes.c_char_p,
        ctypes.c_size_t,
        u8p,
        ctypes.c_size_t,
        sizep,
        ctypes.c_size_t,
        u32p,
    ]
    lib.shim_deframe.restype = ctypes.c_size_t
    lib.shim_can_sample.argtypes = [
        ctypes.c_char_p,
        ctypes.c_size_t,
        ctypes.c_uint8,
        u32p,
        u8p,
    ]
    lib.shim_param_crc.argtypes = [ctypes.c_char_p, ctypes.c_size_t, u32p]
    lib.shim_isotp_init.argtypes = [
        ctypes.c_uint32,
        ctypes.c_uint32,
        ctypes.c_uint8,
        ctypes.c_uint8,
        ctypes.c_size_t,
    ]
    lib.shim_isotp_on_frame.argtypes = [
        ctypes.c_uint32,
        ctypes.c_uint8,
        ctypes.c_char_p,
        ctypes.c_uint32,
    ]
    lib.shim_isotp_on_frame.restype = None
    lib.shim_isotp_poll.argtypes = [ctypes.c_uint32, u32p, u8p, u8p]
    lib.shim_isotp_send.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_uint32]
    lib.shim_isotp_receive.argtypes = [u8p, ctypes.c_size_t, sizep]
    lib.shim_isotp_stats.argtypes = [u32p]
    lib.shim_isotp_stats.restype = None
    return lib


LIB = _load_shim()


def c_reencode(body: bytes) -> tuple[int, bytes]:
    out = (ctypes.c_uint8 * 600)()
    n = ctypes.c_size_t(0)
    st_ = LIB.shim_reencode(body, len(body), out, len(out), ctypes.byref(n))
    return st_, bytes(out[: n.value])


def c_frame(body: bytes) -> bytes:
    out = (ctypes.c_uint8 * 600)()
    n = ctypes.c_size_t(0)
    assert LIB.shim_frame(body, len(body), out, len(out), ctypes.byref(n)) == 0
    return bytes(out[: n.value])


def c_deframe(wire: bytes) -> tuple[list[bytes], list[int]]:
    out = (ctypes.c_uint8 * 65536)()
    lens = (ctypes.c_size_t * 256)()
    stats = (ctypes.c_uint32 * 6)()
    count = LIB.shim_deframe(wire, len(wire), out, len(out), lens, 256, stats)
    bodies, pos = [], 0
    for i in range(count):
        bodies.append(bytes(out[pos : pos + lens[i]]))
        pos += lens[i]
    return bodies, list(stats)


def py_status(body: bytes) -> int:
    try:
        protocol.decode_message(body)
    except errors.FrameError as exc:
        return exc.status
    return 0


# ------------------------------------------------------------------ messages and frames


@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st_message())
def test_python_encoder_c_decoder_c_encoder_python_decoder(msg: Message) -> None:
    body = protocol.encode_message(msg)
    status, again = c_reencode(body)
    assert status == 0
    assert again == body  # C decoded every field and encoded it back identically
    assert protocol.decode_message(again) == msg
    assert c_frame(body) == framing.encode_frame(body)


def test_vector_messages_through_c() -> None:
    for _name, body_hex, wire_hex in records("msg"):
        body = unhex(body_hex)
        assert c_reencode(body) == (0, body)
        assert c_frame(body) == unhex(wire_hex)
    for _name, body_hex, status in records("badbody"):
        assert LIB.shim_decode(unhex(body_hex), len(unhex(body_hex))) == Status[status]


@settings(max_examples=3000, deadline=None)
@given(st.binary(max_size=400))
def test_c_and_python_agree_on_arbitrary_bodies(data: bytes) -> None:
    assert LIB.shim_decode(data, len(data)) == py_status(data)


@settings(max_examples=800, deadline=None)
@given(st.sampled_from([unhex(r[1]) for r in records("msg")]), st.data())
def test_c_and_python_agree_on_mutated_bodies(body: bytes, data: st.DataObject) -> None:
    b = bytearray(body)
    for _ in range(data.draw(st.integers(1, 4))):
        i = data.draw(st.integers(0, len(b) - 1))
        b[i] = data.draw(st.integers(0, 255))
    if data.draw(st.booleans()):
        b = b[: data.draw(st.integers(0, len(b)))]
    mutated = bytes(b)
    assert LIB.shim_decode(mutated, len(mutated)) == py_status(mutated)


@st.composite
def streams(draw: st.DrawFn) -> bytes:
    parts = []
    for _ in range(draw(st.integers(0, 8))):
        kind = draw(st.integers(0, 3))
        if kind == 0:
            parts.append(draw(st.binary(max_size=40)))
        elif kind == 1:
            wire = messages.frame_message(draw(st_message()))
            parts.append(wire[: draw(st.integers(0, len(wire)))])  # torn or whole
        else:
            parts.append(messages.frame_message(draw(st_message())))
    return b"".join(parts)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(streams())
def test_c_and_python_deframers_deliver_the_same_bodies(stream: bytes) -> None:
    c_bodies, c_stats = c_deframe(stream)
    d = framing.Deframer()
    py_bodies = d.feed(stream)
    assert c_bodies == py_bodies
    assert c_stats[0] == d.stats.frames_ok
    assert c_stats[1] == d.stats.crc_errors


@settings(max_examples=200, deadline=None)
@given(samples, st.integers(0, 15))
def test_c_can_sample_frames_equal_python_and_decode_with_dbc(sample: object, node: int) -> None:
    assert isinstance(sample, protocol.Sample)
    body = protocol.encode_message(Message(MsgType.SAMPLE_EVT, 0, sample))
    ids = (ctypes.c_uint32 * 7)()
    data = (ctypes.c_uint8 * 56)()
    n = LIB.shim_can_sample(body, len(body), node, ids, data)
    assert n == (5, 6, 6, 7)[len(sample.counts) - 4]
    c_frames = [(ids[i], bytes(data[8 * i : 8 * i + 8])) for i in range(n)]
    py_frames = [(f.arbitration_id, f.data) for f in pcan.encode_sample_frames(sample, node)]
    assert c_frames == py_frames
    asm = pcan.SampleAssembler(node)
    got = [asm.feed(i, d) for i, d in c_frames][-1]
    assert got is not None and got.counts == sample.counts and got.point_100nm == sample.point_100nm


def test_param_set_crc_agrees() -> None:
    import gen_protocol_vectors as gen

    payload = protocol.encode_param_set(gen.PARAMS)
    crc = ctypes.c_uint32(0)
    assert LIB.shim_param_crc(payload, len(payload), ctypes.byref(crc)) == 0
    assert crc.value == protocol.param_set_crc32(gen.PARAMS)


# ------------------------------------------------------------------ ISO-TP against can-isotp


class Link:
    """The C endpoint (device side) and a can-isotp TransportLayerLogic (host side)."""

    def __init__(self, node: int, bs: int, stmin: int, rx_cap: int = 4095) -> None:
        self.dev_tx = pcan.ID_ISOTP_RESPONSE + node
        self.dev_rx = pcan.ID_ISOTP_REQUEST + node
        assert LIB.shim_isotp_init(self.dev_tx, self.dev_rx, bs, stmin, rx_cap) == 0
        self.to_host: list[isotp.CanMessage] = []
        self.host = isotp.TransportLayerLogic(
            rxfn=lambda _t: self.to_host.pop(0) if self.to_host else None,
            txfn=self._host_tx,
            address=pcan.isotp_address(node),
            params=pcan.isotp_params(timeout_ms=10000),  # loaded CI machines
        )
        self.host.set_sleep_timing(0, 0)

    @property
    def now(self) -> int:
        """The device clock: wall-clock milliseconds (can-isotp times STmin in real time)."""
        return int(time.monotonic() * 1000) & 0xFFFFFFFF

    def _host_tx(self, msg: isotp.CanMessage) -> None:
        data = bytes(msg.data)
        LIB.shim_isotp_on_frame(msg.arbitration_id, len(data), data.ljust(8, b"\0"), self.now)

    def step(self) -> None:
        fid = ctypes.c_uint32()
        dlc = ctypes.c_uint8()
        buf = (ctypes.c_uint8 * 8)()
        while LIB.shim_isotp_poll(self.now, ctypes.byref(fid), ctypes.byref(dlc), buf):
            self.to_host.append(
                isotp.CanMessage(arbitration_id=fid.value, dlc=dlc.value, data=bytes(buf))
            )
        self.host.process()

    def device_receive(self) -> bytes | None:
        out = (ctypes.c_uint8 * 4095)()
        n = ctypes.c_size_t()
        if LIB.shim_isotp_receive(out, len(out), ctypes.byref(n)):
            return bytes(out[: n.value])
        return None

    def stats(self) -> list[int]:
        s = (ctypes.c_uint32 * 11)()
        LIB.shim_isotp_stats(s)
        return list(s)


@pytest.mark.parametrize(("bs", "stmin"), [(0, 0), (1, 0), (4, 1), (8, 0xF5)])
def test_host_can_isotp_to_c_device(bs: int, stmin: int) -> None:
    link = Link(node=3, bs=bs, stmin=stmin)
    for size in (1, 6, 7, 8, 62, 63, 281, 356, 512, 4095):
        payload = bytes((i * 31 + size) & 0xFF for i in range(size))
        link.host.send(payload)
        got = None
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            link.step()
            got = got or link.device_receive()
            if got is not None and not link.host.transmitting():
                break
        assert got == payload, (size, link.stats())
    assert link.stats()[2:7] == [0, 0, 0, 0, 0], link.stats()  # no sequence errors, timeouts, ...


@pytest.mark.parametrize("size", [1, 7, 8, 100, 356, 512, 4095])
def test_c_device_to_host_can_isotp(size: int) -> None:
    link = Link(node=9, bs=0, stmin=0)
    payload = bytes((i * 7 + 3) & 0xFF for i in range(size))
    assert LIB.shim_isotp_send(payload, len(payload), link.now) == 0
    got = None
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        link.step()
        if link.host.available():
            got = link.host.recv()
            break
    assert got is not None and bytes(got) == payload
    assert LIB.shim_isotp_tx_result() == 0


@settings(max_examples=60, deadline=None)
@given(st_message())
def test_messages_over_isotp_both_ways(msg: Message) -> None:
    body = protocol.encode_message(msg)
    link = Link(node=0, bs=2, stmin=0)
    link.host.send(body)
    got = None
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        link.step()
        got = got or link.device_receive()
        if got is not None:
            break
    assert got is not None and protocol.decode_message(got) == msg
    assert LIB.shim_isotp_send(body, len(body), link.now) == 0
    back = None
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        link.step()
        if link.host.available():
            back = link.host.recv()
            break
    assert back is not None and protocol.decode_message(back) == msg


def test_c_device_refuses_oversize_with_flow_control_overflow() -> None:
    link = Link(node=1, bs=0, stmin=0, rx_cap=64)
    errors_seen: list[Exception] = []
    link.host.error_handler = errors_seen.append
    link.host.send(bytes(100))
    for _ in range(200):
        link.step()
    assert link.device_receive() is None
    assert link.stats()[4] == 1  # rx_overflows
    assert not link.host.transmitting()
