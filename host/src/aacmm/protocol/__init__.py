"""The aacmm link protocol, host side (specification: ``docs/protocol.md``).

- :mod:`aacmm.protocol.messages`: message set, :func:`encode_message`,
  :func:`decode_message` (the codec's import path), built from
  :mod:`~aacmm.protocol.constants` (message types, flags, enumerations),
  :mod:`~aacmm.protocol.payloads` (payload classes, :class:`Message`),
  :mod:`~aacmm.protocol.layout` (payload sizes and byte layouts),
  :mod:`~aacmm.protocol.encode` and :mod:`~aacmm.protocol.decode`
- :mod:`aacmm.protocol.framing`: serial frames (COBS + CRC-32), :class:`Deframer`
- :mod:`aacmm.protocol.can`: CAN sample frames (DBC), :class:`SampleAssembler`,
  ISO-TP address and parameters
- :mod:`aacmm.protocol.status`: status codes shared with the firmware

Errors: :class:`aacmm.errors.FrameError` (bytes that are not a valid frame or
message; ``status`` is the firmware's code for the reason) and ``ValueError``
for values that cannot be encoded.
"""

from aacmm.protocol.can import (
    CanFrame,
    SampleAssembler,
    encode_sample_frames,
    isotp_address,
    isotp_params,
    load_dbc,
    make_isotp_stack,
)
from aacmm.protocol.constants import (
    PROTOCOL_VERSION,
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
from aacmm.protocol.framing import Deframer, crc32, decode_frame, encode_frame
from aacmm.protocol.messages import device_error, frame_message, response_type
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
    Ping,
    Sample,
    Stream,
    Trigger,
)
from aacmm.protocol.status import Status, status_name

__all__ = [
    "PROTOCOL_VERSION",
    "BuildFlags",
    "Button",
    "CanFrame",
    "ComputeRequest",
    "ComputeResult",
    "Content",
    "Deframer",
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
    "Ping",
    "ResetCause",
    "Sample",
    "SampleAssembler",
    "SampleStatus",
    "SlotState",
    "Status",
    "StorageFlags",
    "StorageKind",
    "StorageState",
    "Stream",
    "Trigger",
    "crc32",
    "decode_frame",
    "decode_message",
    "decode_param_set",
    "device_error",
    "encode_frame",
    "encode_message",
    "encode_param_set",
    "encode_sample_frames",
    "frame_message",
    "isotp_address",
    "isotp_params",
    "load_dbc",
    "make_isotp_stack",
    "param_set_crc32",
    "response_type",
    "status_name",
]
