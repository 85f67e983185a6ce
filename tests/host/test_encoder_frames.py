"""The firmware's encoder-frame decoder against frames built here, independently.

The frames are built in Python from the published layouts, not from the C code:

* BiSS-C (iC-Haus "BiSS C protocol description"; Renishaw RESOLUTE BiSS-C
  data sheet): idle high, Ack low (one or more clocks), Start 1, CDS, the
  position MSB first, nE and nW (active low), then the CRC-6 of position, nE
  and nW (polynomial x^6 + x + 1, "0x43"; Ack, Start and CDS not covered),
  sent MSB first and inverted; the line stays low afterwards (timeout).
* SSI: the idle 1 sampled at the latching edge, the position MSB first in
  binary or Gray code, then 0 (monoflop time).

The CRC here is the definition itself: the remainder of the polynomial long
division of the message (times x^6) by x^6 + x + 1, bit list by bit list.
A reference decoder written from the same layouts must agree with the C
decoder on every frame, including arbitrary ones (Hypothesis), and every
fault case of aacmm/encoder_frame.h is built on purpose. The simulated
encoders' frames (firmware/src/sim) are checked against the layouts too.
"""

from __future__ import annotations

import ctypes
import os
import random
import subprocess
from collections.abc import Sequence
from pathlib import Path

import pytest
from aacmm.protocol import EncoderFault, EncoderInterface
from hypothesis import given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[2]
LIB_DEFAULT = ROOT / "build" / "encoder" / "libaacmm_encoder.so"
CORPUS = ROOT / "tests" / "protocol" / "corpus"

MAX_BITS = 96
POLY = (1, 0, 0, 0, 0, 1, 1)  # x^6 + x + 1, highest power first

BISS = int(EncoderInterface.BISS_C)
SSI = int(EncoderInterface.SSI_BINARY)
SSI_GRAY = int(EncoderInterface.SSI_GRAY)
F = EncoderFault


class Frame(ctypes.Structure):
    _fields_ = [("line", ctypes.c_uint8 * (MAX_BITS // 8)), ("n_bits", ctypes.c_uint8)]


class JointConfig(ctypes.Structure):
    _fields_ = [("interface", ctypes.c_uint8), ("bits", ctypes.c_uint8)]


def _load() -> ctypes.CDLL:
    path = Path(os.environ.get("AACMM_ENC_LIB", LIB_DEFAULT))
    if "AACMM_ENC_LIB" not in os.environ:  # run outside make: build it first
        subprocess.run(["make", "-s", "--no-print-directory", "encoder-lib"], cwd=ROOT, check=True)
    lib = ctypes.CDLL(str(path))
    lib.aacmm_enc_decode.argtypes = [
        ctypes.POINTER(JointConfig),
        ctypes.POINTER(Frame),
        ctypes.POINTER(ctypes.c_uint32),
        ctypes.POINTER(ctypes.c_uint8),
    ]
    lib.aacmm_enc_decode.restype = ctypes.c_uint8
    lib.aacmm_enc_clocks.argtypes = [ctypes.POINTER(JointConfig)]
    lib.aacmm_enc_clocks.restype = ctypes.c_uint8
    lib.aacmm_biss_crc6.argtypes = [ctypes.c_uint64, ctypes.c_uint]
    lib.aacmm_biss_crc6.restype = ctypes.c_uint8
    lib.aacmm_sim_encoder_frame.argtypes = [
        ctypes.POINTER(JointConfig),
        ctypes.c_uint32,
        ctypes.c_uint8,
        ctypes.c_uint32,
        ctypes.POINTER(Frame),
    ]
    lib.aacmm_sim_encoder_frame.restype = None
    return lib


LIB = _load()


# ---------------------------------------------------------------- the layouts, in Python


def bits_msb_first(value: int, n: int) -> list[int]:
    return [(value >> (n - 1 - i)) & 1 for i in range(n)]


def crc6(message: Sequence[int]) -> list[int]:
    """Remainder of message(x) * x^6 divided by x^6 + x + 1 (long division)."""
    work = list(message) + [0] * 6
    for i in range(len(message)):
        if work[i]:
            for k, p in enumerate(POLY):
                work[i + k] ^= p
    return work[-6:]


def biss_frame(
    position: int,
    bits: int,
    *,
    ne: int = 1,
    nw: int = 1,
    lead: int = 1,
    ack: int = 2,
    cds: int = 0,
    clocks: int | None = None,
) -> list[int]:
    """The line levels a BiSS-C master samples, per the published layout."""
    covered = [*bits_msb_first(position, bits), ne, nw]
    crc = [b ^ 1 for b in crc6(covered)]  # transmitted inverted
    line = [1] * lead + [0] * ack + [1, cds] + covered + crc
    total = clocks if clocks is not None else bits + 18
    return (line + [0] * total)[:total]  # the timeout holds the line low


def gray(value: int) -> int:
    return value ^ (value >> 1)


def ssi_frame(position: int, bits: int, *, use_gray: bool = False) -> list[int]:
    value = gray(position) if use_gray else position
    return [1, *bits_msb_first(value, bits), 0]


def reference_decode(interface: int, bits: int, line: Sequence[int]) -> tuple[int, int, int]:
    """(fault, position, warning), written from the layouts and the documented check order."""
    n = min(len(line), MAX_BITS)
    line = line[:n]
    if n == 0:
        return F.TIMEOUT, 0, 0
    if all(line):
        return F.STUCK_HIGH, 0, 0
    if not any(line):
        return F.STUCK_LOW, 0, 0
    if interface == BISS:
        k = 0
        while k < n and line[k] == 1:
            k += 1
        while k < n and line[k] == 0:
            k += 1
        if k >= n:
            return F.TIMEOUT, 0, 0
        d = k + 2
        if d + bits + 8 > n:
            return F.TIMEOUT, 0, 0
        covered = list(line[d : d + bits + 2])
        received = list(line[d + bits + 2 : d + bits + 8])
        if [b ^ 1 for b in crc6(covered)] != received:
            return F.CRC, 0, 0
        if covered[-2] == 0:
            return F.ERROR_BIT, 0, 0
        pos = int("".join(map(str, covered[:bits])), 2)
        return F.NONE, pos, 1 - covered[-1]
    if n < bits + 2:
        return F.TIMEOUT, 0, 0
    if line[0] != 1 or line[bits + 1] != 0:
        return F.FRAMING, 0, 0
    raw = int("".join(map(str, line[1 : bits + 1])), 2)
    if interface == SSI_GRAY:
        value, shift = raw, raw >> 1
        while shift:
            value ^= shift
            shift >>= 1
        raw = value
    return F.NONE, raw, 0


# ---------------------------------------------------------------- calling the C decoder


def to_frame(line: Sequence[int], n_bits: int | None = None) -> Frame:
    f = Frame()
    for k, level in enumerate(line[:MAX_BITS]):
        if level:
            f.line[k // 8] |= 0x80 >> (k % 8)
    f.n_bits = len(line) if n_bits is None else n_bits
    return f


def c_decode(interface: int, bits: int, frame: Frame) -> tuple[int, int, int]:
    pos = ctypes.c_uint32(0xDEAD)
    warn = ctypes.c_uint8(7)
    fault = LIB.aacmm_enc_decode(
        ctypes.byref(JointConfig(interface, bits)),
        ctypes.byref(frame),
        ctypes.byref(pos),
        ctypes.byref(warn),
    )
    return fault, pos.value, warn.value


def decode(interface: int, bits: int, line: Sequence[int]) -> tuple[int, int, int]:
    return c_decode(interface, bits, to_frame(line))


def sim_frame(interface: int, bits: int, position: int, inject: int, variant: int) -> list[int]:
    f = Frame()
    LIB.aacmm_sim_encoder_frame(
        ctypes.byref(JointConfig(interface, bits)), position, inject, variant, ctypes.byref(f)
    )
    return [(f.line[k // 8] >> (7 - k % 8)) & 1 for k in range(f.n_bits)]


# ---------------------------------------------------------------- CRC


def test_crc6_is_the_polynomial_remainder() -> None:
    rng = random.Random(6)
    for _ in range(2000):
        n = rng.randint(1, 34)
        value = rng.getrandbits(n)
        message = bits_msb_first(value, n)
        crc = crc6(message)
        assert LIB.aacmm_biss_crc6(value, n) == int("".join(map(str, crc)), 2)
        # the codeword (message followed by its CRC) leaves no remainder
        assert _divides(message + crc)
    # x^6 mod (x^6 + x + 1) = x + 1, and the all-zero message has CRC 0
    assert crc6([1]) == [0, 0, 0, 0, 1, 1]
    assert crc6([0] * 34) == [0] * 6


def _divides(codeword: list[int]) -> bool:
    work = list(codeword)
    for i in range(len(work) - 6):
        if work[i]:
            for k, p in enumerate(POLY):
                work[i + k] ^= p
    return not any(work)


def test_crc6_detects_every_single_and_double_bit_error_of_a_frame() -> None:
    bits = 26
    line = biss_frame(0x2A5C3F1, bits, lead=1, ack=1)
    start = line.index(1, line.index(0))
    first, last = start + 2, start + 2 + bits + 2 + 6  # covered bits and CRC
    assert decode(BISS, bits, line) == (F.NONE, 0x2A5C3F1, 0)
    for i in range(first, last):
        bad = list(line)
        bad[i] ^= 1
        assert decode(BISS, bits, bad)[0] == F.CRC, i
    rng = random.Random(2)
    for _ in range(300):
        i, j = rng.sample(range(first, last), 2)
        bad = list(line)
        bad[i] ^= 1
        bad[j] ^= 1
        assert decode(BISS, bits, bad)[0] == F.CRC, (i, j)


# ---------------------------------------------------------------- BiSS-C


def test_biss_positions_all_widths_acks_and_cds() -> None:
    rng = random.Random(1)
    for bits in range(1, 33):
        top = (1 << bits) - 1
        for position in (0, top, rng.getrandbits(bits), rng.getrandbits(bits)):
            for lead, ack, cds in ((0, 1, 0), (1, 1, 1), (2, 3, 0), (3, 5, 1)):
                line = biss_frame(position, bits, lead=lead, ack=ack, cds=cds)
                assert decode(BISS, bits, line) == (F.NONE, position, 0), (bits, lead, ack)


def test_biss_status_bits() -> None:
    assert decode(BISS, 20, biss_frame(777, 20, nw=0)) == (F.NONE, 777, 1)  # warning: kept
    assert decode(BISS, 20, biss_frame(777, 20, ne=0)) == (F.ERROR_BIT, 0, 0)
    assert decode(BISS, 20, biss_frame(777, 20, ne=0, nw=0)) == (F.ERROR_BIT, 0, 0)


def test_biss_line_faults() -> None:
    assert decode(BISS, 32, [1] * 50) == (F.STUCK_HIGH, 0, 0)
    assert decode(BISS, 32, [0] * 50) == (F.STUCK_LOW, 0, 0)
    assert c_decode(BISS, 32, to_frame([], 0)) == (F.TIMEOUT, 0, 0)
    # the Ack never ends: no start bit within the capture
    assert decode(BISS, 32, [1, 1] + [0] * 48) == (F.TIMEOUT, 0, 0)
    # the capture ends inside the frame, at every length short of the end
    line = biss_frame(0x12345678, 32, lead=1, ack=2)
    end = 1 + 2 + 2 + 32 + 2 + 6
    for n in range(1, end):
        want = F.STUCK_HIGH if all(line[:n]) else F.TIMEOUT
        assert decode(BISS, 32, line[:n]) == (want, 0, 0), n
    assert decode(BISS, 32, line[:end]) == (F.NONE, 0x12345678, 0)


# ---------------------------------------------------------------- SSI


def test_ssi_binary_and_gray() -> None:
    rng = random.Random(3)
    for bits in range(1, 33):
        for position in (0, (1 << bits) - 1, rng.getrandbits(bits)):
            assert decode(SSI, bits, ssi_frame(position, bits)) == (F.NONE, position, 0)
            line = ssi_frame(position, bits, use_gray=True)
            assert decode(SSI_GRAY, bits, line) == (F.NONE, position, 0)
            # extra clocks after the monoflop bit are ignored
            assert decode(SSI, bits, [*ssi_frame(position, bits), 0, 1]) == (F.NONE, position, 0)


def test_ssi_faults() -> None:
    line = ssi_frame(0b1011001110, 10)
    assert decode(SSI, 10, [0, *line[1:]]) == (F.FRAMING, 0, 0)  # no idle 1
    assert decode(SSI, 10, [*line[:-1], 1]) == (F.FRAMING, 0, 0)  # not low after the LSB
    assert decode(SSI, 10, line[:-1]) == (F.TIMEOUT, 0, 0)
    assert decode(SSI, 10, [1] * 12) == (F.STUCK_HIGH, 0, 0)
    assert decode(SSI, 10, [0] * 12) == (F.STUCK_LOW, 0, 0)
    assert c_decode(SSI_GRAY, 10, to_frame([], 0)) == (F.TIMEOUT, 0, 0)
    # a position of all ones is not a stuck line: the monoflop bit is 0
    assert decode(SSI, 10, ssi_frame(1023, 10)) == (F.NONE, 1023, 0)


def test_bad_configurations_give_no_position() -> None:
    line = ssi_frame(5, 8)
    for interface, bits in ((SSI, 0), (SSI, 33), (int(EncoderInterface.COUNTS), 8), (9, 8)):
        assert decode(interface, bits, line) == (F.FRAMING, 0, 0)
        assert LIB.aacmm_enc_clocks(ctypes.byref(JointConfig(interface, bits))) == 0


# ---------------------------------------------------------------- the simulated encoders


def test_simulated_encoders_follow_the_layouts() -> None:
    """The C slave's line levels, clock by clock, equal the published layout."""
    rng = random.Random(4)
    for bits in (1, 13, 20, 26, 32):
        for _ in range(30):
            position = rng.getrandbits(bits)
            variant = rng.getrandbits(24)
            lead, ack = 1 + (variant & 1), 1 + ((variant >> 1) % 3)
            assert sim_frame(BISS, bits, position, 0, variant) == biss_frame(
                position, bits, lead=lead, ack=ack
            )
            assert sim_frame(SSI, bits, position, 0, variant) == ssi_frame(position, bits)
            assert sim_frame(SSI_GRAY, bits, position, 0, variant) == ssi_frame(
                position, bits, use_gray=True
            )
    # injected faults, as built here
    assert sim_frame(BISS, 16, 99, 2, 0) == biss_frame(99, 16, ne=0, lead=1, ack=1)
    assert sim_frame(BISS, 16, 99, 3, 0) == biss_frame(99, 16, nw=0, lead=1, ack=1)
    assert sim_frame(SSI, 16, 99, 9, 0) == [*ssi_frame(99, 16)[:-1], 1]


# ---------------------------------------------------------------- arbitrary frames


@settings(max_examples=3000, deadline=None)
@given(
    st.sampled_from([BISS, SSI, SSI_GRAY]),
    st.integers(1, 32),
    st.lists(st.integers(0, 1), max_size=MAX_BITS),
)
def test_c_decoder_equals_reference_on_arbitrary_frames(
    interface: int, bits: int, line: list[int]
) -> None:
    assert decode(interface, bits, line) == reference_decode(interface, bits, line)


@settings(max_examples=1500, deadline=None)
@given(st.integers(1, 32), st.data())
def test_mutated_biss_frames_agree_with_the_reference(bits: int, data: st.DataObject) -> None:
    """Up to three flipped samples anywhere (Ack and start included): the C
    decoder and the reference agree; one or two flips inside the covered
    bits and the CRC, with the frame in place, are always a CRC fault."""
    position = data.draw(st.integers(0, (1 << bits) - 1))
    lead = data.draw(st.integers(0, 3))
    line = biss_frame(position, bits, lead=lead, ack=2)
    first = lead + 2 + 2
    anywhere = data.draw(st.lists(st.integers(0, len(line) - 1), min_size=1, max_size=3))
    mutated = list(line)
    for i in anywhere:
        mutated[i] ^= 1
    assert decode(BISS, bits, mutated) == reference_decode(BISS, bits, mutated)
    in_place = data.draw(
        st.lists(st.integers(first, first + bits + 7), min_size=1, max_size=2, unique=True)
    )
    mutated = list(line)
    for i in in_place:
        mutated[i] ^= 1
    assert decode(BISS, bits, mutated) == (F.CRC, 0, 0)


# ---------------------------------------------------------------- fuzz seeds


def fuzz_seeds() -> dict[str, bytes]:
    """Seed inputs for mode 4 (encoder frames) of tests/protocol/fuzz_protocol.c:
    [4][interface][bits][n_bits][12 line bytes]."""
    seeds: dict[str, bytes] = {}
    cases = {
        "biss32": (BISS, 32, biss_frame(0xCAFEF00D, 32)),
        "biss26_warn": (BISS, 26, biss_frame(0x155AA55, 26, nw=0, lead=2, ack=3)),
        "biss13_err": (BISS, 13, biss_frame(4097, 13, ne=0)),
        "ssi20": (SSI, 20, ssi_frame(0xABCDE, 20)),
        "ssigray17": (SSI_GRAY, 17, ssi_frame(0x1F00F, 17, use_gray=True)),
        "stuck": (BISS, 8, [1] * 26),
    }
    for name, (interface, bits, line) in cases.items():
        f = to_frame(line)
        seeds[f"enc_{name}"] = bytes([4, interface, bits, f.n_bits]) + bytes(f.line)
    return seeds


def test_fuzz_seeds_are_committed() -> None:
    for name, data in fuzz_seeds().items():
        path = CORPUS / name
        if os.environ.get("AACMM_WRITE_SEEDS"):
            path.write_bytes(data)
        assert path.read_bytes() == data, f"stale fuzz seed {name} (AACMM_WRITE_SEEDS=1)"


def test_seeds_decode_as_named() -> None:
    for name, data in fuzz_seeds().items():
        interface, bits, n = data[1], data[2], data[3]
        f = Frame()
        for i, b in enumerate(data[4:]):
            f.line[i] = b
        f.n_bits = n
        fault = c_decode(interface, bits, f)[0]
        want = F.ERROR_BIT if "err" in name else F.STUCK_HIGH if "stuck" in name else F.NONE
        assert fault == want, name


if __name__ == "__main__":  # pragma: no cover
    pytest.main([__file__])
