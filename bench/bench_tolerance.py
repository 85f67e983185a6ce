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

import os
import tomllib
from dataclasses import replace
from importlib import resources

from aacmm.analysis import tolerance as tl
from benchjson import best_of, emit


def main() -> None:
    text = resources.files("aacmm").joinpath("data", "example_tolerance.toml").read_text("utf-8")
    spec = tl.parse_spec(tomllib.loads(text))
    a = tl.allocate(spec)
    wall, cpu, _ = best_of(lambda: tl.allocate(spec), 3)
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
    wall, cpu, _ = best_of(lambda: tl.allocate(rms), 5)
    emit(
        bench="tolerance.closed_form",
        rows=a.design.rows,
        wall_s=round(wall, 4),
        cpu_s=round(cpu, 4),
    )
    trials, rows = 100_000, 20
    wall, cpu, _ = best_of(lambda: tl.monte_carlo_check(a, trials=trials, rows=rows), 2)
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
