"""Encoder angles in double: correctly rounded for every resolution (issue 14.11).

The reference is independent of the core: 2 pi to 400 bits from Machin's
formula in Python integers, the exact quotient |s| 2 pi / cpr as a fraction,
and Python's correctly rounded integer division to a double. Every reading
is compared bit for bit (the old core, with 2 pi to 64 bits, was wrong for
about one reading in 11 000, e.g. 3782405023 at 32 bits).
"""

from __future__ import annotations

import numpy as np
import pytest
from aacmm.core import EncoderConfig, counts_to_angles

pytestmark = pytest.mark.timeout(120)

BITS = 400


def _atan_inv(x: int, bits: int) -> int:
    """atan(1/x) * 2^bits, by its series (error a few units)."""
    one = 1 << bits
    total, term, n, sign, x2 = 0, one // x, 1, 1, x * x
    while term:
        total += sign * (term // n)
        term //= x2
        n += 2
        sign = -sign
    return total


# 2 pi * 2^BITS, within a few units (Machin: pi = 16 atan(1/5) - 4 atan(1/239))
TWO_PI = 2 * (16 * _atan_inv(5, BITS + 8) - 4 * _atan_inv(239, BITS + 8)) >> 8


def _signed(reading: int, cpr: int) -> int:
    delta = reading % cpr
    return delta if 2 * delta < cpr else delta - cpr


def reference(reading: int, cpr: int) -> float:
    """The correctly rounded double of s 2 pi / cpr (zero offset 0, direction +1).

    The quotient of the two integers is rounded correctly by CPython's int
    division; it differs from s 2 pi / cpr by less than 2^-390 relative, far
    below the distance (2^-53 relative at most) that could move it across a
    midpoint between two doubles except in cases of probability 2^-330.
    """
    s = _signed(reading, cpr)
    out = (abs(s) * TWO_PI) / (cpr << BITS)
    return -out if s < 0 else out


def _core(readings: list[int], cpr: int) -> np.ndarray:
    counts = np.zeros((len(readings), 6), dtype=np.uint64)
    counts[:, 0] = readings
    enc = EncoderConfig(counts_per_rev=(cpr,) * 6)
    return counts_to_angles(counts, enc)[:, 0]


def test_the_issue_reading() -> None:
    got = _core([3782405023], 1 << 32)[0]
    assert got == reference(3782405023, 1 << 32) == -0.7498366159219695


@pytest.mark.parametrize(
    ("cpr", "n"),
    [
        (1 << 32, 200_000),
        (1 << 26, 40_000),
        (3600, 3600),  # every reading
        ((1 << 32) - 1, 40_000),
        (1_000_003, 40_000),
        (2, 2),
    ],
)
def test_every_reading_correctly_rounded(cpr: int, n: int) -> None:
    rng = np.random.default_rng(cpr % 1_000_007)
    readings = list(range(cpr)) if n >= cpr else [int(r) for r in rng.integers(0, cpr, n)]
    got = _core(readings, cpr)
    bad = [(r, float(g)) for r, g in zip(readings, got, strict=True) if g != reference(r, cpr)]
    assert bad == [], f"{len(bad)} of {len(readings)} not correctly rounded, e.g. {bad[:3]}"
