"""Message encoder of the link protocol: range checks, then the wire bytes."""

from __future__ import annotations

import math
import struct
from typing import Final

from aacmm.protocol.constants import (
    COUNTS_PER_REV_MAX,
    JAC_ROWS,
    JOINTS_MAX,
    JOINTS_MIN,
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
)
from aacmm.protocol.framing import crc32
from aacmm.protocol.layout import (
    COMPUTE_RSP_LAYOUT,
    DIAG_JOINT_LAYOUT,
    DIAG_LAYOUT,
    HARMONICS_MAX,
    INFO_LAYOUT,
    PARAM_HEADER_LAYOUT,
    PARAM_THERMAL_BIT,
    REF_TEMP_MAX,
    REF_TEMP_MIN,
    SAMPLE_LAYOUT,
    SAMPLE_MAX_BYTES,
    sample_bytes,
)
from aacmm.protocol.payloads import (
    PAYLOAD_CLASS,
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

_FLT_MAX: Final = 3.4028234663852886e38
_I16: Final = (-0x8000, 0x7FFF)


def _check_int(name: str, value: int, lo: int, hi: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"{name} must be an int")
    if not lo <= value <= hi:
        raise ValueError(f"{name}={value} outside {lo}..{hi}")


def _check_ints(name: str, values: tuple[int, ...], n: int, lo: int, hi: int) -> None:
    if len(values) != n:
        raise ValueError(f"{name} needs {n} values, got {len(values)}")
    for i, v in enumerate(values):
        _check_int(f"{name}[{i}]", v, lo, hi)


def _check_floats(name: str, values: tuple[float, ...], n: int, f32: bool = False) -> None:
    if len(values) != n:
        raise ValueError(f"{name} needs {n} values, got {len(values)}")
    for i, v in enumerate(values):
        if not math.isfinite(v):
            raise ValueError(f"{name}[{i}] is not finite")
        if f32 and abs(v) > _FLT_MAX:
            raise ValueError(f"{name}[{i}] does not fit a float32")


def _check_flag(name: str, value: bool) -> None:
    if not isinstance(value, bool):
        raise ValueError(f"{name} must be a bool")


def _content(jacobian: bool, temperatures: bool) -> int:
    """The content byte of these flags (checked to be bools)."""
    _check_flag("jacobian", jacobian)
    _check_flag("temperatures", temperatures)
    return int(Content.JACOBIAN if jacobian else 0) | int(
        Content.TEMPERATURES if temperatures else 0
    )


def _check_joints(name: str, n: int) -> None:
    if not JOINTS_MIN <= n <= JOINTS_MAX:
        raise ValueError(f"{name} needs {JOINTS_MIN} to {JOINTS_MAX} values (one a joint), got {n}")


def _check_np(n: int, p: int) -> None:
    """P must be a parameter count of some N-joint shape: 4N + 1 .. 5N + 2."""
    _check_int("params", p, 4 * n + 1, 5 * n + 2)


def _jacobian_flat(jac: object, p: int) -> tuple[float, ...]:
    """The 3P values of a 3 x P Jacobian (rows x, y, z), row-major."""
    try:
        rows = [tuple(r) for r in jac]  # type: ignore[attr-defined]
    except TypeError:
        rows = []
    if len(rows) != JAC_ROWS or any(len(r) != p for r in rows):
        raise ValueError(f"jacobian must be {JAC_ROWS} rows of {p} values (x, y, z)")
    return tuple(v for r in rows for v in r)


def _enc_jacobian(jac: Jacobian | None, p: int) -> bytes:
    if jac is None:
        return b""
    flat = _jacobian_flat(jac, p)
    _check_floats("jacobian", flat, 3 * p, f32=True)
    try:
        return struct.pack(f"<{3 * p}f", *flat)
    except OverflowError:  # rounding up past FLT_MAX
        raise ValueError("jacobian value does not fit a float32") from None


def _enc_sample(s: Sample) -> bytes:
    _check_int("seq", s.seq, 0, 0xFFFFFFFF)
    _check_int("timestamp_us", s.timestamp_us, 0, 0xFFFFFFFFFFFFFFFF)
    n = len(s.counts)
    _check_joints("counts", n)
    _check_np(n, s.params)
    _check_ints("counts", s.counts, n, 0, 0xFFFFFFFF)
    _check_ints("point_100nm", s.point_100nm, 3, -(2**31), 2**31 - 1)
    _check_int("status", s.status, 0, 0xFFFFFFFF)
    temps = b""
    if s.temp is not None:
        _check_ints("temp", tuple(s.temp), n, *_I16)  # any i16: what the sensor said
        temps = struct.pack(f"<{n}h", *s.temp)
    size = sample_bytes(n, s.params, s.jacobian is not None, s.temp is not None)
    if size > SAMPLE_MAX_BYTES:
        raise ValueError(
            f"a sample of {n} joints and {s.params} parameters with temperatures and Jacobian "
            f"needs {size} bytes, more than the {SAMPLE_MAX_BYTES} a message holds"
        )
    content = _content(s.jacobian is not None, s.temp is not None)
    return (
        SAMPLE_LAYOUT.pack(s.seq, s.timestamp_us, *s.point_100nm, s.status, content, n, s.params)
        + struct.pack(f"<{n}I", *s.counts)
        + temps
        + _enc_jacobian(s.jacobian, s.params)
    )


def encode_param_set(p: ParamSet) -> bytes:
    """The wire encoding of a parameter set (docs/protocol.md 2.3; 262 bytes for the
    paper's arm, at most 495).

    Raises:
        ValueError: a value the decoder would reject, or a shape that is not an arm
            of 4 to 7 joints (a beta on joint 1, tuples of different lengths).
    """
    n = len(p.theta_offset_rad)
    _check_joints("theta_offset_rad", n)
    for name in ("theta_offset_rad", "alpha_rad", "d_mm", "a_mm"):
        _check_floats(name, tuple(getattr(p, name)), n)
    _check_floats("l_mm", (p.l_mm,), 1)
    conv = tuple(p.convention) or (0,) * n
    _check_ints("convention", conv, n, 0, 1)
    beta = tuple(p.beta_rad) or (None,) * n
    if len(beta) != n:
        raise ValueError(f"beta_rad needs {n} values, got {len(beta)}")
    if beta[0] is not None:
        raise ValueError("joint 1 cannot have a beta (it has no previous axis)")
    betas = tuple(b for b in beta if b is not None)
    _check_floats("beta_rad", betas, len(betas))
    if p.tip_xy_mm is None:
        tip: tuple[float, ...] = (p.l_mm,)
    else:
        _check_floats("tip_xy_mm", tuple(p.tip_xy_mm), 2)
        tip = (p.tip_xy_mm[0], p.tip_xy_mm[1], p.l_mm)
    _check_ints("counts_per_rev", p.counts_per_rev, n, 2, COUNTS_PER_REV_MAX)
    _check_ints("zero_offset_counts", p.zero_offset_counts, n, 0, 0xFFFFFFFF)
    _check_ints("direction", p.direction, n, -1, 1)
    for i in range(n):
        if p.direction[i] == 0:
            raise ValueError(f"direction[{i}] must be +1 or -1")
        if p.zero_offset_counts[i] >= p.counts_per_rev[i]:
            raise ValueError(f"zero_offset_counts[{i}] must be < counts_per_rev[{i}]")
    ks = (0,) * n
    if p.harm_cos or p.harm_sin:
        if len(p.harm_cos) != n or len(p.harm_sin) != n:
            raise ValueError(f"harm_cos and harm_sin need {n} rows (one per joint)")
        ks = tuple(len(row) for row in p.harm_cos)
        for i in range(n):
            _check_int(f"harmonics of joint {i + 1}", ks[i], 0, HARMONICS_MAX)
            _check_ints(f"harm_cos[{i}]", tuple(p.harm_cos[i]), ks[i], *_I16)
            _check_ints(f"harm_sin[{i}]", tuple(p.harm_sin[i]), ks[i], *_I16)
    thermal = len(p.cte) > 0
    if thermal:
        _check_ints("cte", tuple(p.cte), n, *_I16)
        _check_int("ref_temp", p.ref_temp, REF_TEMP_MIN, REF_TEMP_MAX)
    elif p.ref_temp != 0:
        raise ValueError("ref_temp needs the thermal block (cte)")
    conv_bits = sum(c << i for i, c in enumerate(conv))
    beta_bits = sum(1 << i for i, b in enumerate(beta) if b is not None)
    em_word = sum(k << (4 * i) for i, k in enumerate(ks)) | (int(thermal) << PARAM_THERMAL_BIT)
    out = PARAM_HEADER_LAYOUT.pack(n, len(tip), conv_bits, beta_bits, em_word)
    floats = (*p.theta_offset_rad, *p.alpha_rad, *p.d_mm, *p.a_mm, *betas, *tip)
    out += struct.pack(f"<{len(floats)}d", *floats)
    out += struct.pack(f"<{n}I", *(c - 1 for c in p.counts_per_rev))
    out += struct.pack(f"<{n}I", *p.zero_offset_counts)
    out += struct.pack(f"<{n}b", *p.direction)
    for i in range(n):
        for j in range(ks[i]):
            out += struct.pack("<hh", p.harm_cos[i][j], p.harm_sin[i][j])
    if thermal:
        out += struct.pack(f"<{n}hh", *p.cte, p.ref_temp)
    return out


def param_set_crc32(p: ParamSet) -> int:
    """The parameter-set CRC reported by the device: CRC-32/ISO-HDLC of the wire encoding."""
    return crc32(encode_param_set(p))


def _enc_payload(t: MsgType, p: Payload) -> bytes:
    if isinstance(p, Ping):
        _check_int("token", p.token, 0, 0xFFFFFFFF)
        return struct.pack("<I", p.token)
    if isinstance(p, DeviceInfo):
        _check_int("protocol_version", p.protocol_version, 0, 0xFFFF)
        _check_int("fw_major", p.fw_major, 0, 0xFF)
        _check_int("fw_minor", p.fw_minor, 0, 0xFF)
        _check_int("fw_patch", p.fw_patch, 0, 0xFFFF)
        _check_int("build_flags", p.build_flags, 0, 0xFFFFFFFF)
        _check_int("param_crc32", p.param_crc32, 0, 0xFFFFFFFF)
        _check_int("param_source", p.param_source, 0, max(ParamSource))
        _check_int("storage_state", p.storage_state, 0, 3)
        _check_int("max_body_bytes", p.max_body_bytes, 0, 0xFFFF)
        _check_int("serial_number", p.serial_number, 0, 0xFFFFFFFF)
        _check_int("can_node_id", p.can_node_id, 0, 15)
        _check_int("joints", p.joints, JOINTS_MIN, JOINTS_MAX)
        _check_np(p.joints, p.params)
        return INFO_LAYOUT.pack(
            p.protocol_version,
            p.fw_major,
            p.fw_minor,
            p.fw_patch,
            p.build_flags,
            p.param_crc32,
            p.param_source,
            p.storage_state,
            p.max_body_bytes,
            p.serial_number,
            p.can_node_id,
            p.joints,
            p.params,
        )
    if isinstance(p, ParamSet):
        return encode_param_set(p)
    if isinstance(p, ParamCrc):
        _check_int("param_crc32", p.param_crc32, 0, 0xFFFFFFFF)
        return struct.pack("<I", p.param_crc32)
    if isinstance(p, MeasureRequest):
        return bytes([_content(p.jacobian, p.temperatures)])
    if isinstance(p, Sample):
        return _enc_sample(p)
    if isinstance(p, ComputeRequest):
        n = len(p.counts)
        _check_joints("counts", n)
        _check_ints("counts", p.counts, n, 0, 0xFFFFFFFF)
        content = _content(p.jacobian, p.temp is not None)
        out = struct.pack(f"<BB{n}I", content, n, *p.counts)
        if p.temp is not None:
            _check_ints("temp", tuple(p.temp), n, REF_TEMP_MIN, REF_TEMP_MAX)
            out += struct.pack(f"<{n}h", *p.temp)
        return out
    if isinstance(p, ComputeResult):
        _check_int("status", p.status, 0, 0xFFFFFFFF)
        _check_floats("point_mm", p.point_mm, 3)
        _check_int("params", p.params, 4 * JOINTS_MIN + 1, PARAMS_MAX)
        content = _content(p.jacobian is not None, p.temperatures)
        return COMPUTE_RSP_LAYOUT.pack(p.status, *p.point_mm, content, p.params) + _enc_jacobian(
            p.jacobian, p.params
        )
    if isinstance(p, Stream):
        _check_int("rate_hz", p.rate_hz, STREAM_RATE_MIN_HZ, STREAM_RATE_MAX_HZ)
        return struct.pack("<HB", p.rate_hz, _content(p.jacobian, p.temperatures))
    if isinstance(p, Trigger):
        _check_int("button", p.button, 0, 0xFF)
        _check_flag("pressed", p.pressed)
        return bytes([p.button, int(p.pressed)]) + _enc_sample(p.sample)
    if isinstance(p, Diagnostics):
        return _enc_diag(p)
    if isinstance(p, ErrorReply):
        _check_int("status", p.status, -0x8000, -1)
        _check_int("request_type", p.request_type, 0, 0xFF)
        return struct.pack("<hB", p.status, p.request_type)
    return b""


def _enc_diag(d: Diagnostics) -> bytes:
    _check_int("storage_kind", d.storage_kind, 0, max(StorageKind))
    _check_int("storage_flags", d.storage_flags, 0, 0xFF)
    if d.storage_flags & ~int(StorageFlags.PERSISTENT):
        raise ValueError(f"storage_flags=0x{d.storage_flags:02x} has unknown bits")
    _check_ints("slot_state", d.slot_state, 2, 0, max(SlotState))
    _check_ints("slot_generation", d.slot_generation, 2, 0, 0xFFFFFFFF)
    _check_int("reset_cause", d.reset_cause, 0, max(ResetCause))
    _check_int("watchdog_ms", d.watchdog_ms, 0, 0xFFFF)
    _check_int("uptime_us", d.uptime_us, 0, 0xFFFFFFFFFFFFFFFF)
    u32s = (
        "storage_errors",
        "storage_bad_records",
        "reset_raw",
        "fault_pc",
        "boot_count",
        "encoder_faults",
        "serial_frames_bad",
        "samples_dropped",
        "samples_late",
        "temp_faults",
    )
    for name in u32s:
        _check_int(name, getattr(d, name), 0, 0xFFFFFFFF)
    _check_joints("joints", len(d.joints))
    out = DIAG_LAYOUT.pack(
        d.storage_kind,
        d.storage_flags,
        *d.slot_state,
        *d.slot_generation,
        d.storage_errors,
        d.storage_bad_records,
        d.reset_cause,
        d.reset_raw,
        d.fault_pc,
        d.boot_count,
        d.watchdog_ms,
        d.uptime_us,
        d.encoder_faults,
        d.serial_frames_bad,
        d.samples_dropped,
        d.samples_late,
        len(d.joints),
    )
    for i, j in enumerate(d.joints):
        if not isinstance(j, JointDiagnostics):
            raise ValueError(f"joints[{i}] must be a JointDiagnostics")
        _check_int(f"joints[{i}].interface", j.interface, 0, max(EncoderInterface))
        _check_int(f"joints[{i}].bits", j.bits, 0, 32)
        _check_int(f"joints[{i}].last_fault", j.last_fault, 0, max(EncoderFault))
        _check_int(f"joints[{i}].faults", j.faults, 0, 0xFFFFFFFF)
        _check_int(f"joints[{i}].warnings", j.warnings, 0, 0xFFFFFFFF)
        out += DIAG_JOINT_LAYOUT.pack(j.interface, j.bits, j.last_fault, j.faults, j.warnings)
    return out + struct.pack("<I", d.temp_faults)


def encode_message(msg: Message) -> bytes:
    """Encode a message into a body (3 .. 512 bytes).

    Raises:
        ValueError: unknown type, payload of the wrong class for the type, or a
            field outside its documented range (including non-finite floats).
    """
    try:
        t = MsgType(msg.type)
    except ValueError:
        raise ValueError(f"unknown message type {msg.type!r}") from None
    _check_int("seq", msg.seq, 0, 0xFF)
    want = PAYLOAD_CLASS[t]
    if (want is None and msg.payload is not None) or (
        want is not None and type(msg.payload) is not want
    ):
        raise ValueError(f"{t.name} needs payload {want.__name__ if want else 'None'}")
    return bytes([PROTOCOL_VERSION, int(t), msg.seq]) + _enc_payload(t, msg.payload)
