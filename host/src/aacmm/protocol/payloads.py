"""Payload classes of the link protocol's messages, mirroring ``aacmm/proto.h`` field for field."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Final, TypeAlias

from aacmm.protocol.constants import POINT_UNIT_MM, MsgType

if TYPE_CHECKING:
    from aacmm.core import EncoderConfig, Params

Jacobian = tuple[tuple[float, ...], ...]
"""A Jacobian as the codec gives it: 3 rows (x, y, z) of 25 values (mm per
parameter unit, columns as :data:`aacmm.core.PARAM_NAMES`), the shape
``aacmm.core`` uses: ``np.asarray(sample.jacobian)`` is a (3, 25) array."""


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
