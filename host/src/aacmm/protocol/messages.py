"""Message codec of the aacmm link protocol, version 1 (see ``docs/protocol.md``).

A message body is ``version u8 | type u8 | seq u8 | payload``, little-endian.
:func:`encode_message` and :func:`decode_message` convert between bodies and
:class:`Message` objects; the payload classes mirror the C structs of
``firmware/include/aacmm/proto.h`` field for field.

Decoding checks everything the C decoder checks (exact payload length, known
type and version, finite floats, no unknown flag bits, enumerations in range)
and raises :class:`aacmm.errors.FrameError` carrying the same status code the
C decoder returns. Encoding raises :class:`ValueError` for values the decoder
would reject, so ``decode_message(encode_message(m)) == m`` for every message
that encodes.

This module is the codec's one import path; the parts live in
:mod:`~aacmm.protocol.constants` (wire constants, enumerations),
:mod:`~aacmm.protocol.payloads` (payload classes, :class:`Message`),
:mod:`~aacmm.protocol.layout` (payload sizes and byte layouts),
:mod:`~aacmm.protocol.encode` and :mod:`~aacmm.protocol.decode`. Here:
framing a message, request/response types and error responses.
"""

from __future__ import annotations

from aacmm.errors import DeviceError
from aacmm.protocol.constants import (
    COUNTS_PER_REV_MAX,
    HEADER_BYTES,
    JAC_COLS,
    JAC_ROWS,
    JAC_SIZE,
    JOINTS,
    MAX_BODY,
    POINT_UNIT_MM,
    PROTOCOL_VERSION,
    RESPONSE_BIT,
    STREAM_RATE_MAX_HZ,
    STREAM_RATE_MIN_HZ,
    BuildFlags,
    Button,
    Content,
    EncoderFault,
    EncoderInterface,
    MsgType,
    ParamSource,
    ResetCause,
    SampleStatus,
    SlotState,
    StorageFlags,
    StorageKind,
    StorageState,
)
from aacmm.protocol.decode import decode_message, decode_param_set
from aacmm.protocol.encode import encode_message, encode_param_set, param_set_crc32
from aacmm.protocol.framing import encode_frame
from aacmm.protocol.layout import (
    COMPUTE_RSP_BASE_BYTES,
    DIAG_BYTES,
    DIAG_JOINT_BYTES,
    INFO_BYTES,
    JACOBIAN_BYTES,
    PARAM_SET_BYTES,
    SAMPLE_BASE_BYTES,
    payload_length,
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
from aacmm.protocol.status import status_name

__all__ = [
    "COMPUTE_RSP_BASE_BYTES",
    "COUNTS_PER_REV_MAX",
    "DIAG_BYTES",
    "DIAG_JOINT_BYTES",
    "HEADER_BYTES",
    "INFO_BYTES",
    "JACOBIAN_BYTES",
    "JAC_COLS",
    "JAC_ROWS",
    "JAC_SIZE",
    "JOINTS",
    "MAX_BODY",
    "PARAM_SET_BYTES",
    "PAYLOAD_CLASS",
    "POINT_UNIT_MM",
    "PROTOCOL_VERSION",
    "RESPONSE_BIT",
    "SAMPLE_BASE_BYTES",
    "STREAM_RATE_MAX_HZ",
    "STREAM_RATE_MIN_HZ",
    "BuildFlags",
    "Button",
    "ComputeRequest",
    "ComputeResult",
    "Content",
    "DeviceInfo",
    "Diagnostics",
    "EncoderFault",
    "EncoderInterface",
    "ErrorReply",
    "Jacobian",
    "JointDiagnostics",
    "MeasureRequest",
    "Message",
    "MsgType",
    "ParamCrc",
    "ParamSet",
    "ParamSource",
    "Payload",
    "Ping",
    "ResetCause",
    "Sample",
    "SampleStatus",
    "SlotState",
    "StorageFlags",
    "StorageKind",
    "StorageState",
    "Stream",
    "Trigger",
    "decode_message",
    "decode_param_set",
    "device_error",
    "encode_message",
    "encode_param_set",
    "frame_message",
    "param_set_crc32",
    "payload_length",
    "response_type",
]


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
