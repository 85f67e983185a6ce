"""Python link-protocol codec: shared vectors, C header agreement, Hypothesis properties."""

from __future__ import annotations

import importlib.util
import itertools
import math
import re
import struct
import sys
from dataclasses import replace
from enum import IntEnum
from pathlib import Path
from types import ModuleType

import isotp
import pytest
from aacmm import errors, protocol
from aacmm.protocol import (
    ComputeRequest,
    ComputeResult,
    DeviceInfo,
    Diagnostics,
    ErrorReply,
    JointDiagnostics,
    MeasureRequest,
    Message,
    MsgType,
    ParamCrc,
    ParamSet,
    Ping,
    Sample,
    Stream,
    Trigger,
    constants,
    framing,
    layout,
    messages,
)
from aacmm.protocol import can as pcan
from aacmm.protocol.status import Status
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[2]
INCLUDE = ROOT / "firmware" / "include" / "aacmm"
VECTOR_FILE = ROOT / "tests" / "vectors" / "protocol_vectors.txt"


def _load_generator() -> ModuleType:
    path = ROOT / "tests" / "vectors" / "gen_protocol_vectors.py"
    spec = importlib.util.spec_from_file_location("gen_protocol_vectors", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules["gen_protocol_vectors"] = mod
    spec.loader.exec_module(mod)
    return mod


GEN = _load_generator()


def records(kind: str) -> list[list[str]]:
    out = []
    for line in VECTOR_FILE.read_text().splitlines():
        if line and not line.startswith("#"):
            fields = line.split()
            if fields[0] == kind:
                out.append(fields[1:])
    return out


def unhex(text: str) -> bytes:
    return b"" if text == "-" else bytes.fromhex(text)


# ------------------------------------------------------------------ strategies

u8 = st.integers(0, 0xFF)
u16 = st.integers(0, 0xFFFF)
u32 = st.integers(0, 0xFFFFFFFF)
u64 = st.integers(0, 0xFFFFFFFFFFFFFFFF)
i32 = st.integers(-(2**31), 2**31 - 1)
f64 = st.floats(allow_nan=False, allow_infinity=False)
f32 = st.floats(allow_nan=False, allow_infinity=False, width=32)
seq_ = st.integers(0, 0xFF)


def tup(s: st.SearchStrategy[object], n: int) -> st.SearchStrategy[tuple[object, ...]]:
    return st.tuples(*([s] * n))


i16 = st.integers(-0x8000, 0x7FFF)
joints_ = st.integers(4, 7)


def jacobians(p: int) -> st.SearchStrategy[object]:
    return st.none() | tup(tup(f32, p), 3)


@st.composite
def param_sets(draw: st.DrawFn) -> ParamSet:
    """Arm models of 4 to 7 joints: conventions, betas (never joint 1), a tip
    vector or l, and sometimes issue 27's error model."""
    n = draw(joints_)
    cpr = draw(tup(st.integers(2, 2**32), n))
    zero = tuple(draw(st.integers(0, min(c, 2**32) - 1)) for c in cpr)  # type: ignore[call-overload]
    conv = draw(st.just(()) | tup(st.integers(0, 1), n))
    beta = draw(st.just(()) | st.tuples(st.none(), *([st.none() | f64] * (n - 1))))
    ks = tuple(draw(st.sampled_from([0, 1, 2, 4])) for _ in range(n))  # K_i per joint
    if draw(st.booleans()):
        ks = (0,) * n
    harm = tuple(tuple(draw(tup(i16, k))) for k in ks) if any(ks) else ()
    harm_s = tuple(tuple(draw(tup(i16, k))) for k in ks) if any(ks) else ()
    thermal = draw(st.booleans())
    return ParamSet(
        theta_offset_rad=draw(tup(f64, n)),  # type: ignore[arg-type]
        alpha_rad=draw(tup(f64, n)),  # type: ignore[arg-type]
        d_mm=draw(tup(f64, n)),  # type: ignore[arg-type]
        a_mm=draw(tup(f64, n)),  # type: ignore[arg-type]
        l_mm=draw(f64),
        counts_per_rev=cpr,  # type: ignore[arg-type]
        zero_offset_counts=zero,
        direction=draw(tup(st.sampled_from([1, -1]), n)),  # type: ignore[arg-type]
        convention=conv,  # type: ignore[arg-type]
        beta_rad=beta,
        tip_xy_mm=draw(st.none() | st.tuples(f64, f64)),
        harm_cos=harm,  # type: ignore[arg-type]
        harm_sin=harm_s,  # type: ignore[arg-type]
        cte=draw(tup(i16, n)) if thermal else (),  # type: ignore[arg-type]
        ref_temp=draw(st.integers(-4000, 8500)) if thermal else 0,
    )


@st.composite
def samples_(draw: st.DrawFn) -> Sample:
    n = draw(joints_)
    p = draw(st.integers(4 * n + 1, 5 * n + 2))
    jac = draw(jacobians(p))
    temp = draw(st.none() | tup(i16, n))  # any i16: what the sensor said
    if jac is not None and layout.sample_bytes(n, p, True, True) > layout.SAMPLE_MAX_BYTES:
        temp = None  # N 7, P 37 cannot carry both (the encoders refuse it)
    return Sample(
        seq=draw(u32),
        timestamp_us=draw(u64),
        counts=draw(tup(u32, n)),  # type: ignore[arg-type]
        point_100nm=draw(tup(i32, 3)),  # type: ignore[arg-type]
        status=draw(u32),
        jacobian=jac,  # type: ignore[arg-type]
        params=p,
        temp=temp,  # type: ignore[arg-type]
    )


temps_c = st.integers(layout.REF_TEMP_MIN, layout.REF_TEMP_MAX)


@st.composite
def compute_requests(draw: st.DrawFn) -> ComputeRequest:
    n = draw(joints_)
    return ComputeRequest(
        draw(tup(u32, n)),  # type: ignore[arg-type]
        draw(st.booleans()),
        draw(st.none() | tup(temps_c, n)),  # type: ignore[arg-type]
    )


@st.composite
def compute_results(draw: st.DrawFn) -> ComputeResult:
    p = draw(st.integers(17, 37))
    return ComputeResult(draw(u32), draw(tup(f64, 3)), draw(jacobians(p)), p, draw(st.booleans()))  # type: ignore[arg-type]


@st.composite
def infos(draw: st.DrawFn) -> DeviceInfo:
    n = draw(joints_)
    return DeviceInfo(
        draw(u16),
        draw(u8),
        draw(u8),
        draw(u16),
        draw(u32),
        draw(u32),
        draw(st.integers(0, 2)),
        draw(st.integers(0, 3)),
        draw(u16),
        draw(u32),
        draw(st.integers(0, 15)),
        n,
        draw(st.integers(4 * n + 1, 5 * n + 2)),
    )


samples = samples_()

PAYLOADS: dict[MsgType, st.SearchStrategy[object]] = {
    MsgType.PING_REQ: st.builds(Ping, u32),
    MsgType.PING_RSP: st.builds(Ping, u32),
    MsgType.INFO_RSP: infos(),
    MsgType.SET_PARAMS_REQ: param_sets(),
    MsgType.GET_PARAMS_RSP: param_sets(),
    MsgType.SET_PARAMS_RSP: st.builds(ParamCrc, u32),
    MsgType.SAVE_PARAMS_RSP: st.builds(ParamCrc, u32),
    MsgType.RESTORE_DEFAULTS_RSP: st.builds(ParamCrc, u32),
    MsgType.MEASURE_REQ: st.builds(MeasureRequest, st.booleans(), st.booleans()),
    MsgType.MEASURE_RSP: samples,
    MsgType.SAMPLE_EVT: samples,
    MsgType.COMPUTE_REQ: compute_requests(),
    MsgType.COMPUTE_RSP: compute_results(),
    MsgType.STREAM_START_REQ: st.builds(Stream, st.integers(1, 1000), st.booleans(), st.booleans()),
    MsgType.STREAM_START_RSP: st.builds(Stream, st.integers(1, 1000), st.booleans(), st.booleans()),
    MsgType.TRIGGER_EVT: st.builds(Trigger, u8, st.booleans(), samples),
    MsgType.ERROR_RSP: st.builds(ErrorReply, st.integers(-0x8000, -1), u8),
    MsgType.DIAG_RSP: st.builds(
        Diagnostics,
        storage_kind=st.integers(0, 5),
        storage_flags=st.integers(0, 1),
        slot_state=tup(st.integers(0, 9), 2),
        slot_generation=tup(u32, 2),
        storage_errors=u32,
        storage_bad_records=u32,
        reset_cause=st.integers(0, 5),
        reset_raw=u32,
        fault_pc=u32,
        boot_count=u32,
        watchdog_ms=u16,
        uptime_us=u64,
        encoder_faults=u32,
        serial_frames_bad=u32,
        samples_dropped=u32,
        samples_late=u32,
        joints=joints_.flatmap(
            lambda n: tup(
                st.builds(
                    JointDiagnostics,
                    st.integers(0, 3),
                    st.integers(0, 32),
                    st.integers(0, 8),
                    u32,
                    u32,
                ),
                n,
            )
        ),
        temp_faults=u32,
    ),
}


@st.composite
def st_message(draw: st.DrawFn) -> Message:
    t = draw(st.sampled_from(list(MsgType)))
    payload = draw(PAYLOADS[t]) if t in PAYLOADS else None
    return Message(t, draw(seq_), payload)  # type: ignore[arg-type]


# ------------------------------------------------------------------ vectors


def test_crc_check_value_and_vectors() -> None:
    assert framing.crc32(b"123456789") == 0xCBF43926 == framing.CRC32_CHECK
    rows = records("crc")
    assert len(rows) >= 4
    for _name, data, crc in rows:
        assert framing.crc32(unhex(data)) == int(crc, 16)


def test_vector_file_is_up_to_date() -> None:
    assert VECTOR_FILE.read_text() == GEN.render(), "run tests/vectors/gen_protocol_vectors.py"
    corpus_dir = ROOT / "tests" / "protocol" / "corpus"
    for name, data in GEN.corpus().items():
        assert (corpus_dir / name).read_bytes() == data, f"stale fuzz seed {name}"


def test_message_vectors_decode_to_the_named_values() -> None:
    expected = GEN.messages()
    rows = records("msg")
    assert len(rows) == len(expected) == 40
    assert {m.type for m in expected.values()} == set(MsgType)  # every type has a vector
    for name, body_hex, wire_hex in rows:
        body, wire = unhex(body_hex), unhex(wire_hex)
        msg = protocol.decode_message(body)
        assert msg == expected[name], name
        assert protocol.encode_message(expected[name]) == body
        assert framing.encode_frame(body) == wire
        assert messages.frame_message(expected[name]) == wire
        assert framing.decode_frame(wire[1:-1]) == body


def test_bad_body_vectors_fail_with_the_named_status() -> None:
    rows = records("badbody")
    assert len(rows) >= 30
    for name, body_hex, status in rows:
        with pytest.raises(errors.FrameError) as info:
            protocol.decode_message(unhex(body_hex))
        assert info.value.status == Status[status], name


def test_version_4_layouts_packed_by_hand() -> None:
    """Version 4's temperature fields where docs/protocol.md 2.4 to 2.6 put them,
    packed here with struct from the spec's layout (not with the codec)."""
    s = GEN.SAMPLE_T
    want = struct.pack(
        "<IQ3iIBBB6I6h",
        s.seq,
        s.timestamp_us,
        *s.point_100nm,
        s.status,
        0x02,  # content: TEMPERATURES
        6,
        25,
        *s.counts,
        *s.temp,
    )
    assert protocol.encode_message(GEN.messages()["sample_evt_t"])[3:] == want
    assert want[-4:-2] == b"\x00\x80"  # TEMP_NONE on the wire
    s7 = GEN.SAMPLE_7TJ
    assert s7.jacobian is not None and s7.temp is not None
    want7 = struct.pack(
        "<IQ3iIBBB7I7h108f",
        s7.seq,
        s7.timestamp_us,
        *s7.point_100nm,
        s7.status,
        0x03,  # JACOBIAN | TEMPERATURES: the temperatures before the Jacobian
        7,
        36,
        *s7.counts,
        *s7.temp,
        *(v for row in s7.jacobian for v in row),
    )
    assert len(want7) == layout.SAMPLE_MAX_BYTES == 505
    assert protocol.encode_message(GEN.messages()["measure_rsp7_tj"])[3:] == want7
    c = GEN.COMPUTE_REQ_T
    assert protocol.encode_message(GEN.messages()["compute_req_tj"])[3:] == struct.pack(
        "<BB6I6h", 0x03, 6, *c.counts, *c.temp
    )
    r = GEN.COMPUTE_RSP_T
    assert protocol.encode_message(GEN.messages()["compute_rsp_t"])[3:] == struct.pack(
        "<I3dBB", r.status, *r.point_mm, 0x02, 25
    )
    diag = protocol.encode_message(GEN.messages()["diag_rsp_tf"])[3:]
    assert len(diag) == 60 + 6 * 11 + 4
    assert diag[-4:] == struct.pack("<I", 0x89ABCDEF)
    assert diag[:-4] == protocol.encode_message(GEN.messages()["diag_rsp"])[3:-4]
    assert protocol.encode_message(GEN.messages()["measure_req_tj"])[3:] == b"\x03"
    assert protocol.encode_message(GEN.messages()["stream_start_req_t"])[3:] == struct.pack(
        "<HB", 100, 0x02
    )


def test_version_errors_name_the_old_version() -> None:
    """A body of version 1, 2 or 3 is named with what it lacks; any other with its number."""
    ping = protocol.encode_message(GEN.messages()["ping_req"])
    for version, what in (
        (1, "six joints, before arm models"),
        (2, "arm models, before the error model"),
        (3, "before device temperatures"),
    ):
        with pytest.raises(errors.FrameError) as info:
            protocol.decode_message(bytes([version]) + ping[1:])
        assert info.value.status == Status.ERR_VERSION and info.value.version == version
        assert str(info.value) == (
            f"protocol version {version} ({what}); this host speaks version 4"
        )
    with pytest.raises(errors.FrameError) as info:
        protocol.decode_message(bytes([5]) + ping[1:])
    assert str(info.value) == "protocol version 5; this host speaks version 4"


def test_bad_frame_vectors_are_dropped_counted_and_resynchronised() -> None:
    good = unhex(records("msg")[0][2])
    for name, wire_hex, counter in records("badframe"):
        d = framing.Deframer()
        assert d.feed(unhex(wire_hex)) == [], name
        assert getattr(d.stats, counter) == 1, name
        assert d.stats.frames_ok == 0
        assert d.last_error is not None
        assert d.feed(good) == [unhex(records("msg")[0][1])]


def test_deframer_any_chunking_with_garbage() -> None:
    rows = records("msg")
    stream = b""
    for _, _, wire in rows:
        stream += unhex(wire) + b"\x13\x37\x00\xff\x01"
    for _, wire, _ in records("badframe"):
        stream += unhex(wire)
    stream += unhex(rows[0][2])
    want = [unhex(b) for _, b, _ in rows] + [unhex(rows[0][1])]
    for chunk in (1, 2, 5, 64, len(stream)):
        d = framing.Deframer()
        got: list[bytes] = []
        for i in range(0, len(stream), chunk):
            got += d.feed(stream[i : i + chunk])
        assert got == want
        assert d.stats.frames_ok == len(want)


def test_can_sample_vectors_and_assembler() -> None:
    rows = records("can")
    frames = pcan.encode_sample_frames(GEN.SAMPLE_A, node_id=5)
    sample_rows = [r for r in rows if r[0].startswith("sample_a_n5_")]
    assert [(f.arbitration_id, f.data) for f in frames] == [
        (int(i, 16), unhex(d)) for _, i, d in sample_rows
    ]
    asm = pcan.SampleAssembler(node_id=5)
    out = [asm.feed(int(i, 16), unhex(d)) for _, i, d in sample_rows]
    assert out[:-1] == [None] * 5
    s = GEN.SAMPLE_A
    assert out[-1] == Sample(
        s.seq, s.timestamp_us & 0xFFFFFFFF, s.counts, s.point_100nm, s.status & 0xFFFF
    )
    # physical values through cantools with scaling: 1e-4 mm per LSB
    db = pcan.load_dbc()
    phys = db.decode_message(0x140, unhex(sample_rows[4][2]))
    assert isinstance(phys, dict)
    assert math.isclose(float(phys["X"]), 1234.5678, abs_tol=1e-9)  # type: ignore[arg-type]
    # temperatures do not travel over CAN; the TEMP_FAULT status bit does
    t_rows = [r for r in rows if r[0].startswith("sample_t_n1_")]
    t_frames = pcan.encode_sample_frames(GEN.SAMPLE_T, node_id=1)
    assert [(f.arbitration_id, f.data) for f in t_frames] == [
        (int(i, 16), unhex(d)) for _, i, d in t_rows
    ]
    t_asm = pcan.SampleAssembler(node_id=1)
    t_out = [t_asm.feed(int(i, 16), unhex(d)) for _, i, d in t_rows][-1]
    assert t_out is not None and t_out.temp is None
    assert t_out.status == protocol.SampleStatus.POINT_VALID | protocol.SampleStatus.TEMP_FAULT
    (trig,) = [r for r in rows if r[0] == "trigger_n5"]
    assert int(trig[1], 16) == pcan.ID_TRIGGER + 5
    assert pcan.decode_trigger_frame(unhex(trig[2])) == pcan.TriggerFrame(s.seq, 0, True)
    with pytest.raises(errors.FrameError):
        pcan.decode_trigger_frame(unhex(trig[2])[:7])
    with pytest.raises(errors.FrameError):
        pcan.decode_trigger_frame(unhex(trig[2])[:5] + b"\x02\x00\x00")


def test_assembler_drops_incomplete_and_foreign() -> None:
    s = GEN.SAMPLE_A
    frames = pcan.encode_sample_frames(s, node_id=2)
    asm = pcan.SampleAssembler(node_id=2)
    # missing Counts34: dropped, then a complete sample gets through
    for f in frames[:2] + frames[3:]:
        assert asm.feed(f.arbitration_id, f.data) is None
    assert asm.stats.incomplete == 1
    assert asm.feed(0x105, frames[0].data) is None  # node 5 frame: foreign
    assert asm.stats.foreign == 1
    assert asm.feed(frames[0].arbitration_id, frames[0].data[:7]) is None  # bad DLC
    assert asm.stats.bad_frames == 1
    got = [asm.feed(f.arbitration_id, f.data) for f in frames]
    assert got[-1] is not None and got[-1].counts == s.counts
    # mismatched SeqTag: the tail belongs to another sample
    other = pcan.encode_sample_frames(Sample(7, 0, (0,) * 6, (0, 0, 0), 0), node_id=2)
    for f in frames[:5] + other[5:]:
        assert asm.feed(f.arbitration_id, f.data) is None
    assert asm.stats.samples == 1


def test_isotp_vectors_reassemble_with_can_isotp() -> None:
    rows = records("isotp")
    assert len(rows) == 5
    for name, tx_hex, msg_hex, frames_hex in rows:
        tx = int(tx_hex, 16)
        rx = tx - 0x80 if tx >= pcan.ID_ISOTP_RESPONSE else tx + 0x80
        queue = [
            isotp.CanMessage(arbitration_id=tx, dlc=8, data=unhex(f)) for f in frames_hex.split(",")
        ]
        sent: list[isotp.CanMessage] = []
        addr = isotp.Address(isotp.AddressingMode.Normal_11bits, txid=rx, rxid=tx)

        def rxfn(_timeout: float, q: list[isotp.CanMessage] = queue) -> isotp.CanMessage | None:
            return q.pop(0) if q else None

        tp = isotp.TransportLayerLogic(
            rxfn=rxfn,
            txfn=sent.append,
            address=addr,
            params=pcan.isotp_params(),
        )
        for _ in range(100):
            tp.process()
        got = tp.recv()
        assert got is not None and bytes(got) == unhex(msg_hex), name
        assert all(m.data[0] >> 4 == 3 for m in sent)  # only flow control went back


# ------------------------------------------------------------------ one definition


def _c_defines(header: str) -> dict[str, int]:
    text = (INCLUDE / header).read_text()
    out = {}
    for name, value in re.findall(r"#define\s+(AACMM_\w+)\s+(0x[0-9A-Fa-f]+|\d+)u?\b", text):
        out[name] = int(value, 0)
    return out


def test_c_can_ids_match_dbc_and_python() -> None:
    d = _c_defines("proto_can.h")
    db = pcan.load_dbc()
    pairs = {
        "AACMM_CAN_ID_SAMPLE_HEADER": ("AACMM_SampleHeader", pcan.ID_SAMPLE_HEADER),
        "AACMM_CAN_ID_COUNTS_12": ("AACMM_Counts12", pcan.ID_COUNTS_12),
        "AACMM_CAN_ID_COUNTS_34": ("AACMM_Counts34", pcan.ID_COUNTS_34),
        "AACMM_CAN_ID_COUNTS_56": ("AACMM_Counts56", pcan.ID_COUNTS_56),
        "AACMM_CAN_ID_COUNTS_7": ("AACMM_Counts7", pcan.ID_COUNTS_7),
        "AACMM_CAN_ID_POINT_XY": ("AACMM_PointXY", pcan.ID_POINT_XY),
        "AACMM_CAN_ID_POINT_Z": ("AACMM_PointZ", pcan.ID_POINT_Z),
        "AACMM_CAN_ID_TRIGGER": ("AACMM_Trigger", pcan.ID_TRIGGER),
        "AACMM_CAN_ID_ISOTP_REQUEST": ("AACMM_IsoTpRequest", pcan.ID_ISOTP_REQUEST),
        "AACMM_CAN_ID_ISOTP_RESPONSE": ("AACMM_IsoTpResponse", pcan.ID_ISOTP_RESPONSE),
    }
    for cname, (dbc_name, py_id) in pairs.items():
        assert d[cname] == db.get_message_by_name(dbc_name).frame_id == py_id, cname
    assert len(db.messages) == len(pairs)
    assert d["AACMM_CAN_NODE_ID_MAX"] == pcan.NODE_ID_MAX
    assert d["AACMM_CAN_SAMPLE_FRAMES_MAX"] == len(pcan.SAMPLE_FRAME_IDS)
    # the C macro AACMM_CAN_SAMPLE_FRAMES(n) = 3 + (n + 1) / 2, as the Python sequence
    assert [len(pcan.sample_frame_ids(n)) for n in range(4, 8)] == [
        3 + (n + 1) // 2 for n in range(4, 8)
    ]
    # node ids never collide: 16 nodes fit between consecutive bases
    bases = sorted(p[1] for p in pairs.values())
    assert all(b - a >= 16 for a, b in itertools.pairwise(bases))
    for m in db.messages:
        assert m.length == 8 and not m.is_extended_frame
        for sig in m.signals:
            assert sig.byte_order == "little_endian"


def test_c_message_types_and_sizes_match_python() -> None:
    text = (INCLUDE / "proto.h").read_text()
    c_types = {
        name: int(value, 0)
        for name, value in re.findall(
            r"AACMM_MSG_(\w+_(?:REQ|RSP|EVT))\s*=\s*(0x[0-9A-Fa-f]+)", text
        )
    }
    assert c_types == {t.name: int(t) for t in MsgType}
    d = _c_defines("proto.h")
    assert d["AACMM_PROTO_VERSION"] == protocol.PROTOCOL_VERSION
    assert d["AACMM_PROTO_MAX_BODY"] == constants.MAX_BODY == framing.MAX_BODY
    assert d["AACMM_PROTO_VERSION"] == constants.PROTOCOL_VERSION == 4
    assert d["AACMM_PROTO_VERSION_PREVIOUS"] == constants.PROTOCOL_VERSION_PREVIOUS == 3
    assert set(constants.OLD_PROTOCOL_VERSIONS) == set(
        range(constants.PROTOCOL_VERSION_OLDEST, constants.PROTOCOL_VERSION_PREVIOUS + 1)
    )
    assert d["AACMM_PROTO_VERSION_OLDEST"] == constants.PROTOCOL_VERSION_OLDEST == 1
    assert re.search(r"#define AACMM_REF_TEMP_MIN \((-\d+)\)", text)[1] == str(layout.REF_TEMP_MIN)  # type: ignore[index]
    assert d["AACMM_REF_TEMP_MAX"] == layout.REF_TEMP_MAX
    assert d["AACMM_PARAM_THERMAL_BIT"] == layout.PARAM_THERMAL_BIT
    # the paper's set: header, 25 f64, then u32 cpr - 1, u32 zero, i8 direction per joint
    paper = struct.calcsize("<8B25d6I6I6b")
    assert d["AACMM_PARAM_SET_PAPER_BYTES"] == layout.PARAM_SET_BYTES == paper
    assert (
        d["AACMM_PARAM_SET_MAX_BYTES"]
        == layout.PARAM_SET_MAX_BYTES
        == layout.param_set_bytes(7, 37, 28, 1)
    )
    assert layout.PARAM_SET_MAX_BYTES <= constants.MAX_BODY - constants.HEADER_BYTES
    assert d["AACMM_PARAM_SET_HEADER_BYTES"] == layout.PARAM_SET_HEADER_BYTES
    assert d["AACMM_HARMONICS_MAX"] == layout.HARMONICS_MAX
    assert d["AACMM_INFO_BYTES"] == layout.INFO_BYTES == layout.INFO_LAYOUT.size
    assert d["AACMM_SAMPLE_BASE_BYTES"] == layout.SAMPLE_BASE_BYTES == layout.SAMPLE_LAYOUT.size
    payload_max = constants.MAX_BODY - constants.HEADER_BYTES
    assert d["AACMM_SAMPLE_MAX_BYTES"] == layout.SAMPLE_MAX_BYTES == 505
    assert layout.SAMPLE_MAX_BYTES == max(
        layout.sample_bytes(n, p, jac, temps)
        for n in range(constants.JOINTS_MIN, constants.JOINTS_MAX + 1)
        for p in range(4 * n + 1, 5 * n + 3)
        for jac in (False, True)
        for temps in (False, True)
        if layout.sample_bytes(n, p, jac, temps) <= payload_max
    )
    assert layout.sample_bytes(7, 37, True, True) > payload_max  # the one refused
    assert layout.sample_bytes(7, 36, True, True) == layout.SAMPLE_MAX_BYTES
    assert layout.TRIGGER_EXTRA_BYTES + layout.SAMPLE_MAX_BYTES <= payload_max
    assert d["AACMM_COMPUTE_RSP_BASE_BYTES"] == layout.COMPUTE_RSP_BASE_BYTES
    assert d["AACMM_DIAG_BASE_BYTES"] == layout.DIAG_BASE_BYTES == layout.DIAG_LAYOUT.size
    assert d["AACMM_CONTENT_JACOBIAN"] == protocol.Content.JACOBIAN
    assert d["AACMM_CONTENT_TEMPERATURES"] == protocol.Content.TEMPERATURES
    assert d["AACMM_CONTENT_KNOWN"] == protocol.Content.JACOBIAN | protocol.Content.TEMPERATURES
    assert "#define AACMM_TEMP_NONE INT16_MIN" in text and constants.TEMP_NONE == -(2**15)
    assert d["AACMM_DIAG_TAIL_BYTES"] == layout.DIAG_TAIL_BYTES == 4
    for flag in protocol.SampleStatus:
        assert d[f"AACMM_SAMPLE_{flag.name}"] == flag.value
    for build in protocol.BuildFlags:
        assert d[f"AACMM_BUILD_{build.name}"] == build.value
    assert d["AACMM_DIAG_JOINT_BYTES"] == layout.DIAG_JOINT_BYTES
    assert layout.DIAG_BYTES == 130  # 60 + 6 * 11 + 4 (the C macro is an expression)
    enums: list[tuple[str, type[IntEnum], str]] = [
        ("AACMM_PARAM_SOURCE_", protocol.ParamSource, "AACMM_PARAM_SOURCE_MAX"),
        ("AACMM_STORAGE_KIND_", protocol.StorageKind, "AACMM_STORAGE_KIND_MAX"),
        ("AACMM_SLOT_", protocol.SlotState, "AACMM_SLOT_STATE_MAX"),
        ("AACMM_RESET_", protocol.ResetCause, "AACMM_RESET_CAUSE_MAX"),
        ("AACMM_ENC_", protocol.EncoderInterface, "AACMM_ENC_INTERFACE_MAX"),
        ("AACMM_ENC_FAULT_", protocol.EncoderFault, "AACMM_ENC_FAULT_MAX"),
    ]
    for prefix, enum, max_name in enums:
        for member in enum:
            assert d[prefix + member.name] == member.value, prefix + member.name
        assert d[max_name] == max(enum)
    assert d["AACMM_STORAGE_PERSISTENT"] == protocol.StorageFlags.PERSISTENT
    f = _c_defines("frame.h")
    assert f["AACMM_FRAME_MAX_BODY"] == framing.MAX_BODY
    assert _c_defines("crc32.h")["AACMM_CRC32_CHECK"] == framing.CRC32_CHECK


def test_status_enum_matches_c_header() -> None:
    text = (INCLUDE / "status.h").read_text()
    c = {n: int(v) for n, v in re.findall(r"AACMM_(OK|ERR_\w+)\s*=\s*(-?\d+)", text)}
    assert c == {s.name: int(s) for s in Status}


# ------------------------------------------------------------------ properties


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st_message())
def test_round_trip(msg: Message) -> None:
    body = protocol.encode_message(msg)
    assert constants.HEADER_BYTES <= len(body) <= constants.MAX_BODY
    assert protocol.decode_message(body) == msg
    wire = framing.encode_frame(body)
    assert len(wire) <= framing.MAX_WIRE
    assert b"\x00" not in wire[1:-1]
    assert framing.Deframer().feed(wire) == [body]


@settings(max_examples=1500, deadline=None)
@given(st.binary(max_size=600))
def test_arbitrary_bodies_raise_only_frame_error(data: bytes) -> None:
    try:
        msg = protocol.decode_message(data)
    except errors.FrameError as exc:
        assert exc.status < 0
    else:
        assert protocol.encode_message(msg) == data  # canonical


@settings(max_examples=300, deadline=None)
@given(st.binary(min_size=1, max_size=3), st.binary(max_size=400))
def test_mutated_valid_bodies_raise_only_frame_error(prefix: bytes, tail: bytes) -> None:
    body = unhex(records("msg")[13][1])
    data = body[: len(prefix)] + prefix + tail
    try:
        protocol.decode_message(data)
    except errors.FrameError:
        pass


@settings(max_examples=500, deadline=None)
@given(st.binary(max_size=2000), st.integers(1, 64))
def test_deframer_arbitrary_bytes_never_raise(data: bytes, chunk: int) -> None:
    d = framing.Deframer()
    for i in range(0, len(data), chunk):
        for body in d.feed(data[i : i + chunk]):
            assert framing.MIN_BODY <= len(body) <= framing.MAX_BODY
    # and it still works afterwards
    good = framing.encode_frame(b"\x01\x02\x03")
    assert d.feed(good) == [b"\x01\x02\x03"]


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=700))
def test_decode_frame_raises_only_frame_error(data: bytes) -> None:
    try:
        body = framing.decode_frame(data)
    except errors.FrameError as exc:
        assert exc.status in (Status.ERR_FRAME, Status.ERR_LENGTH, Status.ERR_CRC)
    else:
        assert framing.MIN_BODY <= len(body) <= framing.MAX_BODY


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 0x7FF), st.binary(max_size=8)), max_size=40))
def test_assembler_arbitrary_frames_never_raise(
    frames: list[tuple[int, bytes]],
) -> None:
    asm = pcan.SampleAssembler(node_id=1)
    for fid, data in frames:
        asm.feed(fid, data)


@settings(max_examples=200, deadline=None)
@given(samples, st.integers(0, 15))
def test_can_sample_round_trip(sample: Sample, node: int) -> None:
    asm = pcan.SampleAssembler(node_id=node)
    out = [asm.feed(f.arbitration_id, f.data) for f in pcan.encode_sample_frames(sample, node)]
    assert out[-1] == Sample(
        sample.seq,
        sample.timestamp_us & 0xFFFFFFFF,
        sample.counts,
        sample.point_100nm,
        sample.status & 0xFFFF,
        params=4 * len(sample.counts) + 1,  # the frames carry no P
    )


# ------------------------------------------------------------------ arguments and errors


def test_encoder_rejects_bad_arguments_with_value_error() -> None:
    good = GEN.messages()
    jac37 = tuple(tuple(0.5 for _ in range(37)) for _ in range(3))
    bad = [
        Message(MsgType.PING_REQ, 256, Ping(1)),
        Message(MsgType.PING_REQ, 0, Ping(-1)),
        Message(MsgType.PING_REQ, 0, None),
        Message(MsgType.INFO_REQ, 0, Ping(1)),
        Message(MsgType.STREAM_START_REQ, 0, Stream(0)),
        Message(MsgType.ERROR_RSP, 0, ErrorReply(0, 1)),
        Message(MsgType.COMPUTE_RSP, 0, ComputeResult(0, (math.nan, 0.0, 0.0))),
        Message(
            MsgType.MEASURE_RSP,
            0,
            Sample(0, 0, (0,) * 6, (0, 0, 0), 0, ((1e39,) * 25,) * 3),
        ),
        Message(MsgType.MEASURE_RSP, 0, Sample(0, 0, (0,) * 3, (0, 0, 0), 0, params=13)),
        Message(MsgType.MEASURE_RSP, 0, Sample(0, 0, (0,) * 8, (0, 0, 0), 0, params=33)),
        Message(MsgType.MEASURE_RSP, 0, Sample(0, 0, (0,) * 7, (0, 0, 0), 0)),  # P 25 < 29
        Message(
            MsgType.MEASURE_RSP,
            0,
            Sample(0, 0, (0,) * 7, (0, 0, 0), 0, ((1.0,) * 25,) * 3, params=29),  # 3 x 25 != 3 x P
        ),
        Message(MsgType.COMPUTE_REQ, 0, ComputeRequest((0,) * 8)),
        Message(MsgType.COMPUTE_RSP, 0, ComputeResult(0, (0.0, 0.0, 0.0), None, params=38)),
        Message(MsgType.MEASURE_RSP, 0, Sample(0, 0, (0,) * 6, (2**31, 0, 0), 0)),
        Message(MsgType.TRIGGER_EVT, 0, Trigger(0, 2, GEN.SAMPLE_A)),  # type: ignore[arg-type]
        # version 4: temperatures
        Message(MsgType.MEASURE_RSP, 0, replace(GEN.SAMPLE_7TJ, params=37, jacobian=jac37)),
        Message(
            MsgType.TRIGGER_EVT,
            0,
            Trigger(0, False, replace(GEN.SAMPLE_7TJ, params=37, jacobian=jac37)),
        ),
        Message(MsgType.SAMPLE_EVT, 0, replace(GEN.SAMPLE_T, temp=(0,) * 5)),  # N 6
        Message(MsgType.SAMPLE_EVT, 0, replace(GEN.SAMPLE_T, temp=(0,) * 5 + (32768,))),
        Message(MsgType.COMPUTE_REQ, 0, replace(GEN.COMPUTE_REQ_T, temp=(0,) * 5 + (8501,))),
        Message(MsgType.COMPUTE_REQ, 0, replace(GEN.COMPUTE_REQ_T, temp=(-4001,) + (0,) * 5)),
        Message(
            MsgType.COMPUTE_REQ,
            0,
            replace(GEN.COMPUTE_REQ_T, temp=(constants.TEMP_NONE,) * 6),
        ),
        Message(MsgType.COMPUTE_REQ, 0, replace(GEN.COMPUTE_REQ_T, temp=(0,) * 7)),
        Message(MsgType.MEASURE_REQ, 0, MeasureRequest(temperatures=1)),  # type: ignore[arg-type]
        Message(MsgType.STREAM_START_REQ, 0, Stream(10, temperatures=None)),  # type: ignore[arg-type]
        Message(MsgType.COMPUTE_RSP, 0, replace(GEN.COMPUTE_RSP_T, temperatures=2)),
        Message(MsgType.DIAG_RSP, 0, replace(GEN.DIAG, temp_faults=2**32)),
    ]
    p = good["set_params_req"].payload
    assert isinstance(p, ParamSet)
    for change in (
        {"direction": (0, 1, 1, 1, 1, 1)},
        {"counts_per_rev": (1, 2, 2, 2, 2, 2)},
        {"zero_offset_counts": (0, 16777216, 0, 0, 0, 0)},
        {"l_mm": math.inf},
        {"d_mm": (0.0,) * 5},
        {"beta_rad": (0.1, None, None, None, None, None)},  # joint 1
        {"convention": (2, 0, 0, 0, 0, 0)},
        {"harm_cos": ((1,),) * 6},  # harm_sin missing
        {"harm_cos": ((1,) * 5,) * 6, "harm_sin": ((1,) * 5,) * 6},  # K 5
        {"ref_temp": 1},  # no thermal block
        {"cte": (40000, 0, 0, 0, 0, 0)},
        {"cte": (0,) * 6, "ref_temp": 8501},  # above 85 degC
        {"cte": (0,) * 6, "ref_temp": -4001},  # below -40 degC
        {
            "harm_cos": ((1,), (), (), (), (), ()),
            "harm_sin": ((1,), (), (), (), (), (1,)),
        },
    ):
        bad.append(Message(MsgType.SET_PARAMS_REQ, 0, ParamSet(**{**p.__dict__, **change})))
    for m in bad:
        with pytest.raises(ValueError):
            protocol.encode_message(m)
    with pytest.raises(ValueError):
        protocol.encode_message(Message(0x3F, 0))  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        framing.encode_frame(b"\x01\x02")
    with pytest.raises(ValueError):
        framing.encode_frame(b"\x01" * 513)
    with pytest.raises(ValueError):
        pcan.SampleAssembler(node_id=16)
    with pytest.raises(ValueError):
        pcan.isotp_address(-1)


def test_error_tree() -> None:
    for cls in (
        errors.InitError,
        errors.OperationError,
        errors.DeviceTimeoutError,
        errors.FrameError,
        errors.DeviceError,
    ):
        assert issubclass(cls, errors.AacmmError)
    e = errors.DeviceError("range", int(Status.ERR_RANGE), 4)
    assert (e.status, e.request_type) == (-2, 4)


def test_response_type_and_device_error() -> None:
    for t in MsgType:
        if int(t) <= 0x3F:
            assert messages.response_type(t) == MsgType(int(t) | 0x80)
        else:
            with pytest.raises(ValueError):
                messages.response_type(t)
    err = messages.device_error(GEN.messages()["error_rsp"])
    assert isinstance(err, errors.DeviceError)
    assert (err.status, err.request_type) == (Status.ERR_RANGE, MsgType.SET_PARAMS_REQ)
    assert "SET_PARAMS_REQ" in str(err) and "ERR_RANGE" in str(err)
    with pytest.raises(ValueError):
        messages.device_error(GEN.messages()["ping_req"])


def test_isotp_helpers() -> None:
    addr = pcan.isotp_address(7)
    assert addr.get_tx_arbitration_id() == 0x607
    assert addr.get_rx_arbitration_id() == 0x687
    params = pcan.isotp_params()
    isotp.TransportLayerLogic(
        rxfn=lambda _t: None, txfn=lambda _m: None, address=addr, params=params
    )
    assert params["tx_padding"] == 0xCC


def crc32_bitwise(data: bytes) -> int:
    """CRC-32/ISO-HDLC bit by bit from its definition (reflected polynomial
    0xEDB88320, init and xorout 0xFFFFFFFF): the oracle, independent of zlib."""
    reg = 0xFFFFFFFF
    for byte in data:
        reg ^= byte
        for _ in range(8):
            reg = (reg >> 1) ^ (0xEDB88320 if reg & 1 else 0)
    return reg ^ 0xFFFFFFFF


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=600))
def test_crc32_matches_the_bitwise_definition(data: bytes) -> None:
    assert framing.crc32(data) == crc32_bitwise(data)
    assert framing.crc32(bytearray(data)) == framing.crc32(memoryview(data))


def test_crc32_is_thread_safe() -> None:
    """Regression: a shared crc.Calculator mixed the data of concurrent callers,
    so a client's reader thread corrupted the CRCs its caller computed."""
    import threading

    from aacmm.protocol.framing import crc32

    payloads = [bytes([i]) * (40 + i) for i in range(8)]
    expected = [crc32_bitwise(p) for p in payloads]
    wrong: list[int] = []

    def worker(k: int) -> None:
        for _ in range(400):
            if crc32(payloads[k]) != expected[k]:
                wrong.append(k)

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(len(payloads))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert wrong == []


@pytest.mark.parametrize("jacobian", [False, True])
def test_receive_cost_per_frame_does_not_grow_with_its_length(jacobian: bool) -> None:
    """#14.3 regression: the ``crc`` package's pure-Python table loop cost about
    60 Python lines per body byte (3,600 lines for a 56-byte sample frame,
    21,600 for 356 bytes: 113 and 663 us, 70 % of a core at 1 kHz). Taking a
    frame off the line (delimiters, COBS, CRC) must cost a constant number of
    interpreted lines, whatever its length (the per-byte work is in C: zlib,
    cobs). Counted with
    ``sys.settrace``, so the check is deterministic, not timed; the time itself
    is measured by ``make bench`` (bench/bench_host_rx.py)."""
    jac = tuple(tuple(float(25 * r + c) for c in range(25)) for r in range(3)) if jacobian else None
    sample = Sample(7, 1000, (1, 2, 3, 4, 5, 6), (10, -20, 30), 1, jac)
    body = protocol.encode_message(Message(MsgType.SAMPLE_EVT, 7, sample))
    assert len(body) == (358 if jacobian else 58)
    frame = framing.encode_frame(body)
    deframer = framing.Deframer()
    lines = 0

    def tracer(frame_: object, event: str, arg: object) -> object:
        nonlocal lines
        if event == "line":
            lines += 1
        return tracer

    sys.settrace(tracer)  # type: ignore[arg-type]
    try:
        bodies = deframer.feed(frame)
    finally:
        sys.settrace(None)
    assert protocol.decode_message(bodies[0]).payload == sample
    assert lines < 100, lines
