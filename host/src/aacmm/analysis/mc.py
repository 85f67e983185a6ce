"""Monte Carlo error-transfer coefficients: the paper's Table 2, made reproducible.

An *error transfer coefficient* is an entry of the 3x25 Jacobian J = dp/dq of
the probe point p = (x, y, z) with respect to the structural parameters q
(theta_i, alpha_i, d_i, a_i, l): a small error dq_k moves the probe by
J[:, k] dq_k. The coefficients depend on the pose, so the paper averages them
over random poses; this module averages |J| (the paper's Table 2 is matched by
absolute values, all joints uniform in [-pi, pi)) with its standard error.

The Jacobians come from the firmware's C core (``aacmm._core``), accumulated
in a fused C loop; work is split into fixed chunks of :data:`CHUNK` poses,
each with its own random stream (:mod:`aacmm.analysis.mc_poses`), so a result
depends on the seed only, never on the number of threads.

Main entry points: :func:`error_transfer_coefficients` (fixed N),
:func:`error_transfer_coefficients_adaptive` (JCGM 101 section 7.9),
:func:`coefficients_over_poses` (logged poses). The poses are in
(:mod:`aacmm.analysis.mc_poses`: :class:`JointDistribution`,
:func:`draw_poses`), the results and reports in
(:mod:`aacmm.analysis.mc_report`: :class:`CoefficientResult`,
:func:`compare_with_paper`, :func:`format_report` (text), :func:`csv_text`,
:func:`to_json` and :func:`figure` (a matplotlib Figure)); the command
``aacmm mc`` (:mod:`aacmm.commands.mc`) writes them to files.

Any arm (issue 26): ``params`` may be an :class:`aacmm.arm.Arm`; the joint
distributions are then one per joint of it, the result has its P columns
(:attr:`CoefficientResult.param_names`) and the checks look at its length
columns (d, a, tip). ``model_name`` names the arm model in the result
(:attr:`CoefficientResult.model`): the paper's Table 2 is compared only for
the paper's arm (:attr:`CoefficientResult.is_paper`). The paper's arm is
computed as before, bit for bit.

Errors: ValueError for bad arguments (N <= 0, bad distributions, bad
tolerances, bad thread counts); :class:`aacmm.core.KinematicsError` (a
ValueError) if a pose is rejected by the core.
"""

from __future__ import annotations

import contextlib
import itertools
import math
import os
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from aacmm.analysis.mc_poses import (
    CHUNK,
    DrawnChunk,
    JointDistribution,
    draw_chunk,
    draw_deviates,
    joint_distributions,
    seed_entropy,
)
from aacmm.analysis.mc_report import (
    CoefficientResult,
)
from aacmm.arm import Arm
from aacmm.core import JAC_ROWS, FloatArray, Model, Params
from aacmm.uncertainty.parallel import in_order
from aacmm.uncertainty.parallel import pool as thread_pool

__all__ = [
    "CHECK_POSES",
    "DEFAULT_BLOCK",
    "DEFAULT_N",
    "MAX_THREADS",
    "Progress",
    "coefficients_over_poses",
    "error_transfer_coefficients",
    "error_transfer_coefficients_adaptive",
    "jcgm_tolerance",
]

#: Default number of poses (the paper's study).
DEFAULT_N = 10_000
#: JCGM 101 7.9: trials per adaptive run, M = max(100 / (1 - p), 10^4).
DEFAULT_BLOCK = 10_000
#: Poses on which the Eq. 11-13 norms and df_z/dtheta_1 = 0 are checked.
CHECK_POSES = 4096


#: Most worker threads accepted (each keeps two chunks of poses in flight).
MAX_THREADS = 256


def _threads(threads: int | None) -> int:
    if threads is None:
        return max(1, min(os.cpu_count() or 1, 64))
    if isinstance(threads, bool) or not isinstance(threads, int) or not 1 <= threads <= MAX_THREADS:
        raise ValueError(f"threads must be an integer in 1..{MAX_THREADS}, got {threads!r}")
    return threads


#: A progress callback: called with the number of poses just accumulated.
Progress = Callable[[int], None]


def _no_progress(n: int) -> None:
    pass


def _accumulate(
    model: Model,
    tasks: Iterable[Callable[[], DrawnChunk]],
    ex: ThreadPoolExecutor | None,
    progress: Progress,
    threads: int = 1,
) -> tuple[FloatArray, FloatArray, int]:
    """Run each task (it returns poses), sum |J| and J^2 in task order.

    Tasks are drawn from the iterable as they are needed (a bounded number in
    flight, :func:`aacmm.uncertainty.parallel.in_order`), so memory does not
    depend on their number.
    """

    def one(task: Callable[[], DrawnChunk]) -> tuple[FloatArray, FloatArray, int]:
        th, scale, offset = task()  # scaled in C: one pass over the poses less
        s, q = model.abs_jacobian_sums(th, scale, offset)
        return s, q, th.shape[0]

    s_tot = np.zeros((JAC_ROWS, model.n_params))
    q_tot = np.zeros((JAC_ROWS, model.n_params))
    n_tot = 0
    for s, q, n in in_order(ex, one, tasks, threads):  # in order: the sum ignores threads
        s_tot += s
        q_tot += q
        n_tot += n
        progress(n)
    return s_tot, q_tot, n_tot


def _chunk_tasks(
    entropy: int, run: int, n: int, joints: tuple[JointDistribution, ...]
) -> Iterator[Callable[[], DrawnChunk]]:
    """The chunks of a run of n poses, one task each, made as they are asked for."""

    def make(k: int) -> Callable[[], DrawnChunk]:
        m = min(CHUNK, n - k * CHUNK)
        return lambda: draw_deviates(entropy, run, k, m, joints)

    return (make(k) for k in range(-(-n // CHUNK)))


def _stats(s: FloatArray, q: FloatArray, n: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    mean = s / n
    if n > 1:
        var = np.maximum(q - s * mean, 0.0) / (n - 1)
    else:
        var = np.zeros_like(mean)
    std = np.sqrt(var)
    return mean, std, std / math.sqrt(n)


def _checks(model: Model, theta: FloatArray) -> tuple[float, float, int]:
    th = theta[:CHECK_POSES]
    if th.shape[0] == 0:
        return 0.0, 0.0, 0
    _, j = model.points_jacobians(th)
    lengths = [k for k, u in enumerate(model.arm.param_units) if u == "mm"]
    if isinstance(model.params, Params):
        lengths = list(range(12, 25))
    norms = np.linalg.norm(j[:, :, lengths], axis=1)
    return float(np.max(np.abs(norms - 1.0))), float(np.max(np.abs(j[:, 2, 0]))), th.shape[0]


def _positive_n(n: int, what: str = "number of poses N") -> int:
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n <= 0:
        raise ValueError(f"{what} must be a positive integer, got {n!r}")
    return int(n)


def _model(params: Params | Arm | None) -> Model:
    return Model(params or Params())


def _names(model: Model) -> tuple[str, ...]:
    return model.param_names


def error_transfer_coefficients(
    n: int = DEFAULT_N,
    joints: Sequence[JointDistribution] | None = None,
    seed: int | None = None,
    params: Params | Arm | None = None,
    threads: int | None = None,
    progress: Progress | None = None,
    model_name: str | None = None,
) -> CoefficientResult:
    """Mean |J| over ``n`` random poses (the paper's Monte Carlo study).

    ``joints``: one :class:`JointDistribution` per joint of the arm (default:
    all uniform in [-pi, pi)); ``seed``: non-negative integer (``None``: a
    fresh one, recorded in the result); ``params``: the arm (default: paper
    Table 1; any :class:`aacmm.arm.Arm`); ``threads``:
    worker threads (default: all cores; the result does not depend on it);
    ``progress``: called with the number of poses of each finished chunk;
    ``model_name``: the arm model's name, kept in the result (None: the paper's
    arm, or an unnamed one).
    Memory does not grow with n: chunks of :data:`CHUNK` poses are drawn as
    the threads need them.

    Raises ValueError for n <= 0 or any bad argument.
    """
    n = _positive_n(n)
    model = _model(params)
    js = joint_distributions(joints, model.joints)
    e = seed_entropy(seed)
    nt = _threads(threads)
    t0 = time.perf_counter()
    tasks = _chunk_tasks(e, 0, n, js)
    workers = min(nt, -(-n // CHUNK))
    with thread_pool(workers) as ex:  # no pool for a single chunk
        s, q, got = _accumulate(model, tasks, ex, progress or _no_progress, workers)
    elapsed = time.perf_counter() - t0
    mean, std, sem = _stats(s, q, got)
    dev, dz, checked = _checks(model, draw_chunk(e, 0, 0, min(n, CHECK_POSES, CHUNK), js))
    return CoefficientResult(
        got,
        mean,
        std,
        sem,
        "random",
        e,
        tuple(j.describe() for j in js),
        dev,
        dz,
        checked,
        elapsed,
        nt,
        param_names=_names(model),
        model=model_name,
    )


@contextlib.contextmanager
def _cancel_on_error(cancel: threading.Event) -> Iterator[None]:
    """Set ``cancel`` if the block raises (before the pool waits for its threads)."""
    try:
        yield
    except BaseException:
        cancel.set()
        raise


def jcgm_tolerance(values: FloatArray, ndig: int) -> FloatArray:
    """JCGM 101 7.9.2: delta = 1/2 10^l where |value| = c 10^l with c of ``ndig`` digits.

    Zero entries get delta = 0 (they must be exactly stable). Raises
    ValueError for ndig < 1.
    """
    if isinstance(ndig, bool) or not isinstance(ndig, int) or ndig < 1:
        raise ValueError(f"significant digits must be a positive integer, got {ndig!r}")
    a = np.abs(values)
    out = np.zeros_like(a)
    nz = a > 0
    out[nz] = 0.5 * 10.0 ** (np.floor(np.log10(a[nz])) - ndig + 1)
    return out


def error_transfer_coefficients_adaptive(
    ndig: int | None = 2,
    tolerance: float | None = None,
    block: int = DEFAULT_BLOCK,
    max_trials: int = 100_000_000,
    joints: Sequence[JointDistribution] | None = None,
    seed: int | None = None,
    params: Params | Arm | None = None,
    threads: int | None = None,
    progress: Progress | None = None,
    model_name: str | None = None,
) -> CoefficientResult:
    """Adaptive Monte Carlo, JCGM 101 (GUM Supplement 1) section 7.9.

    Runs of ``block`` poses (M = 10^4 by default, as 7.9.4 a) are drawn
    until, for every one of the 3 P mean |J| entries (75 for the paper's arm), twice the standard
    deviation of the average of the h run means is at most the numerical
    tolerance delta: an absolute ``tolerance`` (mm/rad or mm/mm, same for all
    entries) if given, else the 7.9.2 rule for ``ndig`` significant digits
    (:func:`jcgm_tolerance`). Entries whose average is 0 must have zero
    spread. Stops at ``max_trials`` with ``converged = False``.
    ``progress`` is called with the poses of each finished run.

    Raises ValueError for a bad tolerance, ndig, block or max_trials.
    """
    if tolerance is not None and (not math.isfinite(tolerance) or tolerance <= 0):
        raise ValueError(f"tolerance must be a positive number, got {tolerance!r}")
    if tolerance is None and ndig is None:
        raise ValueError("give a tolerance or a number of significant digits")
    if ndig is not None:
        jcgm_tolerance(np.ones(1), ndig)  # validates ndig
    block = _positive_n(block, "block size")
    max_trials = _positive_n(max_trials, "max_trials")
    model = _model(params)
    js = joint_distributions(joints, model.joints)
    e = seed_entropy(seed)
    nt = _threads(threads)
    t0 = time.perf_counter()
    runs = 0
    shape = (JAC_ROWS, model.n_params)
    ybar = np.zeros(shape)
    m2 = np.zeros(shape)
    s_tot = np.zeros(shape)
    q_tot = np.zeros(shape)
    n_tot = 0
    converged = False
    delta = np.zeros(shape)
    report = progress or _no_progress

    # Set when the loop below ends by an exception (Ctrl-C, a progress callback
    # refusing the run): the runs in flight stop within a chunk instead of
    # finishing their block (10^8 poses would take half a minute).
    cancel = threading.Event()

    def run_sums(h: int) -> tuple[FloatArray, FloatArray, int]:
        tasks = itertools.takewhile(lambda _: not cancel.is_set(), _chunk_tasks(e, h, block, js))
        return _accumulate(model, tasks, None, _no_progress)

    # Runs go to the threads `nt` at a time, each run whole on one thread, and
    # are examined in order: the stopping run, and so the result, is the same
    # as with one thread (runs computed past it are discarded).
    max_runs = max(1, max_trials // block)
    with thread_pool(min(nt, max_runs)) as ex, _cancel_on_error(cancel):
        h_next = 0
        while not converged and h_next < max_runs:
            batch = list(range(h_next, min(h_next + nt, max_runs)))
            h_next = batch[-1] + 1
            results = map(run_sums, batch) if ex is None else ex.map(run_sums, batch)
            for s, q, got in results:
                report(got)
                runs += 1
                y = s / got
                # Welford: mean and sum of squared deviations of the run means
                d = y - ybar
                ybar += d / runs
                m2 += d * (y - ybar)
                s_tot += s
                q_tot += q
                n_tot += got
                if runs < 2:
                    continue
                sy = np.sqrt(m2 / (runs - 1) / runs)
                if tolerance is not None:
                    delta = np.full_like(ybar, tolerance)
                else:
                    assert ndig is not None
                    delta = jcgm_tolerance(ybar, ndig)
                if bool(np.all(2.0 * sy <= delta)):
                    converged = True
                    break
    elapsed = time.perf_counter() - t0
    mean, std, sem = _stats(s_tot, q_tot, n_tot)
    dev, dz, checked = _checks(model, draw_chunk(e, 0, 0, min(block, CHECK_POSES, CHUNK), js))
    return CoefficientResult(
        n_tot,
        mean,
        std,
        sem,
        "random (adaptive, JCGM 101 7.9)",
        e,
        tuple(j.describe() for j in js),
        dev,
        dz,
        checked,
        elapsed,
        nt,
        runs=runs,
        converged=converged,
        tolerance=delta,
        param_names=_names(model),
        model=model_name,
    )


def coefficients_over_poses(
    theta_rad: FloatArray,
    params: Params | Arm | None = None,
    threads: int | None = None,
    source: str = "poses",
    progress: Progress | None = None,
    model_name: str | None = None,
) -> CoefficientResult:
    """Mean |J| over given poses (n, N) in rad, e.g. from a measurement log (N: the
    arm's joints, six for the paper's).

    Raises ValueError for an empty or mis-shaped array, KinematicsError for a
    pose the core rejects.
    """
    model = _model(params)
    joints = model.joints
    th = np.ascontiguousarray(theta_rad, dtype=np.float64)
    if th.ndim != 2 or th.shape[1] != joints:
        raise ValueError(f"poses must have shape (n, {joints}), got {th.shape}")
    n = th.shape[0]
    if n == 0:
        raise ValueError("no poses to analyse")
    nt = _threads(threads)
    t0 = time.perf_counter()

    def make(k: int) -> Callable[[], DrawnChunk]:
        return lambda: (th[k * CHUNK : (k + 1) * CHUNK], None, None)

    tasks = (make(k) for k in range(-(-n // CHUNK)))
    workers = min(nt, -(-n // CHUNK))
    with thread_pool(workers) as ex:
        s, q, got = _accumulate(model, tasks, ex, progress or _no_progress, workers)
    elapsed = time.perf_counter() - t0
    mean, std, sem = _stats(s, q, got)
    dev, dz, checked = _checks(model, th)
    return CoefficientResult(
        got,
        mean,
        std,
        sem,
        source,
        None,
        ("logged",) * joints,
        dev,
        dz,
        checked,
        elapsed,
        nt,
        param_names=_names(model),
        model=model_name,
    )
