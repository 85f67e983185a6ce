"""Message codec of the aacmm link protocol, version 4 (see ``docs/protocol.md``).

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

The codec's public names are those of :mod:`aacmm.protocol`; the parts live in
:mod:`~aacmm.protocol.constants` (wire constants, enumerations),
:mod:`~aacmm.protocol.payloads` (payload classes, :class:`Message`),
:mod:`~aacmm.protocol.layout` (payload sizes and byte layouts),
:mod:`~aacmm.protocol.encode` and :mod:`~aacmm.protocol.decode`. Here:
framing a message, request/response types and error responses.
"""

from __future__ import annotations

from aacmm.errors import DeviceError
from aacmm.protocol.constants import (
    RESPONSE_BIT,
    MsgType,
)
from aacmm.protocol.encode import encode_message
from aacmm.protocol.framing import encode_frame
from aacmm.protocol.payloads import (
    ErrorReply,
    Message,
)
from aacmm.protocol.status import status_name

__all__ = [
    "device_error",
    "frame_message",
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
