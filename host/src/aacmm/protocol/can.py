"""aacmm on classic CAN: sample frames (via the DBC and ``cantools``) and ISO-TP set-up.

Identifiers are a base plus the node id (0..15). Plain samples go out as five
to seven 8-byte frames (by the arm model's joint count) described by
``aacmm/data/aacmm.dbc``; every other message is a
protocol message body carried by ISO-TP (``can-isotp``) on 0x600+n (host to
device) and 0x680+n (device to host).

``aacmm.dbc`` is the one source of the frame layout, written for node 0;
:func:`dbc_text` derives the DBC of any node from it (every identifier plus
the node id), which is what CAN tools need to decode a real bus: the package
ships them as ``aacmm/data/dbc/aacmm-node<N>.dbc`` and ``aacmm dbc --node N``
writes one.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any, Final

import cantools
import cantools.database
import isotp

from aacmm.errors import FrameError
from aacmm.protocol.payloads import Sample
from aacmm.protocol.status import Status

NODE_ID_MAX: Final = 15

ID_SAMPLE_HEADER: Final = 0x100
ID_COUNTS_12: Final = 0x110
ID_COUNTS_34: Final = 0x120
ID_COUNTS_56: Final = 0x130
ID_POINT_XY: Final = 0x140
ID_POINT_Z: Final = 0x150
ID_TRIGGER: Final = 0x160
ID_COUNTS_7: Final = 0x170
ID_ISOTP_REQUEST: Final = 0x600
ID_ISOTP_RESPONSE: Final = 0x680

SAMPLE_FRAME_IDS: Final = (
    ID_SAMPLE_HEADER,
    ID_COUNTS_12,
    ID_COUNTS_34,
    ID_COUNTS_56,
    ID_COUNTS_7,
    ID_POINT_XY,
    ID_POINT_Z,
)
"""Base ids of every sample frame, in transmit order (a sample of N joints sends
:func:`sample_frame_ids` of them)."""


def sample_frame_ids(joints: int) -> tuple[int, ...]:
    """Base ids of the frames of an N-joint sample (N = 4..7), in transmit order."""
    counts = (ID_COUNTS_12, ID_COUNTS_34, ID_COUNTS_56, ID_COUNTS_7)[: (joints + 1) // 2]
    return (ID_SAMPLE_HEADER, *counts, ID_POINT_XY, ID_POINT_Z)


_SEQUENCES: Final = {n: sample_frame_ids(n) for n in range(4, 8)}

ISOTP_PADDING: Final = 0xCC


def _check_node(node_id: int) -> None:
    if isinstance(node_id, bool) or not isinstance(node_id, int) or not 0 <= node_id <= 15:
        raise ValueError(f"node id {node_id!r} outside 0..{NODE_ID_MAX}")


def dbc_path() -> str:
    """File system path of the packaged DBC file (the source, node 0 identifiers)."""
    return str(resources.files("aacmm").joinpath("data/aacmm.dbc"))


def node_dbc_path(node_id: int) -> str:
    """File system path of the packaged DBC of CAN node ``node_id`` (0..15).

    Raises:
        ValueError: bad node id.
    """
    _check_node(node_id)
    return str(resources.files("aacmm").joinpath(f"data/dbc/aacmm-node{node_id}.dbc"))


# Lines of a DBC that name a frame id: messages, their comments (and their
# signals'), value tables, attributes, transmitters, multiplexing.
_ID_LINE = re.compile(
    r'^(BO_ |CM_ BO_ |CM_ SG_ |VAL_ |BO_TX_BU_ |SG_MUL_VAL_ |BA_ "[^"]*" (?:BO_|SG_) )(\d+)',
    re.MULTILINE,
)
_NODE0_NOTE: Final = "Identifiers are for CAN node 0; node n (0..15) adds n to every identifier."


@cache
def dbc_text(node_id: int = 0) -> str:
    """The DBC text for CAN node ``node_id``: ``aacmm.dbc`` with every frame id
    plus the node id (the database comment names the node).

    Raises:
        ValueError: bad node id.
    """
    _check_node(node_id)
    with open(dbc_path(), encoding="utf-8") as f:
        text = f.read()
    if _NODE0_NOTE not in text:
        raise ValueError("aacmm.dbc lost its node-0 note; update dbc_text")
    text = _ID_LINE.sub(lambda m: f"{m.group(1)}{int(m.group(2)) + node_id}", text)
    return text.replace(
        _NODE0_NOTE,
        f"Identifiers are for CAN node {node_id} (the node-0 identifiers plus {node_id}; "
        "'aacmm dbc --node N' writes the DBC of node N).",
    )


@cache
def load_dbc(node_id: int = 0) -> cantools.database.can.Database:
    """The DBC of CAN node ``node_id`` (default 0: the base identifiers) loaded
    with ``cantools`` (cached).

    Raises:
        ValueError: bad node id.
    """
    db = cantools.database.load_string(dbc_text(node_id), database_format="dbc")
    assert isinstance(db, cantools.database.can.Database)
    return db


def _decode_raw(frame_id: int, data: bytes) -> dict[str, int]:
    """Raw (unscaled) integer signal values of one frame of the DBC."""
    sig = load_dbc().decode_message(frame_id, data, scaling=False, decode_choices=False)
    if not isinstance(sig, dict):
        raise ValueError("unexpected container message")
    out: dict[str, int] = {}
    for k, v in sig.items():
        if not isinstance(v, int):
            raise ValueError(f"signal {k} is not an integer")
        out[k] = v
    return out


@dataclass(frozen=True)
class CanFrame:
    """One classic CAN frame: 11-bit id and 0..8 data bytes."""

    arbitration_id: int
    data: bytes


def encode_sample_frames(sample: Sample, node_id: int = 0) -> list[CanFrame]:
    """The frames of a sample (5 to 7 by its joint count), in transmit order
    (encoded with the DBC).

    Only the low 32 timestamp bits and low 16 status bits travel; the Jacobian
    does not.

    Raises:
        ValueError: bad node id, joint count or sample field out of range.
    """
    _check_node(node_id)
    db = load_dbc()
    s = sample
    n = len(s.counts)
    if n not in _SEQUENCES:
        raise ValueError(f"a sample has 4 to 7 counts, got {n}")
    c = (*s.counts, 0)
    values: list[dict[str, int]] = [
        {"Seq": s.seq, "TimestampUs": s.timestamp_us & 0xFFFFFFFF},
        {"Count1": c[0], "Count2": c[1]},
        {"Count3": c[2], "Count4": c[3]},
        {"Count5": c[4], "Count6": c[5]} if n >= 5 else {},
        {"Count7": c[6], "Reserved": 0} if n == 7 else {},
        {"X": s.point_100nm[0], "Y": s.point_100nm[1]},
        {"Z": s.point_100nm[2], "Status": s.status & 0xFFFF, "SeqTag": s.seq & 0xFF, "Joints": n},
    ]
    frames = []
    for base, sig in zip(SAMPLE_FRAME_IDS, values, strict=True):
        if not sig:
            continue
        try:
            data = db.encode_message(base, sig, scaling=False, strict=True)
        except (cantools.database.EncodeError, KeyError) as exc:
            raise ValueError(f"cannot encode sample frame 0x{base:03x}: {exc}") from None
        frames.append(CanFrame(base + node_id, bytes(data)))
    return frames


@dataclass(frozen=True)
class TriggerFrame:
    """A decoded trigger frame."""

    seq: int
    button: int
    pressed: bool


@dataclass
class AssemblerStats:
    """Counters of :class:`SampleAssembler`."""

    samples: int = 0
    incomplete: int = 0  # a sample missing frames or with a mismatched SeqTag
    bad_frames: int = 0  # wrong DLC or undecodable
    orphans: int = 0  # sample frames arriving with no sample in progress
    foreign: int = 0  # frames of other nodes or unrelated ids


class SampleAssembler:
    """Collects the sample frames of one node and returns complete samples.

    The frames of a sample must arrive in transmit order; a header restarts
    collection, and a sample with a missing frame, count frames that do not
    match the joint count of its PointZ frame, or a SeqTag that does not match
    the header's Seq is dropped and counted. Returned samples have
    ``timestamp_us`` = low 32 bits of the device clock, ``status`` = low 16 bits,
    N counts and no Jacobian; the frames do not carry P, so ``params`` is
    :attr:`params` when set (a client sets it from the device info) or 4N + 1.
    """

    def __init__(self, node_id: int = 0, params: int | None = None) -> None:
        _check_node(node_id)
        self.node_id = node_id
        self.params = params
        self.stats = AssemblerStats()
        self._parts: list[tuple[int, dict[str, int]]] = []

    def _decode(self, base: int, data: bytes) -> dict[str, int] | None:
        if len(data) != 8:
            self.stats.bad_frames += 1
            return None
        try:
            return _decode_raw(base, data)
        except Exception:  # cantools raises several types for bad data
            self.stats.bad_frames += 1
            return None

    def feed(self, arbitration_id: int, data: bytes) -> Sample | None:
        """Process one received frame; return a sample when one completes."""
        base = arbitration_id - self.node_id
        if base not in SAMPLE_FRAME_IDS:
            self.stats.foreign += 1
            return None
        sig = self._decode(base, bytes(data))
        if sig is None:
            return None
        if base == ID_SAMPLE_HEADER:
            if self._parts:
                self.stats.incomplete += 1
            self._parts = [(base, sig)]
            return None
        if not self._parts:
            self.stats.orphans += 1  # no sample in progress
            return None
        ids = (*(b for b, _ in self._parts), base)
        if not any(seq[: len(ids)] == ids for seq in _SEQUENCES.values()):
            self.stats.incomplete += 1  # the sample in progress lost a frame
            self._parts = []
            return None
        self._parts.append((base, sig))
        if base != ID_POINT_Z:
            return None
        p = dict(self._parts)
        self._parts = []
        n = p[ID_POINT_Z]["Joints"]
        if _SEQUENCES.get(n) != ids or p[ID_POINT_Z]["SeqTag"] != p[ID_SAMPLE_HEADER]["Seq"] & 0xFF:
            self.stats.incomplete += 1
            return None
        counts = (
            p[ID_COUNTS_12]["Count1"],
            p[ID_COUNTS_12]["Count2"],
            p[ID_COUNTS_34]["Count3"],
            p[ID_COUNTS_34]["Count4"],
            *((p[ID_COUNTS_56]["Count5"], p[ID_COUNTS_56]["Count6"]) if n >= 5 else ()),
            *((p[ID_COUNTS_7]["Count7"],) if n == 7 else ()),
        )[:n]
        self.stats.samples += 1
        return Sample(
            seq=p[ID_SAMPLE_HEADER]["Seq"],
            timestamp_us=p[ID_SAMPLE_HEADER]["TimestampUs"],
            counts=counts,
            point_100nm=(p[ID_POINT_XY]["X"], p[ID_POINT_XY]["Y"], p[ID_POINT_Z]["Z"]),
            status=p[ID_POINT_Z]["Status"],
            params=self.params if self.params is not None else 4 * n + 1,
        )


def decode_trigger_frame(data: bytes | bytearray) -> TriggerFrame:
    """Decode the 8 data bytes of a trigger frame.

    Raises:
        FrameError: not 8 bytes (ERR_LENGTH) or Pressed not 0/1 (ERR_RANGE).
    """
    if len(data) != 8:
        raise FrameError("trigger frame needs 8 bytes", int(Status.ERR_LENGTH))
    sig = _decode_raw(ID_TRIGGER, bytes(data))
    if sig["Pressed"] > 1:
        raise FrameError("trigger Pressed must be 0 or 1", int(Status.ERR_RANGE))
    return TriggerFrame(sig["Seq"], sig["Button"], bool(sig["Pressed"]))


def isotp_address(node_id: int = 0) -> isotp.Address:
    """ISO-TP normal 11-bit addressing of the host side for ``node_id``."""
    _check_node(node_id)
    return isotp.Address(
        isotp.AddressingMode.Normal_11bits,
        txid=ID_ISOTP_REQUEST + node_id,
        rxid=ID_ISOTP_RESPONSE + node_id,
    )


def isotp_params(timeout_ms: int = 1000) -> dict[str, Any]:
    """``can-isotp`` parameters matching the firmware endpoint.

    Classic CAN, 8-byte frames padded with 0xCC, no block-size limit or STmin
    asked of the device, ``timeout_ms`` for flow control and consecutive frames,
    messages up to 4095 bytes.
    """
    return {
        "stmin": 0,
        "blocksize": 0,
        "tx_padding": ISOTP_PADDING,
        "tx_data_length": 8,
        "can_fd": False,
        "rx_flowcontrol_timeout": timeout_ms,
        "rx_consecutive_frame_timeout": timeout_ms,
        "wftmax": 10,
        "max_frame_size": 4095,
    }


def make_isotp_stack(bus: Any, node_id: int = 0, timeout_ms: int = 1000) -> isotp.CanStack:
    """A threaded ``can-isotp`` stack on a ``python-can`` bus, talking to ``node_id``.

    Call ``start()`` before use and ``stop()`` after, as ``can-isotp`` documents.
    """
    return isotp.CanStack(bus, address=isotp_address(node_id), params=isotp_params(timeout_ms))
