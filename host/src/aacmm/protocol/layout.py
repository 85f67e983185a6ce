"""Byte layouts of the link protocol's payloads (version 4): sizes and ``struct`` formats.

Sizes depend on the arm model: N joints (4..7), P parameters (Jacobian
columns, ``P = 4N + B + T``), and for a parameter set S, the sum of the
joints' encoder harmonics K_i (0..4 each), and H = 1 with the thermal block
(docs/protocol.md 2.3).
"""

from __future__ import annotations

import struct
from typing import Final

from aacmm.protocol.constants import HEADER_BYTES, JOINTS, MsgType

HARMONICS_MAX: Final = 4
PARAM_SET_HEADER_BYTES: Final = 8
PARAM_SET_MAX_BYTES: Final = 495
"""The largest parameter set: N 7, P 37, K 4 on every joint, H 1 (fits one 509-byte payload)."""
PARAM_THERMAL_BIT: Final = 28
"""H's bit in the header's u32 at offset 4 (K_i in nibble i - 1)."""
REF_TEMP_MIN: Final = -4000
"""The reference temperature's range on the wire, 0.01 degC: -40 .. 85 degC."""
REF_TEMP_MAX: Final = 8500
INFO_BYTES: Final = 25
SAMPLE_BASE_BYTES: Final = 31
"""A sample's fixed part, before its N counts, temperatures and Jacobian."""
SAMPLE_MAX_BYTES: Final = 505
"""The largest sample: N 7, P 36 with temperatures and Jacobian (N 7, P 37 with both
would be 517 bytes, more than a body holds: the encoders refuse it)."""
COMPUTE_RSP_BASE_BYTES: Final = 30
DIAG_BASE_BYTES: Final = 60
DIAG_JOINT_BYTES: Final = 11
DIAG_TAIL_BYTES: Final = 4
"""DIAG_RSP's u32 temp_faults after the joints."""
TRIGGER_EXTRA_BYTES: Final = 2


def param_set_bytes(n: int, p: int, s: int = 0, h: int = 0) -> int:
    """Bytes of a parameter set of N joints, P parameters, S harmonics in all (the sum
    of the K_i), thermal block H."""
    return PARAM_SET_HEADER_BYTES + 8 * p + 9 * n + 4 * s + 2 * (n + 1) * h


def sample_bytes(n: int, p: int, jacobian: bool, temperatures: bool = False) -> int:
    """Bytes of a sample of N counts (and N i16 temperatures, and a 3 x P Jacobian)."""
    return SAMPLE_BASE_BYTES + 4 * n + (2 * n if temperatures else 0) + (12 * p if jacobian else 0)


def compute_req_bytes(n: int, temperatures: bool = False) -> int:
    """Bytes of COMPUTE_REQ for N counts (and N i16 temperatures)."""
    return 2 + 4 * n + (2 * n if temperatures else 0)


def diag_bytes(n: int) -> int:
    """Bytes of DIAG_RSP for N joints (their entries, then u32 temp_faults)."""
    return DIAG_BASE_BYTES + DIAG_JOINT_BYTES * n + DIAG_TAIL_BYTES


PARAM_SET_BYTES: Final = param_set_bytes(JOINTS, 25)
"""The paper's arm's parameter set (262 bytes)."""
JACOBIAN_BYTES: Final = 12 * 25
"""The paper's arm's Jacobian (3 x 25 float32)."""
DIAG_BYTES: Final = diag_bytes(JOINTS)
"""DIAG_RSP of a six-joint arm (130 bytes)."""

INFO_LAYOUT = struct.Struct("<HBBHIIBBHIBBB")
SAMPLE_LAYOUT = struct.Struct("<IQ3iIBBB")
PARAM_HEADER_LAYOUT = struct.Struct("<BBBBI")
COMPUTE_RSP_LAYOUT = struct.Struct("<I3dBB")
DIAG_LAYOUT = struct.Struct("<BB2B2IIIBIIIHQIIIIB")
DIAG_JOINT_LAYOUT = struct.Struct("<BBBII")


def _popcount(v: int) -> int:
    return bin(v).count("1")


def param_set_len_raw(b: bytes) -> int:
    """A parameter set's length as its (unchecked) header bytes define it (the header's
    own length if ``b`` is shorter)."""
    if len(b) < PARAM_SET_HEADER_BYTES:
        return PARAM_SET_HEADER_BYTES
    n, tip, _conv, beta, em = PARAM_HEADER_LAYOUT.unpack_from(b)
    ksum = sum((em >> (4 * i)) & 0xF for i in range(7))  # past N too: length first
    return param_set_bytes(n, 4 * n + _popcount(beta) + tip, ksum, (em >> PARAM_THERMAL_BIT) & 1)


def _sample_len_raw(b: bytes) -> int:
    if len(b) < SAMPLE_BASE_BYTES:
        return SAMPLE_BASE_BYTES
    return sample_bytes(b[29], b[30], bool(b[28] & 1), bool(b[28] & 2))


def payload_length(t: MsgType, payload: bytes = b"") -> int:
    """Payload bytes of a message of type ``t`` as the payload's own bytes (content, N, P,
    K, H, read unchecked) define it; when the payload is too short to hold them, the
    length of the fields that define it (so a short payload never matches)."""
    if t in (MsgType.SET_PARAMS_REQ, MsgType.GET_PARAMS_RSP):
        return param_set_len_raw(payload)
    if t == MsgType.COMPUTE_REQ:
        return compute_req_bytes(payload[1], bool(payload[0] & 2)) if len(payload) >= 2 else 2
    if t in (MsgType.MEASURE_RSP, MsgType.SAMPLE_EVT):
        return _sample_len_raw(payload)
    if t == MsgType.TRIGGER_EVT:
        return TRIGGER_EXTRA_BYTES + _sample_len_raw(payload[TRIGGER_EXTRA_BYTES:])
    if t == MsgType.COMPUTE_RSP:
        if len(payload) < COMPUTE_RSP_BASE_BYTES:
            return COMPUTE_RSP_BASE_BYTES
        return COMPUTE_RSP_BASE_BYTES + (12 * payload[29] if payload[28] & 1 else 0)
    if t == MsgType.DIAG_RSP:
        return diag_bytes(payload[59]) if len(payload) >= DIAG_BASE_BYTES else DIAG_BASE_BYTES
    sizes: dict[MsgType, int] = {
        MsgType.PING_REQ: 4,
        MsgType.PING_RSP: 4,
        MsgType.SET_PARAMS_RSP: 4,
        MsgType.SAVE_PARAMS_RSP: 4,
        MsgType.RESTORE_DEFAULTS_RSP: 4,
        MsgType.INFO_RSP: INFO_BYTES,
        MsgType.MEASURE_REQ: 1,
        MsgType.STREAM_START_REQ: 3,
        MsgType.STREAM_START_RSP: 3,
        MsgType.ERROR_RSP: 3,
    }
    return sizes.get(t, 0)


MAX_PAYLOAD: Final = 512 - HEADER_BYTES
