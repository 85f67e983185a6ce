"""Generate tests/vectors/protocol_vectors.txt, the shared link-protocol test vectors.

The expected *values* of every named case are written out twice on purpose:
here (Python) and in tests/protocol/vectors.c (C). Each side encodes its
own values and must produce exactly the bytes in the vector file, and each side
decodes the file's bytes back to its own values. ISO-TP segmentations are
produced with the ``can-isotp`` package as the reference implementation.

Run ``python tests/vectors/gen_protocol_vectors.py`` to rewrite the file; the
pytest suite fails if the committed file differs from what this script makes.

File format: one record per line, whitespace-separated, ``#`` starts a comment.

    crc      NAME INPUT_HEX CRC32_HEX
    msg      NAME BODY_HEX WIRE_HEX          a valid message: body and serial frame
    can      NAME ID_HEX DATA_HEX            one CAN frame (sample/trigger frames)
    isotp    NAME TX_ID_HEX MESSAGE_HEX FRAME_HEX,FRAME_HEX,...
    badbody  NAME BODY_HEX STATUS            a body both decoders reject with STATUS
    badframe NAME WIRE_HEX COUNTER           bytes a deframer drops, counting COUNTER
"""

from __future__ import annotations

import struct
import sys
from dataclasses import replace
from pathlib import Path

import isotp
from aacmm.protocol import can as pcan
from aacmm.protocol.constants import TEMP_NONE, MsgType, SampleStatus
from aacmm.protocol.encode import encode_message, param_set_crc32
from aacmm.protocol.framing import crc32, encode_frame
from aacmm.protocol.payloads import (
    ComputeRequest,
    ComputeResult,
    DeviceInfo,
    Diagnostics,
    ErrorReply,
    JointDiagnostics,
    MeasureRequest,
    Message,
    ParamCrc,
    ParamSet,
    Ping,
    Sample,
    Stream,
    Trigger,
)
from aacmm.protocol.status import Status

VECTORS = Path(__file__).with_name("protocol_vectors.txt")

PARAMS = ParamSet(
    theta_offset_rad=(0.0, 0.001, -0.002, 0.5, -0.25, 0.3333333333333333),
    alpha_rad=(
        1.5707963267948966,
        -1.5707963267948966,
        1.5707963267948966,
        -1.5707963267948966,
        1.5707963267948966,
        -1.5707963267948966,
    ),
    d_mm=(300.0, 65.5, 792.7, 65.5, 883.2, 0.0),
    a_mm=(0.0, -0.125, 0.0, 0.03125, 0.0, -0.0),
    l_mm=183.5,
    counts_per_rev=(4294967296, 16777216, 131072, 2, 4294967295, 1000000),
    zero_offset_counts=(0, 16777215, 65536, 1, 4294967294, 999999),
    direction=(1, -1, 1, -1, 1, -1),
)


def rows3x25(flat: tuple[float, ...]) -> tuple[tuple[float, ...], ...]:
    """The codec's Jacobian shape (3 rows of 25) from the 75 wire values."""
    return tuple(flat[25 * r : 25 * (r + 1)] for r in range(3))


SAMPLE_A = Sample(
    seq=0xFFFFFFFE,
    timestamp_us=0x0123456789ABCDEF,
    counts=(0, 1, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF, 0x00FF00FF),
    point_100nm=(12345678, -22000000, -1),
    status=0x80000005,
)

SAMPLE_J = Sample(
    seq=42,
    timestamp_us=1000000,
    counts=(100, 200, 300, 400, 500, 600),
    point_100nm=(0, 1, -2147483648),
    status=0x00000001,
    jacobian=rows3x25((*((i - 37) * 0.25 for i in range(74)), 3.0 * 2.0**-20)),
)

# An arm model of 7 joints: modified DH on joints 5..7, betas on joints 3 and
# 7, a tip vector (P = 28 + 2 + 3 = 33), assorted encoders.
PARAMS7 = ParamSet(
    theta_offset_rad=(0.0, 0.01, -0.02, 0.0, 0.125, -0.5, 1.0),
    alpha_rad=(
        1.5707963267948966,
        0.002,
        1.5707963267948966,
        -1.5707963267948966,
        0.0,
        3.0,
        -0.25,
    ),
    d_mm=(250.0, 0.0, 5.0, 550.0, 2.0, 120.0, 60.0),
    a_mm=(0.0, 600.0, 40.0, 0.0, 30.0, 0.0, 3.0),
    l_mm=110.0,
    counts_per_rev=(4294967296, 16777216, 3600000, 2, 4294967295, 262144, 1048576),
    zero_offset_counts=(0, 12345, 3599999, 1, 5, 99, 524288),
    direction=(1, -1, 1, 1, -1, 1, -1),
    convention=(0, 0, 0, 0, 1, 1, 1),
    beta_rad=(None, None, 0.0015, None, None, None, -0.001),
    tip_xy_mm=(1.5, -2.0),
)

# A 5-joint set with issue 27's error model: K = 2, 1, 2, 0, 3 harmonics and the thermal block.
PARAMS5E = ParamSet(
    theta_offset_rad=(0.0, 0.001, 0.0, -0.001, 0.0),
    alpha_rad=(0.0, 1.5707963267948966, 0.001, -0.0005, 1.5707963267948966),
    d_mm=(210.0, 0.0, 0.5, 1.0, 80.0),
    a_mm=(0.0, 24.0, 260.0, 260.0, 12.0),
    l_mm=95.0,
    counts_per_rev=(1 << 32,) * 5,
    zero_offset_counts=(0, 1, 2, 3, 4),
    direction=(1, 1, -1, -1, 1),
    convention=(1, 1, 1, 1, 1),
    beta_rad=(None, None, 0.002, -0.001, None),
    harm_cos=((1, -2), (3,), (32767, -32768), (), (5, 6, -13)),
    harm_sin=((-7, 8), (9,), (-32768, 32767), (), (11, -12, 14)),
    cte=(2300, 1200, -1, 0, 32767),
    ref_temp=2000,
)


def rows3(flat: tuple[float, ...], p: int) -> tuple[tuple[float, ...], ...]:
    """The codec's Jacobian shape (3 rows of P) from the 3P wire values."""
    return tuple(flat[p * r : p * (r + 1)] for r in range(3))


# A 7-joint sample with its 3 x 33 Jacobian, and a 5-joint compute (P 23).
SAMPLE_7 = Sample(
    seq=7,
    timestamp_us=0xFFFFFFFFFFFF,
    counts=(7, 6, 5, 4, 3, 2, 0xFFFFFFFF),
    point_100nm=(-5, 2147483647, 0),
    status=0x4001,
    jacobian=rows3(tuple((i % 17 - 8) * 0.125 for i in range(99)), 33),
    params=33,
)

COMPUTE_RSP5 = ComputeResult(
    status=1,
    point_mm=(-1.0, 2.5, 1e-9),
    jacobian=rows3(tuple(i * -0.5 for i in range(69)), 23),
    params=23,
)

DIAG = Diagnostics(
    storage_kind=4,
    storage_flags=1,
    slot_state=(1, 3),
    slot_generation=(0x01020304, 0xFFFFFFFF),
    storage_errors=2,
    storage_bad_records=1,
    reset_cause=5,
    reset_raw=0x00000004,
    fault_pc=0x000012A6,
    boot_count=3,
    watchdog_ms=1000,
    uptime_us=0x0000000123456789,
    encoder_faults=17,
    serial_frames_bad=0x80000000,
    samples_dropped=5,
    samples_late=6,
    joints=(
        JointDiagnostics(1, 32, 0, 0, 0),
        JointDiagnostics(1, 26, 1, 12, 3),
        JointDiagnostics(2, 20, 6, 1, 0),
        JointDiagnostics(3, 13, 3, 0xFFFFFFFF, 0),
        JointDiagnostics(0, 0, 7, 2, 0),
        JointDiagnostics(1, 1, 8, 1, 0xFFFFFFFF),
    ),
)

COMPUTE_RSP = ComputeResult(
    status=1,
    point_mm=(1234.5678901234567, -0.0001, 2200.0),
    jacobian=rows3x25(tuple(i * 0.5 for i in range(75))),
)

# Version 4 (device temperatures). A paper-arm sample with its six link
# temperatures (0.01 degC): one link without a reading (TEMP_NONE) and one
# reading out of range that decoders still accept, so TEMP_FAULT is set; the
# point is valid (no thermal block in force).
SAMPLE_T = Sample(
    seq=0x00010000,
    timestamp_us=86_400_000_000,
    counts=(1000, 2000, 3000, 4000, 5000, 6000),
    point_100nm=(3000000, -1500000, 4500000),
    status=int(SampleStatus.POINT_VALID | SampleStatus.TEMP_FAULT),
    temp=(2000, 2150, -4000, 8500, TEMP_NONE, 32767),
)

# The largest sample: 7 joints, P 36, temperatures and Jacobian (505 bytes).
SAMPLE_7TJ = Sample(
    seq=0xFFFFFFFF,
    timestamp_us=123456789,
    counts=(0xFFFFFFFF, 1, 2, 3, 4, 5, 6),
    point_100nm=(-2147483648, 0, 2147483647),
    status=0x0001,
    jacobian=rows3(tuple((i % 29 - 14) * 0.0625 for i in range(108)), 36),
    params=36,
    temp=(-3999, -1, 0, 1, 2500, 8499, -32767),
)

COMPUTE_REQ_T = ComputeRequest(
    counts=(11, 22, 33, 44, 55, 66),
    jacobian=True,
    temp=(-4000, 8500, 2000, 2001, 0, -1),
)

COMPUTE_RSP_T = ComputeResult(
    status=1,
    point_mm=(100.25, -200.5, 300.125),
    params=25,
    temperatures=True,
)


def messages() -> dict[str, Message]:
    """The named valid messages of the vector file."""
    crc = param_set_crc32(PARAMS)
    return {
        "ping_req": Message(MsgType.PING_REQ, 0, Ping(0xDEADBEEF)),
        "ping_rsp": Message(MsgType.PING_RSP, 0xFF, Ping(0xDEADBEEF)),
        "info_req": Message(MsgType.INFO_REQ, 1),
        "info_rsp": Message(
            MsgType.INFO_RSP,
            1,
            DeviceInfo(
                protocol_version=4,
                fw_major=0,
                fw_minor=3,
                fw_patch=17,
                build_flags=0x1E,
                param_crc32=crc,
                param_source=1,
                storage_state=0,
                max_body_bytes=512,
                serial_number=0xA5C3E001,
                can_node_id=5,
                joints=6,
                params=25,
            ),
        ),
        "info_rsp7": Message(
            MsgType.INFO_RSP,
            13,
            DeviceInfo(4, 0, 1, 0, 0x2C, param_set_crc32(PARAMS7), 2, 1, 512, 77, 15, 7, 33),
        ),
        "get_params_rsp7": Message(MsgType.GET_PARAMS_RSP, 14, PARAMS7),
        "set_params_req5e": Message(MsgType.SET_PARAMS_REQ, 15, PARAMS5E),
        "sample_evt7": Message(MsgType.SAMPLE_EVT, 16, SAMPLE_7),
        "compute_req5": Message(
            MsgType.COMPUTE_REQ,
            17,
            ComputeRequest(counts=(1, 0xFFFFFFFF, 3, 4, 5), jacobian=True),
        ),
        "compute_rsp5": Message(MsgType.COMPUTE_RSP, 17, COMPUTE_RSP5),
        "diag_rsp7": Message(
            MsgType.DIAG_RSP,
            18,
            replace(DIAG, joints=(*DIAG.joints, JointDiagnostics(2, 24, 5, 9, 10))),
        ),
        "get_params_req": Message(MsgType.GET_PARAMS_REQ, 2),
        "get_params_rsp": Message(MsgType.GET_PARAMS_RSP, 2, PARAMS),
        "set_params_req": Message(MsgType.SET_PARAMS_REQ, 3, PARAMS),
        "set_params_rsp": Message(MsgType.SET_PARAMS_RSP, 3, ParamCrc(crc)),
        "save_params_req": Message(MsgType.SAVE_PARAMS_REQ, 4),
        "save_params_rsp": Message(MsgType.SAVE_PARAMS_RSP, 4, ParamCrc(crc)),
        "restore_defaults_req": Message(MsgType.RESTORE_DEFAULTS_REQ, 5),
        "restore_defaults_rsp": Message(MsgType.RESTORE_DEFAULTS_RSP, 5, ParamCrc(0x12345678)),
        "measure_req": Message(MsgType.MEASURE_REQ, 6, MeasureRequest(jacobian=True)),
        "measure_rsp": Message(MsgType.MEASURE_RSP, 6, SAMPLE_J),
        "compute_req": Message(
            MsgType.COMPUTE_REQ,
            7,
            ComputeRequest(counts=tuple(k * 0x01010101 for k in range(1, 7)), jacobian=True),
        ),
        "compute_rsp": Message(MsgType.COMPUTE_RSP, 7, COMPUTE_RSP),
        "stream_start_req": Message(MsgType.STREAM_START_REQ, 8, Stream(1000, False)),
        "stream_start_rsp": Message(MsgType.STREAM_START_RSP, 8, Stream(250, True)),
        "stream_stop_req": Message(MsgType.STREAM_STOP_REQ, 9),
        "stream_stop_rsp": Message(MsgType.STREAM_STOP_RSP, 9),
        "sample_evt": Message(MsgType.SAMPLE_EVT, 10, SAMPLE_A),
        "trigger_evt": Message(MsgType.TRIGGER_EVT, 11, Trigger(0, True, SAMPLE_A)),
        "diag_req": Message(MsgType.DIAG_REQ, 12),
        "diag_rsp": Message(MsgType.DIAG_RSP, 12, DIAG),
        "error_rsp": Message(MsgType.ERROR_RSP, 3, ErrorReply(int(Status.ERR_RANGE), 0x04)),
        # version 4: device temperatures
        "sample_evt_t": Message(MsgType.SAMPLE_EVT, 19, SAMPLE_T),
        "measure_rsp7_tj": Message(MsgType.MEASURE_RSP, 20, SAMPLE_7TJ),
        "trigger_evt7_tj": Message(MsgType.TRIGGER_EVT, 21, Trigger(1, False, SAMPLE_7TJ)),
        "measure_req_tj": Message(
            MsgType.MEASURE_REQ, 22, MeasureRequest(jacobian=True, temperatures=True)
        ),
        "stream_start_req_t": Message(
            MsgType.STREAM_START_REQ, 23, Stream(100, jacobian=False, temperatures=True)
        ),
        "compute_req_tj": Message(MsgType.COMPUTE_REQ, 24, COMPUTE_REQ_T),
        "compute_rsp_t": Message(MsgType.COMPUTE_RSP, 24, COMPUTE_RSP_T),
        "diag_rsp_tf": Message(MsgType.DIAG_RSP, 25, replace(DIAG, temp_faults=0x89ABCDEF)),
    }


def _hdr(t: int, seq: int = 0) -> bytes:
    return bytes([4, t, seq])


def _params_bytes(
    header: bytes = bytes([6, 1, 0, 0, 0, 0, 0, 0]), **change: tuple[int, float]
) -> bytes:
    """The paper-shaped parameter set's wire bytes (docs/protocol.md 2.3, packed here
    with struct, independently of the codec) with some fields replaced (key:
    f/cpr/zero/dir; cpr as counts per revolution, sent as cpr - 1)."""
    fields: dict[str, list[float]] = {
        "f": list(
            PARAMS.theta_offset_rad + PARAMS.alpha_rad + PARAMS.d_mm + PARAMS.a_mm + (PARAMS.l_mm,)
        ),
        "cpr": [float(v) for v in PARAMS.counts_per_rev],
        "zero": [float(v) for v in PARAMS.zero_offset_counts],
        "dir": [float(v) for v in PARAMS.direction],
    }
    for key, (index, value) in change.items():
        fields[key][index] = value
    cpr = [int(v) - 1 for v in fields["cpr"]]
    ints = [int(v) for v in fields["zero"] + fields["dir"]]
    return header + struct.pack("<25d6I6I6b", *fields["f"], *cpr, *ints)


def bad_bodies() -> list[tuple[str, bytes, Status]]:
    """Bodies both decoders must reject, with the status they must report."""
    s = SAMPLE_A
    sample53 = struct.pack(
        "<IQ3iIBBB6I",
        s.seq,
        s.timestamp_us,
        *s.point_100nm,
        s.status,
        0,
        6,
        25,
        *s.counts,
    )  # the paper's sample without Jacobian: 55 bytes
    good_ping = encode_message(messages()["ping_req"])
    diag = encode_message(messages()["diag_rsp"])[3:]
    counts6 = struct.pack("<6I", *range(1, 7))
    sample_7tj = encode_message(messages()["measure_rsp7_tj"])[3:]
    return [
        ("empty", b"", Status.ERR_LENGTH),
        ("header_short", bytes([1, 1]), Status.ERR_LENGTH),
        ("version_0", bytes([0]) + good_ping[1:], Status.ERR_VERSION),
        ("version_1", bytes([1]) + good_ping[1:], Status.ERR_VERSION),
        ("version_2", bytes([2]) + good_ping[1:], Status.ERR_VERSION),
        ("version_3", bytes([3]) + good_ping[1:], Status.ERR_VERSION),
        ("version_5", bytes([5]) + good_ping[1:], Status.ERR_VERSION),
        ("type_unknown_0c", _hdr(0x0C), Status.ERR_UNKNOWN_TYPE),
        ("type_unknown_00", _hdr(0x00), Status.ERR_UNKNOWN_TYPE),
        ("type_unknown_c1", _hdr(0xC1, 9) + b"\x00" * 4, Status.ERR_UNKNOWN_TYPE),
        ("ping_short", good_ping[:-1], Status.ERR_LENGTH),
        ("ping_long", good_ping + b"\x00", Status.ERR_LENGTH),
        ("info_req_payload", _hdr(0x02) + b"\x00", Status.ERR_LENGTH),
        ("stream_rate_0", _hdr(0x09) + struct.pack("<HB", 0, 0), Status.ERR_RANGE),
        (
            "stream_rate_1001",
            _hdr(0x09) + struct.pack("<HB", 1001, 0),
            Status.ERR_RANGE,
        ),
        (
            "stream_content_04",
            _hdr(0x89) + struct.pack("<HB", 10, 4),
            Status.ERR_RANGE,
        ),
        ("measure_content_80", _hdr(0x07) + b"\x80", Status.ERR_RANGE),
        ("measure_content_04", _hdr(0x07) + b"\x04", Status.ERR_RANGE),
        (
            "params_nan",
            _hdr(0x04) + _params_bytes(f=(3, float("nan"))),
            Status.ERR_NOT_FINITE,
        ),
        (
            "params_inf",
            _hdr(0x83) + _params_bytes(f=(24, float("-inf"))),
            Status.ERR_NOT_FINITE,
        ),
        ("params_dir_0", _hdr(0x04) + _params_bytes(dir=(2, 0)), Status.ERR_RANGE),
        ("params_dir_2", _hdr(0x04) + _params_bytes(dir=(5, 2)), Status.ERR_RANGE),
        (
            "params_cpr_1",
            _hdr(0x04) + _params_bytes(cpr=(0, 1), zero=(0, 0)),
            Status.ERR_RANGE,
        ),
        (
            "params_zero_ge_cpr",
            _hdr(0x04) + _params_bytes(zero=(3, 2)),
            Status.ERR_RANGE,
        ),
        ("params_short", _hdr(0x04) + _params_bytes()[:-1], Status.ERR_LENGTH),
        (
            "params_header_short",
            _hdr(0x04) + bytes([6, 1, 0, 0, 0, 0, 0]),
            Status.ERR_LENGTH,
        ),
        (
            "params_joints_3",
            _hdr(0x04) + bytes([3, 1, 0, 0, 0, 0, 0, 0]) + bytes(8 * 13 + 27),
            Status.ERR_RANGE,
        ),
        (
            "params_joints_8",
            _hdr(0x04) + bytes([8, 1, 0, 0, 0, 0, 0, 0]) + bytes(8 * 33 + 72),
            Status.ERR_RANGE,
        ),
        (
            "params_tip_2",
            _hdr(0x04) + _params_bytes(bytes([6, 2, 0, 0, 0, 0, 0, 0])) + bytes(8),
            Status.ERR_RANGE,
        ),
        (
            "params_beta_joint1",
            _hdr(0x04) + _params_bytes(bytes([6, 1, 0, 1, 0, 0, 0, 0])) + bytes(8),
            Status.ERR_RANGE,
        ),
        (
            "params_conv_joint7",
            _hdr(0x04) + _params_bytes(bytes([6, 1, 0x40, 0, 0, 0, 0, 0])),
            Status.ERR_RANGE,
        ),
        (
            "params_k_5",
            _hdr(0x04) + _params_bytes(bytes([6, 1, 0, 0, 5, 0, 0, 0])) + bytes(20),
            Status.ERR_RANGE,
        ),
        (
            "params_k_past_n",
            _hdr(0x04) + _params_bytes(bytes([6, 1, 0, 0, 0, 0, 0, 1])) + bytes(4),
            Status.ERR_RANGE,
        ),
        (
            "params_thermal_bit29",
            _hdr(0x04) + _params_bytes(bytes([6, 1, 0, 0, 0, 0, 0, 0x20])),
            Status.ERR_RANGE,
        ),
        (
            "params_reserved",
            _hdr(0x04) + _params_bytes(bytes([6, 1, 0, 0, 0, 0, 0, 0x80])),
            Status.ERR_RANGE,
        ),
        (
            "params_ref_temp_hot",
            _hdr(0x04)
            + _params_bytes(bytes([6, 1, 0, 0, 0, 0, 0, 0x10]))
            + struct.pack("<6hh", 2300, 0, 0, 0, 0, 0, 8501),
            Status.ERR_RANGE,
        ),
        (
            "params_ref_temp_cold",
            _hdr(0x83)
            + _params_bytes(bytes([6, 1, 0, 0, 0, 0, 0, 0x10]))
            + struct.pack("<6hh", 0, 0, 0, 0, 0, 0, -4001),
            Status.ERR_RANGE,
        ),
        (
            "params_beta_missing",
            _hdr(0x04) + _params_bytes(bytes([6, 1, 0, 2, 0, 0, 0, 0])),
            Status.ERR_LENGTH,
        ),
        (
            "params_k_missing",
            _hdr(0x83) + _params_bytes(bytes([6, 1, 0, 0, 1, 0, 0, 0])),
            Status.ERR_LENGTH,
        ),
        ("error_status_0", _hdr(0xFF) + struct.pack("<hB", 0, 1), Status.ERR_RANGE),
        ("error_status_pos", _hdr(0xFF) + struct.pack("<hB", 7, 1), Status.ERR_RANGE),
        (
            "sample_jac_missing",
            _hdr(0x87) + sample53[:28] + b"\x01" + sample53[29:],
            Status.ERR_LENGTH,
        ),
        (
            "sample_no_jac_extra",
            _hdr(0x40) + sample53 + b"\x00" * 300,
            Status.ERR_LENGTH,
        ),
        (
            "sample_content_04",
            _hdr(0x40) + sample53[:28] + b"\x04" + sample53[29:],
            Status.ERR_RANGE,
        ),
        (  # TEMPERATURES set, the N temperatures missing
            "sample_temps_missing",
            _hdr(0x40) + sample53[:28] + b"\x02" + sample53[29:],
            Status.ERR_LENGTH,
        ),
        (  # temperatures sent without the bit
            "sample_temps_unflagged",
            _hdr(0x40) + sample53 + struct.pack("<6h", *(2000,) * 6),
            Status.ERR_LENGTH,
        ),
        (  # N 7, P 37 with temperatures and Jacobian: 517 bytes, more than a body holds
            "sample_tj_n7_p37",
            _hdr(0x87) + sample_7tj[:30] + bytes([37]) + sample_7tj[31:] + bytes(12),
            Status.ERR_LENGTH,
        ),
        (
            "sample_joints_3",
            _hdr(0x40) + sample53[:29] + bytes([3, 13]) + sample53[31:-12],
            Status.ERR_RANGE,
        ),
        (
            "sample_joints_8",
            _hdr(0x40) + sample53[:29] + bytes([8, 33]) + sample53[31:] + bytes(8),
            Status.ERR_RANGE,
        ),
        (
            "sample_params_24",
            _hdr(0x40) + sample53[:30] + bytes([24]) + sample53[31:],
            Status.ERR_RANGE,
        ),
        (
            "sample_params_33",
            _hdr(0x40) + sample53[:30] + bytes([33]) + sample53[31:],
            Status.ERR_RANGE,
        ),
        ("sample_counts_short", _hdr(0x40) + sample53[:-1], Status.ERR_LENGTH),
        (
            "sample_jac_nan",
            _hdr(0x87)
            + sample53[:28]
            + b"\x01"
            + sample53[29:]
            + struct.pack("<f", 1.0) * 74
            + b"\x00\x00\xc0\x7f",
            Status.ERR_NOT_FINITE,
        ),
        (
            "compute_rsp_inf",
            _hdr(0x88) + struct.pack("<I3dBB", 1, 1.0, float("inf"), 0.0, 0, 25),
            Status.ERR_NOT_FINITE,
        ),
        (
            "compute_rsp_params_16",
            _hdr(0x88) + struct.pack("<I3dBB", 1, 1.0, 2.0, 0.0, 0, 16),
            Status.ERR_RANGE,
        ),
        (
            "compute_rsp_params_38",
            _hdr(0x88) + struct.pack("<I3dBB", 1, 1.0, 2.0, 0.0, 0, 38),
            Status.ERR_RANGE,
        ),
        (
            "compute_req_joints_3",
            _hdr(0x08) + struct.pack("<BB3I", 0, 3, 1, 2, 3),
            Status.ERR_RANGE,
        ),
        (
            "compute_req_joints_8",
            _hdr(0x08) + struct.pack("<BB8I", 0, 8, *range(8)),
            Status.ERR_RANGE,
        ),
        (
            "compute_req_short",
            _hdr(0x08) + struct.pack("<BB5I", 0, 6, *range(5)),
            Status.ERR_LENGTH,
        ),
        (
            "compute_req_content_04",
            _hdr(0x08) + bytes([4, 6]) + counts6,
            Status.ERR_RANGE,
        ),
        (
            "compute_req_temp_hot",
            _hdr(0x08) + bytes([2, 6]) + counts6 + struct.pack("<6h", 2000, 0, 8501, 0, 0, 0),
            Status.ERR_RANGE,
        ),
        (
            "compute_req_temp_cold",
            _hdr(0x08) + bytes([3, 6]) + counts6 + struct.pack("<6h", 0, 0, 0, 0, 0, -4001),
            Status.ERR_RANGE,
        ),
        (  # no reading is no temperature to compute at
            "compute_req_temp_none",
            _hdr(0x08) + bytes([2, 6]) + counts6 + struct.pack("<6h", -32768, 0, 0, 0, 0, 0),
            Status.ERR_RANGE,
        ),
        (
            "compute_req_temps_missing",
            _hdr(0x08) + bytes([2, 6]) + counts6,
            Status.ERR_LENGTH,
        ),
        (
            "compute_rsp_content_04",
            _hdr(0x88) + struct.pack("<I3dBB", 1, 1.0, 2.0, 0.0, 4, 25),
            Status.ERR_RANGE,
        ),
        (
            "info_storage_4",
            _hdr(0x82) + struct.pack("<HBBHIIBBHIBBB", 2, 0, 0, 0, 0, 0, 0, 4, 512, 0, 0, 6, 25),
            Status.ERR_RANGE,
        ),
        (
            "info_node_16",
            _hdr(0x82) + struct.pack("<HBBHIIBBHIBBB", 2, 0, 0, 0, 0, 0, 0, 0, 512, 0, 16, 6, 25),
            Status.ERR_RANGE,
        ),
        (
            "info_source_3",
            _hdr(0x82) + struct.pack("<HBBHIIBBHIBBB", 2, 0, 0, 0, 0, 0, 3, 0, 512, 0, 0, 6, 25),
            Status.ERR_RANGE,
        ),
        (
            "info_joints_8",
            _hdr(0x82) + struct.pack("<HBBHIIBBHIBBB", 2, 0, 0, 0, 0, 0, 0, 0, 512, 0, 0, 8, 33),
            Status.ERR_RANGE,
        ),
        (
            "info_params_31",
            _hdr(0x82) + struct.pack("<HBBHIIBBHIBBB", 2, 0, 0, 0, 0, 0, 0, 0, 512, 0, 0, 5, 31),
            Status.ERR_RANGE,
        ),
        ("diag_req_payload", _hdr(0x0B) + b"\x00", Status.ERR_LENGTH),
        ("diag_short", _hdr(0x8B) + diag[:-1], Status.ERR_LENGTH),
        # a version 3 DIAG_RSP (no temp_faults) under a version 4 header
        ("diag_no_temp_faults", _hdr(0x8B) + diag[:-4], Status.ERR_LENGTH),
        ("diag_kind_6", _hdr(0x8B) + b"\x06" + diag[1:], Status.ERR_RANGE),
        ("diag_flags_2", _hdr(0x8B) + diag[:1] + b"\x02" + diag[2:], Status.ERR_RANGE),
        ("diag_slot_10", _hdr(0x8B) + diag[:3] + b"\x0a" + diag[4:], Status.ERR_RANGE),
        (
            "diag_reset_6",
            _hdr(0x8B) + diag[:20] + b"\x06" + diag[21:],
            Status.ERR_RANGE,
        ),
        (
            "diag_interface_4",
            _hdr(0x8B) + diag[:60] + b"\x04" + diag[61:],
            Status.ERR_RANGE,
        ),
        (
            "diag_bits_33",
            _hdr(0x8B) + diag[:72] + b"\x21" + diag[73:],
            Status.ERR_RANGE,
        ),
        (
            "diag_joints_3",
            _hdr(0x8B) + diag[:59] + b"\x03" + diag[60:-33],
            Status.ERR_RANGE,
        ),
        (
            "diag_joints_8",
            _hdr(0x8B) + diag[:59] + b"\x08" + diag[60:] + bytes(22),
            Status.ERR_RANGE,
        ),
        (
            "diag_fault_9",  # joint 6's last_fault (13 bytes before the end: temp_faults last)
            _hdr(0x8B) + diag[:-13] + b"\x09" + diag[-12:],
            Status.ERR_RANGE,
        ),
        ("trigger_pressed_2", _hdr(0x41) + b"\x00\x02" + sample53, Status.ERR_RANGE),
        ("trigger_short", _hdr(0x41) + b"\x00\x01" + sample53[:-2], Status.ERR_LENGTH),
    ]


def bad_frames() -> list[tuple[str, bytes, str]]:
    """Wire bytes a deframer must drop, and the counter that must count them."""
    good = encode_frame(encode_message(messages()["ping_req"]))
    inner = good[1:-1]
    flipped = bytearray(good)
    flipped[3] ^= 0x01 if flipped[3] != 0x01 else 0x03
    big_body = bytes([1, 0x40, 0]) + bytes(range(1, 256)) * 3  # 768 bytes, no zero
    from cobs import cobs

    oversize = b"\x00" + cobs.encode(big_body) + b"\x00"
    runt_raw = bytes([1, 1, 0]) + b"\x01\x02\x03"  # 6 bytes < header + CRC
    return [
        ("crc_flipped", bytes(flipped), "crc_errors"),
        (
            "crc_zeroed",
            b"\x00" + cobs.encode(encode_message(messages()["ping_req"]) + b"\x00" * 4) + b"\x00",
            "crc_errors",
        ),
        ("torn_code_runs_past", b"\x00" + inner[:-3] + b"\x00", "cobs_errors"),
        ("garbage_code", b"\x00\x10\x41\x42\x00", "cobs_errors"),
        ("runt", b"\x00" + cobs.encode(runt_raw) + b"\x00", "runts"),
        ("oversize", oversize, "oversize"),
    ]


def _isotp_segment(txid: int, rxid: int, payload: bytes) -> list[bytes]:
    """Frames can-isotp sends for ``payload`` when the receiver grants everything."""
    sent: list[isotp.CanMessage] = []
    pending: list[isotp.CanMessage] = []

    def rxfn(timeout: float) -> isotp.CanMessage | None:
        return pending.pop(0) if pending else None

    def txfn(msg: isotp.CanMessage) -> None:
        sent.append(msg)
        if (msg.data[0] >> 4) == 1:  # first frame: grant all (CTS, BS 0, STmin 0)
            pending.append(isotp.CanMessage(arbitration_id=rxid, dlc=3, data=b"\x30\x00\x00"))

    addr = isotp.Address(isotp.AddressingMode.Normal_11bits, txid=txid, rxid=rxid)
    tp = isotp.TransportLayerLogic(rxfn=rxfn, txfn=txfn, address=addr, params=pcan.isotp_params())
    tp.send(payload)
    for _ in range(1000):
        tp.process()
        if not tp.transmitting():
            break
    else:  # pragma: no cover - the reference stack stalled
        raise RuntimeError("can-isotp did not finish sending")
    return [bytes(m.data) for m in sent]


def isotp_cases() -> list[tuple[str, int, bytes, list[bytes]]]:
    msgs = messages()
    out = []
    for name, node, direction in (
        ("ping_req", 5, "req"),
        ("get_params_rsp", 5, "rsp"),
        ("measure_rsp", 0, "rsp"),
        ("info_rsp", 15, "rsp"),
        ("sample_evt7", 3, "rsp"),
    ):
        body = encode_message(msgs[name])
        if direction == "req":
            tx, rx = pcan.ID_ISOTP_REQUEST + node, pcan.ID_ISOTP_RESPONSE + node
        else:
            tx, rx = pcan.ID_ISOTP_RESPONSE + node, pcan.ID_ISOTP_REQUEST + node
        out.append((f"{name}_n{node}", tx, body, _isotp_segment(tx, rx, body)))
    return out


def render() -> str:
    lines = [
        "# aacmm link protocol test vectors (generated by gen_protocol_vectors.py; do not edit)",
        "# See the generator for the format. All hex is lowercase, bytes in wire order.",
        f"crc check {b'123456789'.hex()} {crc32(b'123456789'):08x}",
        f"crc empty - {crc32(b''):08x}",
        f"crc zeros8 {bytes(8).hex()} {crc32(bytes(8)):08x}",
        (
            f"crc params {encode_message(messages()['get_params_rsp'])[3:].hex()} "
            f"{param_set_crc32(PARAMS):08x}"
        ),
    ]
    for name, msg in messages().items():
        body = encode_message(msg)
        lines.append(f"msg {name} {body.hex()} {encode_frame(body).hex()}")
    for i, fr in enumerate(pcan.encode_sample_frames(SAMPLE_A, node_id=5)):
        lines.append(f"can sample_a_n5_{i} {fr.arbitration_id:03x} {fr.data.hex()}")
    for i, fr in enumerate(pcan.encode_sample_frames(SAMPLE_7, node_id=2)):
        lines.append(f"can sample_7_n2_{i} {fr.arbitration_id:03x} {fr.data.hex()}")
    # CAN carries the TEMP_FAULT status bit, not the temperatures
    for i, fr in enumerate(pcan.encode_sample_frames(SAMPLE_T, node_id=1)):
        lines.append(f"can sample_t_n1_{i} {fr.arbitration_id:03x} {fr.data.hex()}")
    trig = pcan.load_dbc().encode_message(
        pcan.ID_TRIGGER,
        {"Seq": SAMPLE_A.seq, "Button": 0, "Pressed": 1, "Reserved": 0},
        scaling=False,
    )
    lines.append(f"can trigger_n5 {pcan.ID_TRIGGER + 5:03x} {bytes(trig).hex()}")
    for name, tx, body, frames in isotp_cases():
        lines.append(f"isotp {name} {tx:03x} {body.hex()} {','.join(f.hex() for f in frames)}")
    for name, body, status in bad_bodies():
        lines.append(f"badbody {name} {body.hex() or '-'} {status.name}")
    for name, wire, counter in bad_frames():
        lines.append(f"badframe {name} {wire.hex()} {counter}")
    return "\n".join(lines) + "\n"


CORPUS = Path(__file__).parent.parent / "protocol" / "corpus"


def corpus() -> dict[str, bytes]:
    """Seed inputs of the libFuzzer harness (tests/protocol/fuzz_protocol.c).

    The first byte selects the harness mode: 0 deframer (then a chunk-size
    byte), 1 message body, 2 ISO-TP frame records, 3 COBS (4, encoder frames: seeds from
    tests/host/test_encoder_frames.py).
    """
    seeds: dict[str, bytes] = {}
    wires = b""
    for name, msg in messages().items():
        body = encode_message(msg)
        seeds[f"body_{name}"] = b"\x01" + body
        wires += encode_frame(body)
        seeds[f"cobs_{name}"] = b"\x03" + encode_frame(body)[1:-1]
    seeds["deframe_all_valid"] = b"\x00\x07" + wires
    bad = b"".join(w for _, w, _ in bad_frames())
    seeds["deframe_bad_frames"] = b"\x00\x03" + bad + wires[:200]
    for name, body, _ in bad_bodies():
        seeds[f"badbody_{name}"] = b"\x01" + body
    for name, _, _body, frames in isotp_cases():
        records = b""
        for i, fr in enumerate(frames):
            records += bytes([1, 8]) + fr
            if i == 0 and len(frames) > 1:  # a flow control for the harness's own send
                records += bytes([1, 3]) + b"\x30\x00\x00" + b"\xcc" * 5
        seeds[f"isotp_{name}"] = b"\x02\x0f" + records
    return seeds


def main() -> int:
    VECTORS.write_text(render())
    print(f"wrote {VECTORS}")
    CORPUS.mkdir(exist_ok=True)
    for name, data in corpus().items():
        (CORPUS / name).write_bytes(data)
    print(f"wrote {len(corpus())} seeds to {CORPUS}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
