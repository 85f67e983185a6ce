"""Byte layouts of the link protocol's payloads: sizes and ``struct`` formats."""

from __future__ import annotations

import struct
from typing import Final

from aacmm.protocol.constants import JOINTS, MsgType

PARAM_SET_BYTES: Final = 278
INFO_BYTES: Final = 23
SAMPLE_BASE_BYTES: Final = 53
JACOBIAN_BYTES: Final = 300
COMPUTE_RSP_BASE_BYTES: Final = 29
DIAG_JOINT_BYTES: Final = 11
DIAG_BYTES: Final = 59 + JOINTS * DIAG_JOINT_BYTES

INFO_LAYOUT = struct.Struct("<HBBHIIBBHIB")
SAMPLE_LAYOUT = struct.Struct("<IQ6I3iIB")
PARAMS_LAYOUT = struct.Struct("<25d6Q6I6b")
COMPUTE_REQ_LAYOUT = struct.Struct("<B6I")
COMPUTE_RSP_LAYOUT = struct.Struct("<I3dB")
JACOBIAN_LAYOUT = struct.Struct("<75f")
DIAG_LAYOUT = struct.Struct("<BB2B2IIIBIIIHQIIII")
DIAG_JOINT_LAYOUT = struct.Struct("<BBBII")


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
