"""Counters of one ``aacmm log`` run: samples, losses, gaps, extent, link temperatures,
rate while connected."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from aacmm.records.files import fmt_point


@dataclass
class Extent:
    """Bounding box of the valid points, in 1e-4 mm."""

    lo: list[int] = field(default_factory=lambda: [0, 0, 0])
    hi: list[int] = field(default_factory=lambda: [0, 0, 0])
    n: int = 0

    def add(self, p: tuple[int, ...]) -> None:
        if self.n == 0:
            self.lo, self.hi = list(p), list(p)
        else:
            for i in range(3):
                v = p[i]
                if v < self.lo[i]:
                    self.lo[i] = v
                elif v > self.hi[i]:
                    self.hi[i] = v
        self.n += 1

    def as_dict(self) -> dict[str, Any] | None:
        if self.n == 0:
            return None
        return {
            axis: {
                "min": float(fmt_point(self.lo[i])),
                "max": float(fmt_point(self.hi[i])),
                "size": float(fmt_point(self.hi[i] - self.lo[i])),
            }
            for i, axis in enumerate("xyz")
        }


@dataclass
class TempRange:
    """Range of the link temperatures the samples carry, in wire units (0.01 degC);
    :meth:`as_dict` has the shape of :func:`aacmm.records.logs.temperature_summary`."""

    lo: list[int | None] = field(default_factory=list)
    hi: list[int | None] = field(default_factory=list)
    rows_read: int = 0

    def add(self, temp: tuple[int, ...] | None, none: int) -> None:
        """One sample's temperatures (None: it carries none; ``none``: no reading)."""
        if temp is None:
            return
        if not self.lo:
            self.lo, self.hi = [None] * len(temp), [None] * len(temp)
        for j, t in enumerate(temp[: len(self.lo)]):
            if t == none:
                continue
            lo, hi = self.lo[j], self.hi[j]
            self.lo[j] = t if lo is None or t < lo else lo
            self.hi[j] = t if hi is None or t > hi else hi
        self.rows_read += all(t != none for t in temp)

    def as_dict(self) -> dict[str, Any] | None:
        read = [j for j, v in enumerate(self.lo) if v is not None]
        if not read:
            return None
        lo = [v for v in self.lo if v is not None]
        hi = [v for v in self.hi if v is not None]
        return {
            "min": min(lo) / 100.0,
            "max": max(hi) / 100.0,
            "rows_read": self.rows_read,
            "links": [
                None if a is None or b is None else {"min": a / 100.0, "max": b / 100.0}
                for a, b in zip(self.lo, self.hi, strict=True)
            ],
        }


@dataclass
class Session:
    """Counters of one log run (over all reconnects)."""

    samples: int = 0
    lost: int = 0
    duplicates: int = 0
    overruns: int = 0
    dropped: int = 0
    triggers: int = 0
    presses: int = 0  # trigger rows that are presses (a press and its release: 2 rows)
    reconnects: int = 0
    first_host: float | None = None
    last_host: float | None = None
    last_seq: int | None = None
    extent: Extent = field(default_factory=Extent)
    temps: TempRange = field(default_factory=TempRange)
    gaps: list[dict[str, Any]] = field(default_factory=list)
    # time connected (sum over the stretches between reconnect gaps) and the
    # sample intervals in it: the rate while connected
    seg_first: float | None = None
    seg_rows: int = 0
    connected_s: float = 0.0
    intervals: int = 0

    def end_segment(self) -> None:
        """Close the current connected stretch (at a gap and at the end)."""
        if self.seg_first is not None and self.last_host is not None:
            self.connected_s += self.last_host - self.seg_first
            self.intervals += self.seg_rows - 1
        self.seg_first, self.seg_rows = None, 0

    def rate_hz(self) -> float | None:
        """Samples per second while connected (gaps excluded)."""
        open_s = 0.0
        open_iv = 0
        if self.seg_first is not None and self.last_host is not None:
            open_s, open_iv = self.last_host - self.seg_first, self.seg_rows - 1
        t = self.connected_s + open_s
        return (self.intervals + open_iv) / t if t > 0 else None
