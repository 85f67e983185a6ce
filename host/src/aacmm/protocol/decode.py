"""Message decoder of the link protocol: every check the C decoder makes, with its status."""

from __future__ import annotations

import math
import struct
from typing import Final

from aacmm.errors import FrameError
from aacmm.protocol.constants import (
    COUNTS_PER_REV_MAX,
    HEADER_BYTES,
    JAC_COLS,
    JAC_ROWS,
    JOINTS,
    MAX_BODY,
    PROTOCOL_VERSION,
    STREAM_RATE_MAX_HZ,
    STREAM_RATE_MIN_HZ,
    Content,
    EncoderFault,
    EncoderInterface,
    MsgType,
    ParamSource,
    ResetCause,
    SlotState,
    StorageFlags,
    StorageKind,
    StorageState,
)
from aacmm.protocol.layout import (
    COMPUTE_REQ_LAYOUT,
    COMPUTE_RSP_BASE_BYTES,
    COMPUTE_RSP_LAYOUT,
    DIAG_JOINT_BYTES,
    DIAG_JOINT_LAYOUT,
    DIAG_LAYOUT,
    INFO_LAYOUT,
    JACOBIAN_LAYOUT,
    PARAM_SET_BYTES,
    PARAMS_LAYOUT,
    SAMPLE_BASE_BYTES,
    SAMPLE_LAYOUT,
    payload_length,
)
from aacmm.protocol.payloads import (
    ComputeRequest,
    ComputeResult,
    DeviceInfo,
    Diagnostics,
    ErrorReply,
    Jacobian,
    JointDiagnostics,
    MeasureRequest,
    Message,
    ParamCrc,
    ParamSet,
    Payload,
    Ping,
    Sample,
    Stream,
    Trigger,
)
from aacmm.protocol.status import Status


def _fail(text: str, status: Status) -> FrameError:
    return FrameError(text, int(status))


def _content(b: int) -> bool:
    if b & ~int(Content.JACOBIAN):
        raise _fail(f"unknown content bits 0x{b:02x}", Status.ERR_RANGE)
    return bool(b & Content.JACOBIAN)


def _finite(values: tuple[float, ...]) -> tuple[float, ...]:
    if not all(math.isfinite(v) for v in values):
        raise _fail("non-finite float", Status.ERR_NOT_FINITE)
    return values


def _dec_jacobian(b: bytes, offset: int) -> Jacobian:
    flat = _finite(JACOBIAN_LAYOUT.unpack_from(b, offset))
    return tuple(flat[r * JAC_COLS : (r + 1) * JAC_COLS] for r in range(JAC_ROWS))


# Offset of the content byte inside the payload, for types that have one.
_CONTENT_OFFSET: Final[dict[MsgType, int]] = {
    MsgType.MEASURE_RSP: SAMPLE_BASE_BYTES - 1,
    MsgType.SAMPLE_EVT: SAMPLE_BASE_BYTES - 1,
    MsgType.TRIGGER_EVT: 2 + SAMPLE_BASE_BYTES - 1,
    MsgType.COMPUTE_RSP: COMPUTE_RSP_BASE_BYTES - 1,
}


def _dec_sample(b: bytes) -> Sample:
    f = SAMPLE_LAYOUT.unpack_from(b)
    jac = _content(f[12])
    return Sample(
        seq=f[0],
        timestamp_us=f[1],
        counts=tuple(f[2:8]),
        point_100nm=tuple(f[8:11]),
        status=f[11],
        jacobian=_dec_jacobian(b, SAMPLE_BASE_BYTES) if jac else None,
    )


def decode_param_set(b: bytes | bytearray | memoryview) -> ParamSet:
    """Decode and check a 278-byte parameter set.

    Raises:
        FrameError: wrong length (ERR_LENGTH), non-finite value (ERR_NOT_FINITE),
            encoder configuration out of range (ERR_RANGE).
    """
    if len(b) != PARAM_SET_BYTES:
        raise _fail("parameter set must be 278 bytes", Status.ERR_LENGTH)
    f = PARAMS_LAYOUT.unpack(bytes(b))
    _finite(tuple(f[:25]))
    cpr, zero, direction = tuple(f[25:31]), tuple(f[31:37]), tuple(f[37:43])
    for i in range(JOINTS):
        if not 2 <= cpr[i] <= COUNTS_PER_REV_MAX or zero[i] >= cpr[i]:
            raise _fail("encoder configuration out of range", Status.ERR_RANGE)
        if direction[i] not in (1, -1):
            raise _fail("encoder direction must be +1 or -1", Status.ERR_RANGE)
    return ParamSet(
        theta_offset_rad=tuple(f[0:6]),
        alpha_rad=tuple(f[6:12]),
        d_mm=tuple(f[12:18]),
        a_mm=tuple(f[18:24]),
        l_mm=f[24],
        counts_per_rev=cpr,
        zero_offset_counts=zero,
        direction=direction,
    )


def _dec_diag(b: bytes) -> Diagnostics:
    f = DIAG_LAYOUT.unpack_from(b)
    joints = tuple(
        JointDiagnostics(*DIAG_JOINT_LAYOUT.unpack_from(b, DIAG_LAYOUT.size + i * DIAG_JOINT_BYTES))
        for i in range(JOINTS)
    )
    d = Diagnostics(
        storage_kind=f[0],
        storage_flags=f[1],
        slot_state=(f[2], f[3]),
        slot_generation=(f[4], f[5]),
        storage_errors=f[6],
        storage_bad_records=f[7],
        reset_cause=f[8],
        reset_raw=f[9],
        fault_pc=f[10],
        boot_count=f[11],
        watchdog_ms=f[12],
        uptime_us=f[13],
        encoder_faults=f[14],
        serial_frames_bad=f[15],
        samples_dropped=f[16],
        samples_late=f[17],
        joints=joints,
    )
    if (
        d.storage_kind > max(StorageKind)
        or d.storage_flags & ~int(StorageFlags.PERSISTENT)
        or max(d.slot_state) > max(SlotState)
        or d.reset_cause > max(ResetCause)
        or any(
            j.interface > max(EncoderInterface) or j.bits > 32 or j.last_fault > max(EncoderFault)
            for j in joints
        )
    ):
        raise _fail("diagnostics field out of range", Status.ERR_RANGE)
    return d


def _dec_payload(t: MsgType, b: bytes) -> Payload:
    if t in (MsgType.PING_REQ, MsgType.PING_RSP):
        return Ping(struct.unpack("<I", b)[0])
    if t == MsgType.INFO_RSP:
        info = DeviceInfo(*INFO_LAYOUT.unpack(b))
        if (
            info.param_source > max(ParamSource)
            or info.storage_state > max(StorageState)
            or info.can_node_id > 15
        ):
            raise _fail("device info field out of range", Status.ERR_RANGE)
        return info
    if t in (MsgType.SET_PARAMS_REQ, MsgType.GET_PARAMS_RSP):
        return decode_param_set(b)
    if t in (MsgType.SET_PARAMS_RSP, MsgType.SAVE_PARAMS_RSP, MsgType.RESTORE_DEFAULTS_RSP):
        return ParamCrc(struct.unpack("<I", b)[0])
    if t == MsgType.MEASURE_REQ:
        return MeasureRequest(_content(b[0]))
    if t == MsgType.COMPUTE_REQ:
        f = COMPUTE_REQ_LAYOUT.unpack(b)
        return ComputeRequest(counts=tuple(f[1:7]), jacobian=_content(f[0]))
    if t in (MsgType.STREAM_START_REQ, MsgType.STREAM_START_RSP):
        rate, c = struct.unpack("<HB", b)
        jac = _content(c)
        if not STREAM_RATE_MIN_HZ <= rate <= STREAM_RATE_MAX_HZ:
            raise _fail("stream rate out of range", Status.ERR_RANGE)
        return Stream(rate, jac)
    if t in (MsgType.MEASURE_RSP, MsgType.SAMPLE_EVT):
        return _dec_sample(b)
    if t == MsgType.TRIGGER_EVT:
        if b[1] > 1:
            raise _fail("trigger pressed must be 0 or 1", Status.ERR_RANGE)
        return Trigger(button=b[0], pressed=bool(b[1]), sample=_dec_sample(b[2:]))
    if t == MsgType.COMPUTE_RSP:
        f = COMPUTE_RSP_LAYOUT.unpack_from(b)
        point = _finite(tuple(f[1:4]))
        jac = _content(f[4])
        return ComputeResult(
            status=f[0],
            point_mm=point,
            jacobian=_dec_jacobian(b, COMPUTE_RSP_BASE_BYTES) if jac else None,
        )
    if t == MsgType.DIAG_RSP:
        return _dec_diag(b)
    if t == MsgType.ERROR_RSP:
        code, req = struct.unpack("<hB", b)
        if code >= 0:
            raise _fail("error response with a non-negative status", Status.ERR_RANGE)
        return ErrorReply(code, req)
    return None


def decode_message(body: bytes | bytearray | memoryview) -> Message:
    """Decode one message body.

    Raises:
        FrameError: with ``status`` ERR_LENGTH (short body or wrong payload
            size), ERR_VERSION, ERR_UNKNOWN_TYPE, ERR_NOT_FINITE or ERR_RANGE.
            Nothing else is raised for any input bytes.
    """
    body = bytes(body)
    if len(body) < HEADER_BYTES:
        raise _fail("body shorter than the header", Status.ERR_LENGTH)
    if len(body) > MAX_BODY:
        raise _fail("body longer than 512 bytes", Status.ERR_LENGTH)
    if body[0] != PROTOCOL_VERSION:
        raise _fail(f"protocol version {body[0]} (want {PROTOCOL_VERSION})", Status.ERR_VERSION)
    try:
        t = MsgType(body[1])
    except ValueError:
        raise _fail(f"unknown message type 0x{body[1]:02x}", Status.ERR_UNKNOWN_TYPE) from None
    payload = body[HEADER_BYTES:]
    off = _CONTENT_OFFSET.get(t)
    jac = off is not None and len(payload) > off and bool(payload[off] & Content.JACOBIAN)
    if len(payload) != payload_length(t, jac):
        raise _fail(f"{t.name} payload of {len(payload)} bytes", Status.ERR_LENGTH)
    return Message(t, body[2], _dec_payload(t, payload))
