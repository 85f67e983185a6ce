"""Message codec of the aacmm link protocol, version 1 (see ``docs/protocol.md``).

A message body is ``version u8 | type u8 | seq u8 | payload``, little-endian.
:func:`encode_message` and :func:`decode_message` convert between bodies and
:class:`Message` objects; the payload classes below mirror the C structs of
``firmware/include/aacmm/proto.h`` field for field.

Decoding checks everything the C decoder checks (exact payload length, known
type and version, finite floats, no unknown flag bits, enumerations in range)
and raises :class:`aacmm.errors.FrameError` carrying the same status code the
C decoder returns. Encoding raises :class:`ValueError` for values the decoder
would reject, so ``decode_message(encode_message(m)) == m`` for every message
that encodes.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from enum import IntEnum, IntFlag
from typing import TYPE_CHECKING, Final, TypeAlias

from aacmm.errors import DeviceError, FrameError
from aacmm.protocol.framing import crc32, encode_frame
from aacmm.protocol.status import Status, status_name

if TYPE_CHECKING:
    from aacmm.core import EncoderConfig, Params

PROTOCOL_VERSION: Final = 1
HEADER_BYTES: Final = 3
MAX_BODY: Final = 512
JOINTS: Final = 6
JAC_ROWS: Final = 3
JAC_COLS: Final = 25
JAC_SIZE: Final = 75
"""3x25 row-major on the wire; columns theta1..6, alpha1..6, d1..6, a1..6, l."""

Jacobian = tuple[tuple[float, ...], ...]
"""A Jacobian as the codec gives it: 3 rows (x, y, z) of 25 values (mm per
parameter unit, columns as :data:`aacmm.core.PARAM_NAMES`), the shape
``aacmm.core`` uses: ``np.asarray(sample.jacobian)`` is a (3, 25) array."""
POINT_UNIT_MM: Final = 1e-4
"""Wire unit of the sample point: int32 counts of 1e-4 mm (100 nm)."""
STREAM_RATE_MIN_HZ: Final = 1
STREAM_RATE_MAX_HZ: Final = 1000
COUNTS_PER_REV_MAX: Final = 1 << 32
RESPONSE_BIT: Final = 0x80

_FLT_MAX: Final = 3.4028234663852886e38


class MsgType(IntEnum):
    """Message types (wire values)."""

    PING_REQ = 0x01
    INFO_REQ = 0x02
    GET_PARAMS_REQ = 0x03
    SET_PARAMS_REQ = 0x04
    SAVE_PARAMS_REQ = 0x05
    RESTORE_DEFAULTS_REQ = 0x06
    MEASURE_REQ = 0x07
    COMPUTE_REQ = 0x08
    STREAM_START_REQ = 0x09
    STREAM_STOP_REQ = 0x0A
    DIAG_REQ = 0x0B
    SAMPLE_EVT = 0x40
    TRIGGER_EVT = 0x41
    PING_RSP = 0x81
    INFO_RSP = 0x82
    GET_PARAMS_RSP = 0x83
    SET_PARAMS_RSP = 0x84
    SAVE_PARAMS_RSP = 0x85
    RESTORE_DEFAULTS_RSP = 0x86
    MEASURE_RSP = 0x87
    COMPUTE_RSP = 0x88
    STREAM_START_RSP = 0x89
    STREAM_STOP_RSP = 0x8A
    DIAG_RSP = 0x8B
    ERROR_RSP = 0xFF


class Content(IntFlag):
    """Optional content of samples and compute results."""

    NONE = 0
    JACOBIAN = 0x01


class SampleStatus(IntFlag):
    """Sample status bits (u32 on the wire; unknown bits are kept)."""

    POINT_VALID = 0x0001
    ENCODER_FAULT = 0x0002
    TRIGGER_DOWN = 0x0004
    PARAMS_DEFAULT = 0x0008
    POINT_CLIPPED = 0x0010
    OVERRUN = 0x0020
    ENCODER_WARNING = 0x0040
    #: read at a button edge: the sample of a trigger event, never a stream
    #: sample (its seq is the link's next stream seq; docs/protocol.md 2.7)
    TRIGGER_EVENT = 0x0080
    JOINT1_FAULT = 0x0100
    JOINT2_FAULT = 0x0200
    JOINT3_FAULT = 0x0400
    JOINT4_FAULT = 0x0800
    JOINT5_FAULT = 0x1000
    JOINT6_FAULT = 0x2000


class Button(IntEnum):
    """The button index of a trigger event (TRIGGER_EVT, CAN trigger frame)."""

    CAPTURE = 0  #: the probe (front) button: take a point
    UNDO = 1  #: the second button: undo the last point


class BuildFlags(IntFlag):
    """Device info ``build_flags``."""

    KIN_FIXED = 0x0001
    KIN_F64 = 0x0002
    JACOBIAN = 0x0004
    SERIAL = 0x0008
    CAN = 0x0010


class ParamSource(IntEnum):
    """Device info ``param_source``: where the active parameter set came from."""

    DEFAULTS = 0
    """The built-in defaults."""
    STORAGE = 1
    """Loaded from storage, or saved since: a restart loads this set."""
    HOST = 2
    """Set by the host (SET_PARAMS) and not saved: lost at restart."""


class StorageState(IntEnum):
    OK = 0
    EMPTY = 1
    CORRUPT = 2
    VERSION = 3


class StorageKind(IntEnum):
    """Diagnostics ``storage_kind``: where the parameter records live."""

    NONE = 0
    RAM = 1
    RAM_RETAINED = 2
    FILE = 3
    FLASH = 4
    EEPROM = 5


class StorageFlags(IntFlag):
    """Diagnostics ``storage_flags``."""

    NONE = 0
    PERSISTENT = 0x01


class SlotState(IntEnum):
    """Diagnostics ``slot_state``: what a record slot held when last read."""

    ERASED = 0
    NEWEST = 1
    OLDER = 2
    BAD_CRC = 3
    BAD_CONTENTS = 4
    VERSION = 5
    BAD_LENGTH = 6
    INCOMPLETE = 7
    UNRECOGNISED = 8
    READ_ERROR = 9


class ResetCause(IntEnum):
    """Diagnostics ``reset_cause``: why the device last started."""

    UNKNOWN = 0
    POWER_ON = 1
    PIN = 2
    WATCHDOG = 3
    SOFTWARE = 4
    FAULT = 5


class EncoderInterface(IntEnum):
    """Diagnostics: a joint's encoder interface."""

    COUNTS = 0
    BISS_C = 1
    SSI_BINARY = 2
    SSI_GRAY = 3


class EncoderFault(IntEnum):
    """Diagnostics: kind of a joint's latest fault (the reading was discarded)."""

    NONE = 0
    CRC = 1
    ERROR_BIT = 2
    STUCK_LOW = 3
    STUCK_HIGH = 4
    TIMEOUT = 5
    FRAMING = 6
    RANGE = 7
    READ = 8


# ---------------------------------------------------------------- payloads


@dataclass(frozen=True)
class Ping:
    """PING_REQ / PING_RSP: a u32 token the device echoes."""

    token: int


@dataclass(frozen=True)
class DeviceInfo:
    """INFO_RSP (23 bytes)."""

    protocol_version: int
    fw_major: int
    fw_minor: int
    fw_patch: int
    build_flags: int
    param_crc32: int
    param_source: int
    storage_state: int
    max_body_bytes: int
    serial_number: int
    can_node_id: int


@dataclass(frozen=True)
class ParamSet:
    """SET_PARAMS_REQ / GET_PARAMS_RSP (278 bytes).

    Kinematic parameters (float64, mm and rad, finite) and the encoder
    configuration: counts per revolution 2 .. 2**32 (u64 on the wire), zero
    offset in counts (< counts per revolution), direction +1 or -1.
    """

    theta_offset_rad: tuple[float, ...]
    alpha_rad: tuple[float, ...]
    d_mm: tuple[float, ...]
    a_mm: tuple[float, ...]
    l_mm: float
    counts_per_rev: tuple[int, ...]
    zero_offset_counts: tuple[int, ...]
    direction: tuple[int, ...]

    def to_core(self) -> tuple[Params, EncoderConfig]:
        """The set as :class:`aacmm.core.Params` and :class:`aacmm.core.EncoderConfig`,
        ready for ``Model(params)`` and ``counts_to_angles(counts, encoders)``::

            params, encoders = arm.get_params().to_core()
            point, jac = Model(params).point_jacobian(counts_to_angles([counts], encoders)[0])
        """
        from aacmm.core import EncoderConfig, Params

        return (
            Params(self.theta_offset_rad, self.alpha_rad, self.d_mm, self.a_mm, self.l_mm),
            EncoderConfig(self.counts_per_rev, self.zero_offset_counts, self.direction),
        )

    @classmethod
    def from_core(cls, params: Params, encoders: EncoderConfig | None = None) -> ParamSet:
        """The device's set for ``params`` and ``encoders`` (default: 2^32 counts per
        revolution, no offset, direction +1): the inverse of :meth:`to_core`.
        The codec checks the ranges when it is sent."""
        from aacmm.core import EncoderConfig

        enc = encoders if encoders is not None else EncoderConfig()
        return cls(
            params.theta_offset_rad,
            params.alpha_rad,
            params.d_mm,
            params.a_mm,
            params.l_mm,
            enc.counts_per_rev,
            enc.zero_offset_counts,
            enc.direction,
        )


@dataclass(frozen=True)
class ParamCrc:
    """SET_PARAMS_RSP / SAVE_PARAMS_RSP / RESTORE_DEFAULTS_RSP: CRC of the resulting set."""

    param_crc32: int


@dataclass(frozen=True)
class MeasureRequest:
    """MEASURE_REQ."""

    jacobian: bool = False


@dataclass(frozen=True)
class Sample:
    """MEASURE_RSP / SAMPLE_EVT (53 bytes, 353 with the Jacobian).

    ``point_100nm`` is the probe point in units of 1e-4 mm (see :attr:`point_mm`);
    ``jacobian`` is a :data:`Jacobian` (3 rows of 25 float32 values: shape
    (3, 25) as in :mod:`aacmm.core`) or ``None``.
    """

    seq: int
    timestamp_us: int
    counts: tuple[int, ...]
    point_100nm: tuple[int, ...]
    status: int
    jacobian: Jacobian | None = None

    @property
    def point_mm(self) -> tuple[float, float, float]:
        """The point in mm."""
        x, y, z = (v * POINT_UNIT_MM for v in self.point_100nm)
        return (x, y, z)


@dataclass(frozen=True)
class ComputeRequest:
    """COMPUTE_REQ: six encoder counts to evaluate on the device."""

    counts: tuple[int, ...]
    jacobian: bool = False


@dataclass(frozen=True)
class ComputeResult:
    """COMPUTE_RSP: the device's point in mm (float64) and optional
    :data:`Jacobian` (3 rows of 25)."""

    status: int
    point_mm: tuple[float, ...]
    jacobian: Jacobian | None = None


@dataclass(frozen=True)
class Stream:
    """STREAM_START_REQ / STREAM_START_RSP: rate 1..1000 Hz and content."""

    rate_hz: int
    jacobian: bool = False


@dataclass(frozen=True)
class Trigger:
    """TRIGGER_EVT: a button edge (``button``: :class:`Button`) and the sample read at it.

    The sample carries :attr:`SampleStatus.TRIGGER_EVENT` and, as ``seq``, the
    number of the link's next stream sample (docs/protocol.md 2.7).
    """

    button: int
    pressed: bool
    sample: Sample


@dataclass(frozen=True)
class JointDiagnostics:
    """One joint's encoder input in DIAG_RSP (11 bytes)."""

    interface: int
    """:class:`EncoderInterface`."""
    bits: int
    """Position bits 1..32 (0 for ``COUNTS``)."""
    last_fault: int
    """:class:`EncoderFault` of the latest fault (``NONE`` if none yet)."""
    faults: int
    """Readings discarded since start-up."""
    warnings: int
    """Readings that carried the encoder's warning bit (still used)."""


@dataclass(frozen=True)
class Diagnostics:
    """DIAG_RSP (125 bytes): storage, reset cause, watchdog, encoder faults, link counters."""

    storage_kind: int
    storage_flags: int
    slot_state: tuple[int, int]
    slot_generation: tuple[int, int]
    storage_errors: int
    storage_bad_records: int
    reset_cause: int
    reset_raw: int
    fault_pc: int
    boot_count: int
    watchdog_ms: int
    uptime_us: int
    encoder_faults: int
    serial_frames_bad: int
    samples_dropped: int
    samples_late: int
    joints: tuple[JointDiagnostics, ...]


@dataclass(frozen=True)
class ErrorReply:
    """ERROR_RSP: negative status code and the type of the failed request."""

    status: int
    request_type: int


Payload: TypeAlias = (
    Ping
    | DeviceInfo
    | ParamSet
    | ParamCrc
    | MeasureRequest
    | Sample
    | ComputeRequest
    | ComputeResult
    | Stream
    | Trigger
    | Diagnostics
    | ErrorReply
    | None
)

PAYLOAD_CLASS: Final[dict[MsgType, type | None]] = {
    MsgType.PING_REQ: Ping,
    MsgType.INFO_REQ: None,
    MsgType.GET_PARAMS_REQ: None,
    MsgType.SET_PARAMS_REQ: ParamSet,
    MsgType.SAVE_PARAMS_REQ: None,
    MsgType.RESTORE_DEFAULTS_REQ: None,
    MsgType.MEASURE_REQ: MeasureRequest,
    MsgType.COMPUTE_REQ: ComputeRequest,
    MsgType.STREAM_START_REQ: Stream,
    MsgType.STREAM_STOP_REQ: None,
    MsgType.SAMPLE_EVT: Sample,
    MsgType.TRIGGER_EVT: Trigger,
    MsgType.PING_RSP: Ping,
    MsgType.INFO_RSP: DeviceInfo,
    MsgType.GET_PARAMS_RSP: ParamSet,
    MsgType.SET_PARAMS_RSP: ParamCrc,
    MsgType.SAVE_PARAMS_RSP: ParamCrc,
    MsgType.RESTORE_DEFAULTS_RSP: ParamCrc,
    MsgType.MEASURE_RSP: Sample,
    MsgType.COMPUTE_RSP: ComputeResult,
    MsgType.STREAM_START_RSP: Stream,
    MsgType.STREAM_STOP_RSP: None,
    MsgType.DIAG_REQ: None,
    MsgType.DIAG_RSP: Diagnostics,
    MsgType.ERROR_RSP: ErrorReply,
}
"""Which payload class each message type carries (``None``: empty payload)."""


@dataclass(frozen=True)
class Message:
    """One message: type, sequence number (0..255) and payload."""

    type: MsgType
    seq: int
    payload: Payload = None


# ---------------------------------------------------------------- encoding

PARAM_SET_BYTES: Final = 278
INFO_BYTES: Final = 23
SAMPLE_BASE_BYTES: Final = 53
JACOBIAN_BYTES: Final = 300
COMPUTE_RSP_BASE_BYTES: Final = 29
DIAG_JOINT_BYTES: Final = 11
DIAG_BYTES: Final = 59 + JOINTS * DIAG_JOINT_BYTES

_INFO = struct.Struct("<HBBHIIBBHIB")
_SAMPLE = struct.Struct("<IQ6I3iIB")
_PARAMS = struct.Struct("<25d6Q6I6b")
_COMPUTE_REQ = struct.Struct("<B6I")
_COMPUTE_RSP = struct.Struct("<I3dB")
_JAC = struct.Struct("<75f")
_DIAG = struct.Struct("<BB2B2IIIBIIIHQIIII")
_DIAG_JOINT = struct.Struct("<BBBII")


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


def _jacobian_flat(jac: object) -> tuple[float, ...]:
    """The 75 values of a 3 x 25 Jacobian (rows x, y, z), row-major."""
    try:
        rows = [tuple(r) for r in jac]  # type: ignore[attr-defined]
    except TypeError:
        rows = []
    if len(rows) != JAC_ROWS or any(len(r) != JAC_COLS for r in rows):
        raise ValueError(f"jacobian must be {JAC_ROWS} rows of {JAC_COLS} values (x, y, z)")
    return tuple(v for r in rows for v in r)


def _dec_jacobian(b: bytes, offset: int) -> Jacobian:
    flat = _finite(_JAC.unpack_from(b, offset))
    return tuple(flat[r * JAC_COLS : (r + 1) * JAC_COLS] for r in range(JAC_ROWS))


def _enc_jacobian(jac: Jacobian | None) -> bytes:
    if jac is None:
        return b""
    flat = _jacobian_flat(jac)
    _check_floats("jacobian", flat, JAC_SIZE, f32=True)
    try:
        return _JAC.pack(*flat)
    except OverflowError:  # rounding up past FLT_MAX
        raise ValueError("jacobian value does not fit a float32") from None


def _enc_sample(s: Sample) -> bytes:
    _check_int("seq", s.seq, 0, 0xFFFFFFFF)
    _check_int("timestamp_us", s.timestamp_us, 0, 0xFFFFFFFFFFFFFFFF)
    _check_ints("counts", s.counts, JOINTS, 0, 0xFFFFFFFF)
    _check_ints("point_100nm", s.point_100nm, 3, -(2**31), 2**31 - 1)
    _check_int("status", s.status, 0, 0xFFFFFFFF)
    content = Content.JACOBIAN if s.jacobian is not None else Content.NONE
    return _SAMPLE.pack(
        s.seq, s.timestamp_us, *s.counts, *s.point_100nm, s.status, content
    ) + _enc_jacobian(s.jacobian)


def encode_param_set(p: ParamSet) -> bytes:
    """The 278-byte wire encoding of a parameter set.

    Raises:
        ValueError: a value the decoder would reject.
    """
    for name in ("theta_offset_rad", "alpha_rad", "d_mm", "a_mm"):
        _check_floats(name, getattr(p, name), JOINTS)
    _check_floats("l_mm", (p.l_mm,), 1)
    _check_ints("counts_per_rev", p.counts_per_rev, JOINTS, 2, COUNTS_PER_REV_MAX)
    _check_ints("zero_offset_counts", p.zero_offset_counts, JOINTS, 0, 0xFFFFFFFF)
    _check_ints("direction", p.direction, JOINTS, -1, 1)
    for i in range(JOINTS):
        if p.direction[i] == 0:
            raise ValueError(f"direction[{i}] must be +1 or -1")
        if p.zero_offset_counts[i] >= p.counts_per_rev[i]:
            raise ValueError(f"zero_offset_counts[{i}] must be < counts_per_rev[{i}]")
    return _PARAMS.pack(
        *p.theta_offset_rad,
        *p.alpha_rad,
        *p.d_mm,
        *p.a_mm,
        p.l_mm,
        *p.counts_per_rev,
        *p.zero_offset_counts,
        *p.direction,
    )


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
        return _INFO.pack(
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
        )
    if isinstance(p, ParamSet):
        return encode_param_set(p)
    if isinstance(p, ParamCrc):
        _check_int("param_crc32", p.param_crc32, 0, 0xFFFFFFFF)
        return struct.pack("<I", p.param_crc32)
    if isinstance(p, MeasureRequest):
        _check_flag("jacobian", p.jacobian)
        return bytes([int(p.jacobian)])
    if isinstance(p, Sample):
        return _enc_sample(p)
    if isinstance(p, ComputeRequest):
        _check_flag("jacobian", p.jacobian)
        _check_ints("counts", p.counts, JOINTS, 0, 0xFFFFFFFF)
        return _COMPUTE_REQ.pack(int(p.jacobian), *p.counts)
    if isinstance(p, ComputeResult):
        _check_int("status", p.status, 0, 0xFFFFFFFF)
        _check_floats("point_mm", p.point_mm, 3)
        content = Content.JACOBIAN if p.jacobian is not None else Content.NONE
        return _COMPUTE_RSP.pack(p.status, *p.point_mm, content) + _enc_jacobian(p.jacobian)
    if isinstance(p, Stream):
        _check_int("rate_hz", p.rate_hz, STREAM_RATE_MIN_HZ, STREAM_RATE_MAX_HZ)
        _check_flag("jacobian", p.jacobian)
        return struct.pack("<HB", p.rate_hz, int(p.jacobian))
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
    )
    for name in u32s:
        _check_int(name, getattr(d, name), 0, 0xFFFFFFFF)
    if len(d.joints) != JOINTS:
        raise ValueError(f"joints needs {JOINTS} entries, got {len(d.joints)}")
    out = _DIAG.pack(
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
    )
    for i, j in enumerate(d.joints):
        if not isinstance(j, JointDiagnostics):
            raise ValueError(f"joints[{i}] must be a JointDiagnostics")
        _check_int(f"joints[{i}].interface", j.interface, 0, max(EncoderInterface))
        _check_int(f"joints[{i}].bits", j.bits, 0, 32)
        _check_int(f"joints[{i}].last_fault", j.last_fault, 0, max(EncoderFault))
        _check_int(f"joints[{i}].faults", j.faults, 0, 0xFFFFFFFF)
        _check_int(f"joints[{i}].warnings", j.warnings, 0, 0xFFFFFFFF)
        out += _DIAG_JOINT.pack(j.interface, j.bits, j.last_fault, j.faults, j.warnings)
    return out


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


# ---------------------------------------------------------------- decoding


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


def payload_length(t: MsgType, jacobian: bool = False) -> int:
    """Payload bytes of message type ``t`` (with or without the Jacobian)."""
    jac = JACOBIAN_BYTES if jacobian else 0
    sizes: dict[MsgType, int] = {
        MsgType.PING_REQ: 4,
        MsgType.PING_RSP: 4,
        MsgType.SET_PARAMS_RSP: 4,
        MsgType.SAVE_PARAMS_RSP: 4,
        MsgType.RESTORE_DEFAULTS_RSP: 4,
        MsgType.INFO_RSP: INFO_BYTES,
        MsgType.SET_PARAMS_REQ: PARAM_SET_BYTES,
        MsgType.GET_PARAMS_RSP: PARAM_SET_BYTES,
        MsgType.MEASURE_REQ: 1,
        MsgType.COMPUTE_REQ: 25,
        MsgType.STREAM_START_REQ: 3,
        MsgType.STREAM_START_RSP: 3,
        MsgType.ERROR_RSP: 3,
        MsgType.MEASURE_RSP: SAMPLE_BASE_BYTES + jac,
        MsgType.SAMPLE_EVT: SAMPLE_BASE_BYTES + jac,
        MsgType.TRIGGER_EVT: 2 + SAMPLE_BASE_BYTES + jac,
        MsgType.COMPUTE_RSP: COMPUTE_RSP_BASE_BYTES + jac,
        MsgType.DIAG_RSP: DIAG_BYTES,
    }
    return sizes.get(t, 0)


# Offset of the content byte inside the payload, for types that have one.
_CONTENT_OFFSET: Final[dict[MsgType, int]] = {
    MsgType.MEASURE_RSP: SAMPLE_BASE_BYTES - 1,
    MsgType.SAMPLE_EVT: SAMPLE_BASE_BYTES - 1,
    MsgType.TRIGGER_EVT: 2 + SAMPLE_BASE_BYTES - 1,
    MsgType.COMPUTE_RSP: COMPUTE_RSP_BASE_BYTES - 1,
}


def _dec_sample(b: bytes) -> Sample:
    f = _SAMPLE.unpack_from(b)
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
    f = _PARAMS.unpack(bytes(b))
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
    f = _DIAG.unpack_from(b)
    joints = tuple(
        JointDiagnostics(*_DIAG_JOINT.unpack_from(b, _DIAG.size + i * DIAG_JOINT_BYTES))
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
        info = DeviceInfo(*_INFO.unpack(b))
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
        f = _COMPUTE_REQ.unpack(b)
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
        f = _COMPUTE_RSP.unpack_from(b)
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


def frame_message(msg: Message) -> bytes:
    """Encode a message and wrap it in a serial frame (see :mod:`aacmm.protocol.framing`).

    Raises:
        ValueError: as :func:`encode_message`.
    """
    return encode_frame(encode_message(msg))


def response_type(request: MsgType) -> MsgType:
    """The response type of a request type (``request | 0x80``).

    Raises:
        ValueError: ``request`` is not a request type (0x01..0x3F).
    """
    if not 0x01 <= int(request) <= 0x3F:
        raise ValueError(f"{request!r} is not a request type")
    return MsgType(int(request) | RESPONSE_BIT)


def device_error(msg: Message) -> DeviceError:
    """The :class:`aacmm.errors.DeviceError` for an ERROR_RSP message (for the caller to raise).

    Raises:
        ValueError: ``msg`` is not an ERROR_RSP.
    """
    if not isinstance(msg.payload, ErrorReply):
        raise ValueError("not an error response")
    reply = msg.payload
    try:
        req = MsgType(reply.request_type).name
    except ValueError:
        req = f"type 0x{reply.request_type:02x}"
    return DeviceError(
        f"device refused {req} (seq {msg.seq}): {status_name(reply.status)}",
        reply.status,
        reply.request_type,
    )
