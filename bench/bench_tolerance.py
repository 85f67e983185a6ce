"""Benchmarks of the tolerance allocation; one JSON object per line on stdout.

* tolerance.allocate: ``aacmm tolerance example``'s allocation (100 poses,
  4^6 encoder combinations, worst pose, exact coverage radius), best of 3.
* tolerance.closed_form: an RMS target without encoders (one row, bisection).
* tolerance.check: the Monte Carlo check, arms x poses per second (10^5 arms
  x 20 poses through the C core, all threads).

Wall-clock figures depend on the machine's load; ``cpu_s`` (process CPU time,
all threads) does not.
"""

from __future__ import annotations

import json
import os
import time
import tomllib
from collections.abc import Callable
from dataclasses import replace
from importlib import resources

from aacmm.analysis import tolerance as tl


def best_of(fn: Callable[[], object], repeats: int = 3) -> tuple[float, float]:
    """Best wall time and best process CPU time of ``fn``."""
    best_wall = best_cpu = float("inf")
    for _ in range(repeats):
        c0, t0 = time.process_time(), time.perf_counter()
        fn()
        best_wall = min(best_wall, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    return best_wall, best_cpu


def emit(**kv: object) -> None:
    print(json.dumps(kv), flush=True)


def main() -> None:
    text = resources.files("aacmm").joinpath("data", "example_tolerance.toml").read_text("utf-8")
    spec = tl.parse_spec(tomllib.loads(text))
    a = tl.allocate(spec)
    wall, cpu = best_of(lambda: tl.allocate(spec))
    emit(
        bench="tolerance.allocate",
        rows=a.design.rows,
        combinations=a.combinations,
        solved=a.solved,
        iterations=a.iterations,
        wall_s=round(wall, 4),
        cpu_s=round(cpu, 4),
    )
    rms = replace(spec, encoders=(), target=replace(spec.target, over="rms", coverage_factor=2.0))
    wall, cpu = best_of(lambda: tl.allocate(rms), repeats=5)
    emit(
        bench="tolerance.closed_form",
        rows=a.design.rows,
        wall_s=round(wall, 4),
        cpu_s=round(cpu, 4),
    )
    trials, rows = 100_000, 20
    wall, cpu = best_of(lambda: tl.monte_carlo_check(a, trials=trials, rows=rows), repeats=2)
    emit(
        bench="tolerance.check",
        trials=trials,
        poses=rows,
        threads=os.cpu_count() or 1,
        wall_s=round(wall, 3),
        cpu_s=round(cpu, 3),
        arm_poses_per_s=round(trials * rows / wall),
        arm_poses_per_cpu_s=round(trials * rows / cpu),
    )


if __name__ == "__main__":
    main()
