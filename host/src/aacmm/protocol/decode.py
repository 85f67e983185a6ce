"""Message decoder of the link protocol: every check the C decoder makes, with its status."""

from __future__ import annotations

import math
import struct

from aacmm.errors import FrameError
from aacmm.protocol.constants import (
    COUNTS_PER_REV_MAX,
    HEADER_BYTES,
    JAC_ROWS,
    JOINTS_MAX,
    JOINTS_MIN,
    MAX_BODY,
    OLD_PROTOCOL_VERSIONS,
    PARAMS_MAX,
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
    COMPUTE_RSP_BASE_BYTES,
    COMPUTE_RSP_LAYOUT,
    DIAG_JOINT_BYTES,
    DIAG_JOINT_LAYOUT,
    DIAG_LAYOUT,
    HARMONICS_MAX,
    INFO_LAYOUT,
    PARAM_HEADER_LAYOUT,
    PARAM_SET_HEADER_BYTES,
    PARAM_THERMAL_BIT,
    REF_TEMP_MAX,
    REF_TEMP_MIN,
    SAMPLE_BASE_BYTES,
    SAMPLE_LAYOUT,
    param_set_len_raw,
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


_CONTENT_KNOWN = int(Content.JACOBIAN | Content.TEMPERATURES)


def _content(b: int) -> tuple[bool, bool]:
    """The content byte's (jacobian, temperatures) flags."""
    if b & ~_CONTENT_KNOWN:
        raise _fail(f"unknown content bits 0x{b:02x}", Status.ERR_RANGE)
    return bool(b & Content.JACOBIAN), bool(b & Content.TEMPERATURES)


def _finite(values: tuple[float, ...]) -> tuple[float, ...]:
    if not all(math.isfinite(v) for v in values):
        raise _fail("non-finite float", Status.ERR_NOT_FINITE)
    return values


def _dec_jacobian(b: bytes, offset: int, p: int) -> Jacobian:
    flat = _finite(struct.unpack_from(f"<{3 * p}f", b, offset))
    return tuple(flat[r * p : (r + 1) * p] for r in range(JAC_ROWS))


def _np_ok(n: int, p: int) -> bool:
    """N in 4..7 and P a parameter count of some N-joint shape (4N + 1 .. 5N + 2)."""
    return JOINTS_MIN <= n <= JOINTS_MAX and 4 * n + 1 <= p <= 5 * n + 2


def _dec_sample(b: bytes) -> Sample:
    f = SAMPLE_LAYOUT.unpack_from(b)
    jac, temps = _content(f[6])
    n, p = f[7], f[8]
    if not _np_ok(n, p):
        raise _fail(f"sample of {n} joints and {p} parameters", Status.ERR_RANGE)
    off = SAMPLE_BASE_BYTES + 4 * n
    temp = struct.unpack_from(f"<{n}h", b, off) if temps else None  # any i16
    off += 2 * n if temps else 0
    return Sample(
        seq=f[0],
        timestamp_us=f[1],
        counts=struct.unpack_from(f"<{n}I", b, SAMPLE_BASE_BYTES),
        point_100nm=tuple(f[2:5]),
        status=f[5],
        jacobian=_dec_jacobian(b, off, p) if jac else None,
        params=p,
        temp=temp,
    )


def _param_header_ok(h: bytes) -> bool:
    n, tip, conv, beta, em = PARAM_HEADER_LAYOUT.unpack_from(h)
    if not JOINTS_MIN <= n <= JOINTS_MAX:
        return False
    ks = [(em >> (4 * i)) & 0xF for i in range(JOINTS_MAX)]
    mask = (1 << n) - 1
    return (
        tip in (1, 3)
        and not conv & ~mask
        and not beta & ~(mask & ~1)
        and all(k <= HARMONICS_MAX for k in ks)
        and not any(ks[n:])
        and em >> (PARAM_THERMAL_BIT + 1) == 0
    )


def decode_param_set(b: bytes | bytearray | memoryview) -> ParamSet:
    """Decode and check a parameter set (docs/protocol.md 2.3).

    Raises:
        FrameError: shorter than its header or not the length its header defines
            (ERR_LENGTH), a header field out of range (ERR_RANGE), a non-finite
            value (ERR_NOT_FINITE), an encoder configuration out of range (ERR_RANGE).
    """
    b = bytes(b)
    if len(b) < PARAM_SET_HEADER_BYTES or len(b) != param_set_len_raw(b):
        raise _fail(f"parameter set of {len(b)} bytes", Status.ERR_LENGTH)
    if not _param_header_ok(b):
        raise _fail("parameter set header out of range", Status.ERR_RANGE)
    n, tip, conv, beta, em = PARAM_HEADER_LAYOUT.unpack_from(b)
    ks = tuple((em >> (4 * i)) & 0xF for i in range(n))
    thermal = (em >> PARAM_THERMAL_BIT) & 1
    nb = bin(beta).count("1")
    nf = 4 * n + nb + tip
    off = PARAM_SET_HEADER_BYTES
    fl = _finite(struct.unpack_from(f"<{nf}d", b, off))
    off += 8 * nf
    cpr = tuple(c + 1 for c in struct.unpack_from(f"<{n}I", b, off))
    zero = struct.unpack_from(f"<{n}I", b, off + 4 * n)
    direction = struct.unpack_from(f"<{n}b", b, off + 8 * n)
    off += 9 * n
    for i in range(n):
        if not 2 <= cpr[i] <= COUNTS_PER_REV_MAX or zero[i] >= cpr[i]:
            raise _fail("encoder configuration out of range", Status.ERR_RANGE)
        if direction[i] not in (1, -1):
            raise _fail("encoder direction must be +1 or -1", Status.ERR_RANGE)
    harm = struct.unpack_from(f"<{2 * sum(ks)}h", b, off)
    off += 4 * sum(ks)
    tail = struct.unpack_from(f"<{n + 1}h", b, off) if thermal else ()
    if thermal and not REF_TEMP_MIN <= tail[n] <= REF_TEMP_MAX:
        raise _fail("reference temperature outside -40 .. 85 degC", Status.ERR_RANGE)
    starts = [2 * sum(ks[:i]) for i in range(n)]
    betas = iter(fl[4 * n : 4 * n + nb])
    tipv = fl[4 * n + nb :]
    return ParamSet(
        theta_offset_rad=fl[0:n],
        alpha_rad=fl[n : 2 * n],
        d_mm=fl[2 * n : 3 * n],
        a_mm=fl[3 * n : 4 * n],
        l_mm=tipv[-1],
        counts_per_rev=cpr,
        zero_offset_counts=zero,
        direction=direction,
        convention=tuple((conv >> i) & 1 for i in range(n)) if conv else (),
        beta_rad=tuple(next(betas) if (beta >> i) & 1 else None for i in range(n)) if beta else (),
        tip_xy_mm=(tipv[0], tipv[1]) if tip == 3 else None,
        harm_cos=tuple(harm[starts[i] : starts[i] + 2 * ks[i] : 2] for i in range(n))
        if any(ks)
        else (),
        harm_sin=tuple(harm[starts[i] + 1 : starts[i] + 2 * ks[i] : 2] for i in range(n))
        if any(ks)
        else (),
        cte=tuple(tail[:n]),
        ref_temp=tail[n] if thermal else 0,
    )


def _dec_diag(b: bytes) -> Diagnostics:
    f = DIAG_LAYOUT.unpack_from(b)
    n = f[18]
    if not JOINTS_MIN <= n <= JOINTS_MAX:
        raise _fail(f"diagnostics of {n} joints", Status.ERR_RANGE)
    joints = tuple(
        JointDiagnostics(*DIAG_JOINT_LAYOUT.unpack_from(b, DIAG_LAYOUT.size + i * DIAG_JOINT_BYTES))
        for i in range(n)
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
        temp_faults=struct.unpack_from("<I", b, DIAG_LAYOUT.size + n * DIAG_JOINT_BYTES)[0],
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
            or not _np_ok(info.joints, info.params)
        ):
            raise _fail("device info field out of range", Status.ERR_RANGE)
        return info
    if t in (MsgType.SET_PARAMS_REQ, MsgType.GET_PARAMS_RSP):
        return decode_param_set(b)
    if t in (MsgType.SET_PARAMS_RSP, MsgType.SAVE_PARAMS_RSP, MsgType.RESTORE_DEFAULTS_RSP):
        return ParamCrc(struct.unpack("<I", b)[0])
    if t == MsgType.MEASURE_REQ:
        return MeasureRequest(*_content(b[0]))
    if t == MsgType.COMPUTE_REQ:
        jac, temps = _content(b[0])
        n = b[1]
        if not JOINTS_MIN <= n <= JOINTS_MAX:
            raise _fail(f"compute request of {n} joints", Status.ERR_RANGE)
        temp = struct.unpack_from(f"<{n}h", b, 2 + 4 * n) if temps else None
        if temp is not None and not all(REF_TEMP_MIN <= v <= REF_TEMP_MAX for v in temp):
            raise _fail("compute temperature outside -40 .. 85 degC", Status.ERR_RANGE)
        return ComputeRequest(counts=struct.unpack_from(f"<{n}I", b, 2), jacobian=jac, temp=temp)
    if t in (MsgType.STREAM_START_REQ, MsgType.STREAM_START_RSP):
        rate, c = struct.unpack("<HB", b)
        jac, temps = _content(c)
        if not STREAM_RATE_MIN_HZ <= rate <= STREAM_RATE_MAX_HZ:
            raise _fail("stream rate out of range", Status.ERR_RANGE)
        return Stream(rate, jac, temps)
    if t in (MsgType.MEASURE_RSP, MsgType.SAMPLE_EVT):
        return _dec_sample(b)
    if t == MsgType.TRIGGER_EVT:
        if b[1] > 1:
            raise _fail("trigger pressed must be 0 or 1", Status.ERR_RANGE)
        return Trigger(button=b[0], pressed=bool(b[1]), sample=_dec_sample(b[2:]))
    if t == MsgType.COMPUTE_RSP:
        f = COMPUTE_RSP_LAYOUT.unpack_from(b)
        point = _finite(tuple(f[1:4]))
        jac, temps = _content(f[4])
        p = f[5]
        if not 4 * JOINTS_MIN + 1 <= p <= PARAMS_MAX:
            raise _fail(f"compute result of {p} parameters", Status.ERR_RANGE)
        return ComputeResult(
            status=f[0],
            point_mm=point,
            jacobian=_dec_jacobian(b, COMPUTE_RSP_BASE_BYTES, p) if jac else None,
            params=p,
            temperatures=temps,
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
        what = OLD_PROTOCOL_VERSIONS.get(body[0])
        old = f" ({what})" if what else ""
        raise FrameError(
            f"protocol version {body[0]}{old}; this host speaks version {PROTOCOL_VERSION}",
            int(Status.ERR_VERSION),
            body[0],
        )
    try:
        t = MsgType(body[1])
    except ValueError:
        raise _fail(f"unknown message type 0x{body[1]:02x}", Status.ERR_UNKNOWN_TYPE) from None
    payload = body[HEADER_BYTES:]
    if len(payload) != payload_length(t, payload):
        raise _fail(f"{t.name} payload of {len(payload)} bytes", Status.ERR_LENGTH)
    return Message(t, body[2], _dec_payload(t, payload))
