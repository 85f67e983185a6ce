"""Benchmarks of the Monte Carlo analysis; one JSON object per line on stdout.

* analysis.abs_sums: the coefficient accumulation alone (fused C loop over
  point + Jacobian + |J| and J^2 sums, aacmm_simd_abs_jacobian_sums_f64) on
  pre-drawn poses, on the scalar kernel and on the widest one this CPU runs,
  1 thread and all threads, in 64 chunks on the analysis's own thread pool
  (aacmm.uncertainty.parallel: inline for one thread, a pool with the GIL
  released for more); ns per pose per thread = wall x threads / poses.
* analysis.mc: error_transfer_coefficients end to end (random poses drawn
  with numpy, accumulation, thread pool, the Eq. 11-13 check on 4096 poses),
  N = 10^6 and N = 10^4 (the paper's whole study).
* analysis.cli_mc_1e4, analysis.cli_mc_1e7: `aacmm mc -n 10000` and
  `aacmm mc -n 10000000` as a process on all cores, Python start-up included
  (wall and CPU time; issue 17's target: 10^7 under 1 s wall on 2 cores).
* analysis.uncertainty: Monte Carlo propagation, trials x poses per second,
  1 thread and all threads.
* machine: the CPU count, the load average at the start and the batch
  kernel (the figures are only comparable at a similar load).

Each figure is the best of several repeats. Wall-clock rates depend on what
else runs on the machine; the ``cpu`` figures (process CPU time, all threads)
give the cost per core independent of that load.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from aacmm import core
from aacmm import uncertainty as unc
from aacmm.analysis import mc
from aacmm.analysis.mc_poses import draw_poses
from aacmm.core import Model
from aacmm.uncertainty.parallel import in_order
from aacmm.uncertainty.parallel import pool as thread_pool
from benchjson import best_of, emit


def main() -> None:
    ncpu = os.cpu_count() or 1
    load1, load5, _ = os.getloadavg()
    emit(
        bench="machine",
        what="the conditions of this run (figures scale with the load on a shared machine)",
        cpus=ncpu,
        loadavg_1min=round(load1, 2),
        loadavg_5min=round(load5, 2),
        kernel=core.kernel(),
        kernels=list(core.available_kernels()),
    )
    model = Model()
    n = 1 << 20
    theta = draw_poses(n, seed=1)
    chunks = np.array_split(theta, 64)
    kernels = sorted({"scalar", core.available_kernels()[-1]}, key=core.KERNELS.index)
    for kern in kernels:
        core.set_kernel(kern)
        for threads in sorted({1, ncpu}):
            # the thread pool of the analysis itself: none for one thread
            with thread_pool(threads) as ex:

                def run(pool: ThreadPoolExecutor | None = ex, threads: int = threads) -> None:
                    list(in_order(pool, model.abs_jacobian_sums, chunks, threads))

                t, cpu, _ = best_of(run, 5)
            emit(
                bench="analysis.abs_sums",
                what="fused C |J| accumulation (point+Jacobian+sums)",
                kernel=kern,
                poses=n,
                threads=threads,
                ns_per_pose=round(t / n * 1e9, 2),
                ns_per_pose_per_thread=round(t * threads / n * 1e9, 2),
                target_ns_per_pose_per_thread=25.0,
                poses_per_s=round(n / t),
                cpu_ns_per_pose=round(cpu / n * 1e9, 2),
                poses_per_cpu_s=round(n / cpu),
            )
    core.set_kernel("auto")
    for n_mc, reps in ((1_000_000, 3), (10_000, 20)):
        for threads in sorted({1, ncpu}):
            acc = float("inf")

            def one(n_mc: int = n_mc, threads: int = threads) -> None:
                nonlocal acc
                r = mc.error_transfer_coefficients(n_mc, seed=1, threads=threads)
                acc = min(acc, r.elapsed_s)

            t, cpu, _ = best_of(one, reps)
            emit(
                bench="analysis.mc",
                what="error_transfer_coefficients incl. numpy RNG and checks",
                poses=n_mc,
                threads=threads,
                ms=round(t * 1e3, 3),
                poses_per_s=round(n_mc / t),
                accumulate_ms=round(acc * 1e3, 3),
                cpu_ms=round(cpu * 1e3, 3),
                poses_per_cpu_s=round(n_mc / cpu),
            )
    for n_cli, target in ((10_000, None), (10_000_000, 1.0)):
        best_wall = best_cpu = float("inf")
        for _ in range(3):
            r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            subprocess.run(
                [sys.executable, "-m", "aacmm.cli", "mc", "-n", str(n_cli), "--seed", "1"],
                check=True,
                stdout=subprocess.DEVNULL,
            )
            wall = time.perf_counter() - t0
            r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            best_wall = min(best_wall, wall)
            best_cpu = min(best_cpu, r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)
        extra = {} if target is None else {"target_wall_s": target}
        emit(
            bench=f"analysis.cli_mc_1e{len(str(n_cli)) - 1}",
            what=f"aacmm mc -n {n_cli}, Python start-up included",
            kernel=core.kernel(),
            threads=ncpu,
            wall_s=round(best_wall, 3),
            cpu_s=round(best_cpu, 3),
            **extra,
        )
    spec = unc.UncertaintySpec.from_u(
        {"theta": 1e-5, "alpha": 1e-5, "d": 0.005, "a": 0.005, "l": 0.005}
    )
    trials, poses = 100_000, 48
    for threads in sorted({1, ncpu}):

        def propagate(th: int = threads) -> object:
            return unc.propagate(spec, trials=trials, workspace=poses, seed=0, threads=th)

        t, cpu, _ = best_of(propagate, 2)
        emit(
            bench="analysis.uncertainty",
            what="MC + linear propagation incl. quantiles (exact)",
            kernel=core.kernel(),
            trials=trials,
            poses=poses,
            threads=threads,
            s=round(t, 3),
            cpu_s=round(cpu, 3),
            trial_poses_per_s=round(trials * poses / t),
            ns_per_trial_pose_cpu=round(cpu / (trials * poses) * 1e9, 2),
        )


if __name__ == "__main__":
    main()
