"""The aacmm link protocol, host side (specification: ``docs/protocol.md``).

- :mod:`aacmm.protocol.messages`: message set, :func:`encode_message`,
  :func:`decode_message`
- :mod:`aacmm.protocol.framing`: serial frames (COBS + CRC-32), :class:`Deframer`
- :mod:`aacmm.protocol.can`: CAN sample frames (DBC), :class:`SampleAssembler`,
  ISO-TP address and parameters
- :mod:`aacmm.protocol.status`: status codes shared with the firmware
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
from aacmm.protocol.framing import Deframer, crc32, decode_frame, encode_frame
from aacmm.protocol.messages import (
    PROTOCOL_VERSION,
    BuildFlags,
    ComputeRequest,
    ComputeResult,
    Content,
    DeviceInfo,
    ErrorReply,
    MeasureRequest,
    Message,
    MsgType,
    ParamCrc,
    ParamSet,
    ParamSource,
    Ping,
    Sample,
    SampleStatus,
    StorageState,
    Stream,
    Trigger,
    decode_message,
    decode_param_set,
    encode_message,
    encode_param_set,
    frame_message,
    param_set_crc32,
)
from aacmm.protocol.status import Status, status_name

__all__ = [
    "PROTOCOL_VERSION",
    "BuildFlags",
    "CanFrame",
    "ComputeRequest",
    "ComputeResult",
    "Content",
    "Deframer",
    "DeviceInfo",
    "ErrorReply",
    "MeasureRequest",
    "Message",
    "MsgType",
    "ParamCrc",
    "ParamSet",
    "ParamSource",
    "Ping",
    "Sample",
    "SampleAssembler",
    "SampleStatus",
    "Status",
    "StorageState",
    "Stream",
    "Trigger",
    "crc32",
    "decode_frame",
    "decode_message",
    "decode_param_set",
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
    "status_name",
]
