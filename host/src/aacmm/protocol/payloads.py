"""Payload classes of the link protocol's messages, mirroring ``aacmm/proto.h`` field for field."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Final, TypeAlias

from aacmm.protocol.constants import POINT_UNIT_MM, MsgType

if TYPE_CHECKING:
    from aacmm.arm import Arm
    from aacmm.core import EncoderConfig, Params

Jacobian = tuple[tuple[float, ...], ...]
"""A Jacobian as the codec gives it: 3 rows (x, y, z) of P values (mm per
parameter unit, columns as the arm's ``param_names``; the paper's arm: 25, as
:data:`aacmm.core.PARAM_NAMES`), the shape ``aacmm.core`` uses:
``np.asarray(sample.jacobian)`` is a (3, P) array."""


@dataclass(frozen=True)
class Ping:
    """PING_REQ / PING_RSP: a u32 token the device echoes."""

    token: int


@dataclass(frozen=True)
class DeviceInfo:
    """INFO_RSP (25 bytes): ``joints`` N and ``params`` P of the active arm model."""

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
    joints: int = 6
    params: int = 25


@dataclass(frozen=True)
class ParamSet:
    """SET_PARAMS_REQ / GET_PARAMS_RSP: the arm model, its encoders, its error model.

    One entry per joint (N = 4..7) in every per-joint tuple. Kinematic
    parameters are float64, mm and rad, finite; ``l_mm`` is the tip's z in
    the last frame (the paper's l). The shape: ``convention`` per joint 0
    (standard DH) or 1 (modified DH), ``()`` = all standard; ``beta_rad`` per
    joint a Hayati beta or ``None``, ``()`` = none (never joint 1);
    ``tip_xy_mm`` ``None`` for the tip (0, 0, l) (one parameter), else
    (t_x, t_y) with t_z = l (three parameters). Encoders: counts per
    revolution 2 .. 2**32, zero offset in counts (< counts per revolution),
    direction +1 or -1. The error model (issue 27): ``harm_cos``/``harm_sin``
    N rows, row i the K_i <= 4 encoder harmonics of joint i + 1 in units of
    1e-7 rad (rows may differ in length; ``()`` = every K_i 0), ``cte`` N
    link coefficients of thermal expansion in 1e-8/K and ``ref_temp`` (every
    link's reference temperature) in 0.01 degC, -4000 .. 8500 (``()`` = no
    thermal block). ``aacmm.protocol.errwire`` converts an
    :class:`aacmm.errmodel.ErrorModel` to and from these fields. Layout:
    docs/protocol.md 2.3.
    """

    theta_offset_rad: tuple[float, ...]
    alpha_rad: tuple[float, ...]
    d_mm: tuple[float, ...]
    a_mm: tuple[float, ...]
    l_mm: float
    counts_per_rev: tuple[int, ...]
    zero_offset_counts: tuple[int, ...]
    direction: tuple[int, ...]
    convention: tuple[int, ...] = ()
    beta_rad: tuple[float | None, ...] = ()
    tip_xy_mm: tuple[float, float] | None = None
    harm_cos: tuple[tuple[int, ...], ...] = ()
    harm_sin: tuple[tuple[int, ...], ...] = ()
    cte: tuple[int, ...] = ()
    ref_temp: int = 0

    def __post_init__(self) -> None:
        # One form per set (as on the wire): all standard is (), no beta is ().
        conv = tuple(self.convention)
        beta = tuple(self.beta_rad)
        object.__setattr__(self, "convention", conv if any(conv) else ())
        object.__setattr__(self, "beta_rad", beta if any(b is not None for b in beta) else ())

    @property
    def joints(self) -> int:
        """N, the number of joints."""
        return len(self.theta_offset_rad)

    @property
    def n_params(self) -> int:
        """P = 4N + B + T: the arm model's parameters (Jacobian columns)."""
        betas = sum(1 for b in self.beta_rad if b is not None)
        return 4 * self.joints + betas + (1 if self.tip_xy_mm is None else 3)

    @property
    def harmonics(self) -> tuple[int, ...]:
        """K_i, the encoder harmonics of each joint's error model (all 0: none)."""
        return tuple(len(r) for r in self.harm_cos) if self.harm_cos else (0,) * self.joints

    @property
    def is_paper_shape(self) -> bool:
        """Six standard joints, no beta, tip l: the 25 parameters of :class:`aacmm.core.Params`."""
        return (
            self.joints == 6
            and not any(self.convention)
            and all(b is None for b in self.beta_rad)
            and self.tip_xy_mm is None
        )

    def to_core(self) -> tuple[Params, EncoderConfig]:
        """The set as :class:`aacmm.core.Params` and :class:`aacmm.core.EncoderConfig`,
        ready for ``Model(params)`` and ``counts_to_angles(counts, encoders)``::

            params, encoders = arm.get_params().to_core()
            point, jac = Model(params).point_jacobian(counts_to_angles([counts], encoders)[0])

        Raises:
            ValueError: the set is not of the paper's shape (use :meth:`to_arm`).
        """
        from aacmm.core import EncoderConfig, Params

        if not self.is_paper_shape:
            raise ValueError(
                f"the parameter set is an arm of {self.joints} joints and {self.n_params} "
                "parameters, not the paper's six-joint shape"
            )
        return (
            Params(self.theta_offset_rad, self.alpha_rad, self.d_mm, self.a_mm, self.l_mm),
            EncoderConfig(self.counts_per_rev, self.zero_offset_counts, self.direction),
        )

    def to_arm(self) -> tuple[Arm, EncoderConfig]:
        """The set as an :class:`aacmm.arm.Arm` (any shape) and its encoders, for
        ``Model(arm)`` and ``counts_to_angles(counts, encoders)``."""
        from aacmm.arm import Arm, Joint
        from aacmm.core import EncoderConfig

        n = self.joints
        conv = self.convention or (0,) * n
        beta = self.beta_rad or (None,) * n
        joints = tuple(
            Joint(
                convention="modified" if conv[i] else "standard",
                theta_offset_rad=self.theta_offset_rad[i],
                alpha_rad=self.alpha_rad[i],
                d_mm=self.d_mm[i],
                a_mm=self.a_mm[i],
                beta_rad=beta[i],
            )
            for i in range(n)
        )
        if self.tip_xy_mm is None:
            arm = Arm(joints, "z", (0.0, 0.0, self.l_mm))
        else:
            arm = Arm(joints, "xyz", (self.tip_xy_mm[0], self.tip_xy_mm[1], self.l_mm))
        return arm, EncoderConfig(self.counts_per_rev, self.zero_offset_counts, self.direction)

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

    @classmethod
    def from_arm(cls, arm: Arm, encoders: EncoderConfig | None = None) -> ParamSet:
        """The device's set for any :class:`aacmm.arm.Arm` and its encoders (default:
        2^32 counts per revolution, no offset, direction +1 on every joint): the
        inverse of :meth:`to_arm`. A set of the paper's shape equals
        :meth:`from_core` of the same values."""
        from aacmm.core import EncoderConfig

        n = arm.n_joints
        enc = encoders if encoders is not None else EncoderConfig.default(n)
        js = arm.joints
        conv = tuple(1 if j.convention == "modified" else 0 for j in js)
        beta = tuple(j.beta_rad for j in js)
        return cls(
            tuple(j.theta_offset_rad for j in js),
            tuple(j.alpha_rad for j in js),
            tuple(j.d_mm for j in js),
            tuple(j.a_mm for j in js),
            arm.tip_mm[2],
            enc.counts_per_rev,
            enc.zero_offset_counts,
            enc.direction,
            convention=conv,
            beta_rad=beta,
            tip_xy_mm=None if arm.tip == "z" else (arm.tip_mm[0], arm.tip_mm[1]),
        )


@dataclass(frozen=True)
class ParamCrc:
    """SET_PARAMS_RSP / SAVE_PARAMS_RSP / RESTORE_DEFAULTS_RSP: CRC of the resulting set."""

    param_crc32: int


@dataclass(frozen=True)
class MeasureRequest:
    """MEASURE_REQ."""

    jacobian: bool = False
    temperatures: bool = False


@dataclass(frozen=True)
class Sample:
    """MEASURE_RSP / SAMPLE_EVT (31 + 4N bytes, + 2N with temperatures, + 12P with the
    Jacobian).

    ``counts`` holds the N joint readings of the device's arm model;
    ``point_100nm`` is the probe point in units of 1e-4 mm (see :attr:`point_mm`);
    ``params`` is P, the arm model's parameters; ``jacobian`` is a
    :data:`Jacobian` (3 rows of P float32 values: shape (3, P) as in
    :mod:`aacmm.core`) or ``None``.
    """

    seq: int
    timestamp_us: int
    counts: tuple[int, ...]
    point_100nm: tuple[int, ...]
    status: int
    jacobian: Jacobian | None = None
    params: int = 25
    temp: tuple[int, ...] | None = None
    """The N link temperatures as on the wire (0.01 degC, :data:`TEMP_NONE` for a
    link without a reading) when the content has TEMPERATURES, else ``None``."""

    @property
    def point_mm(self) -> tuple[float, float, float]:
        """The point in mm."""
        x, y, z = (v * POINT_UNIT_MM for v in self.point_100nm)
        return (x, y, z)


@dataclass(frozen=True)
class ComputeRequest:
    """COMPUTE_REQ: the N encoder counts (N of the device's arm model) to evaluate."""

    counts: tuple[int, ...]
    jacobian: bool = False
    temp: tuple[int, ...] | None = None
    """The N link temperatures to compute at (0.01 degC, -4000 .. 8500), or ``None``:
    the reference temperatures."""


@dataclass(frozen=True)
class ComputeResult:
    """COMPUTE_RSP: the device's point in mm (float64), P of its arm model and the
    optional :data:`Jacobian` (3 rows of P)."""

    status: int
    point_mm: tuple[float, ...]
    jacobian: Jacobian | None = None
    params: int = 25
    temperatures: bool = False
    """True when the point was computed at the request's temperatures."""


@dataclass(frozen=True)
class Stream:
    """STREAM_START_REQ / STREAM_START_RSP: rate 1..1000 Hz and content."""

    rate_hz: int
    jacobian: bool = False
    temperatures: bool = False


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
    """DIAG_RSP (64 + 11N bytes): storage, reset cause, watchdog, encoder faults, link
    counters; ``joints`` one entry per joint of the arm model, then ``temp_faults``."""

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
    temp_faults: int = 0
    """Samples with :attr:`SampleStatus.TEMP_FAULT` (version 4: after the joints)."""


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
