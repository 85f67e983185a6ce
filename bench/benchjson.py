"""What every ``make bench`` script shares: JSON lines out, best-of timing.

Each bench script prints one JSON object per line (``emit``); times are the
best of several runs (``best_of``), wall and process CPU (all threads), since
the machine is shared and the least disturbed run is the one to compare.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


def emit(**kv: object) -> None:
    """Print one benchmark record as a JSON line (flushed: benches are slow)."""
    print(json.dumps(kv), flush=True)


def best_of(fn: Callable[[], T], repeats: int, warm_up: bool = False) -> tuple[float, float, T]:
    """Best wall time, best process CPU time (s) and the last result of ``fn``.

    ``fn`` runs ``repeats`` times timed; with ``warm_up``, once untimed before
    (imports, caches, thread pools).

    Raises:
        ValueError: ``repeats`` < 1.
    """
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, not {repeats}")
    if warm_up:
        fn()
    best_wall = best_cpu = float("inf")
    for _ in range(repeats - 1):
        wall, cpu, _ = _timed(fn)
        best_wall, best_cpu = min(best_wall, wall), min(best_cpu, cpu)
    wall, cpu, out = _timed(fn)
    return min(best_wall, wall), min(best_cpu, cpu), out


def _timed(fn: Callable[[], T]) -> tuple[float, float, T]:
    c0, t0 = time.process_time(), time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, time.process_time() - c0, out
