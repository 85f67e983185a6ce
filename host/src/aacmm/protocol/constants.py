"""Wire constants and enumerations of the aacmm link protocol (``docs/protocol.md``)."""

from __future__ import annotations

from enum import IntEnum, IntFlag
from typing import Final

PROTOCOL_VERSION: Final = 4
PROTOCOL_VERSION_PREVIOUS: Final = 3
"""The error-model version before device temperatures (issue 27): its requests are
answered with an ERROR_RSP ERR_VERSION encoded in version 3, and a body of it is
reported as such."""
PROTOCOL_VERSION_OLDEST: Final = 1
"""The six-joint version before the arm model: answered alike, in version 1 (and
version 2, the arm model before the error model's layout, in version 2)."""
OLD_PROTOCOL_VERSIONS: Final[dict[int, str]] = {
    1: "six joints, before arm models",
    2: "arm models, before the error model",
    3: "before device temperatures",
}
"""What each older version (OLDEST .. PREVIOUS) lacks, as the version errors name it."""
HEADER_BYTES: Final = 3
MAX_BODY: Final = 512
JOINTS: Final = 6
"""The paper's arm's joint count (any arm model has 4..7: JOINTS_MIN..JOINTS_MAX)."""
JOINTS_MIN: Final = 4
JOINTS_MAX: Final = 7
PARAMS_MAX: Final = 37
JAC_ROWS: Final = 3
JAC_COLS: Final = 25
JAC_SIZE: Final = 75
"""The paper's arm's 3x25 Jacobian; an arm model's is 3 x P (P = 4N + B + T),
row-major, columns in aacmm/kinematics.h's order."""

POINT_UNIT_MM: Final = 1e-4
"""Wire unit of the sample point: int32 counts of 1e-4 mm (100 nm)."""
TEMP_UNIT_C: Final = 0.01
"""A link temperature on the wire (samples, COMPUTE_REQ): i16 in 0.01 degC."""
TEMP_NONE: Final = -32768
"""The wire value of a link temperature the sensor did not give."""
STREAM_RATE_MIN_HZ: Final = 1
STREAM_RATE_MAX_HZ: Final = 1000
COUNTS_PER_REV_MAX: Final = 1 << 32
RESPONSE_BIT: Final = 0x80


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
    #: samples: the N link temperatures follow the counts; COMPUTE_REQ: the
    #: temperatures to compute at (docs/protocol.md 2.4, 2.5)
    TEMPERATURES = 0x02


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
    JOINT7_FAULT = 0x4000
    #: a link temperature was missing or outside -40 .. 85 degC; with the
    #: thermal block in force the sample has no point
    TEMP_FAULT = 0x8000


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
    #: the platform reads link temperatures (known at run time)
    TEMPERATURES = 0x0020


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
