"""Monte Carlo error-transfer coefficients: the paper's Table 2, made reproducible.

An *error transfer coefficient* is an entry of the 3x25 Jacobian J = dp/dq of
the probe point p = (x, y, z) with respect to the structural parameters q
(theta_i, alpha_i, d_i, a_i, l): a small error dq_k moves the probe by
J[:, k] dq_k. The coefficients depend on the pose, so the paper averages them
over random poses; this module averages |J| (the paper's Table 2 is matched by
absolute values, all joints uniform in [-pi, pi)) with its standard error.

The Jacobians come from the firmware's C core (``aacmm._core``), accumulated
in a fused C loop; work is split into fixed chunks of :data:`CHUNK` poses,
each with its own random stream (``SeedSequence(seed, spawn_key=(run, chunk))``),
so a result depends on the seed only, never on the number of threads.

Main entry points: :func:`error_transfer_coefficients` (fixed N),
:func:`error_transfer_coefficients_adaptive` (JCGM 101 section 7.9),
:func:`coefficients_over_poses` (logged poses), :func:`compare_with_paper`,
and the reports :func:`format_report` (text), :func:`csv_text`,
:func:`to_json` and :func:`figure` (a matplotlib Figure); the command
``aacmm mc`` (:mod:`aacmm.commands.mc`) writes them to files.

Errors: ValueError for bad arguments (N <= 0, bad distributions, bad
tolerances, bad thread counts); :class:`aacmm.core.KinematicsError` (a
ValueError) if a pose is rejected by the core.
"""

from __future__ import annotations

import csv
import io
import math
import os
import textwrap
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from importlib import resources
from typing import Any, Literal

import numpy as np

from aacmm.analysis._parallel import in_order
from aacmm.analysis._parallel import pool as thread_pool
from aacmm.core import (
    AXES,
    JAC_COLS,
    JAC_ROWS,
    JOINT_ANGLE_MAX_RAD,
    JOINTS,
    PARAM_NAMES,
    PARAM_UNITS,
    FloatArray,
    Model,
    Params,
)

#: Poses per random stream and per C call: the unit of work of a thread.
CHUNK = 16384
#: Default number of poses (the paper's study).
DEFAULT_N = 10_000
#: JCGM 101 7.9: trials per adaptive run, M = max(100 / (1 - p), 10^4).
DEFAULT_BLOCK = 10_000
#: Poses on which the Eq. 11-13 norms and df_z/dtheta_1 = 0 are checked.
CHECK_POSES = 4096

#: Table 2 columns: (Jacobian row, Jacobian column offset, label).
TABLE2_COLUMNS: tuple[tuple[int, int, str], ...] = (
    (0, 6, "dfx/dalpha"),
    (1, 6, "dfy/dalpha"),
    (2, 6, "dfz/dalpha"),
    (0, 0, "dfx/dtheta"),
    (1, 0, "dfy/dtheta"),
    (2, 0, "dfz/dtheta"),
)


# --------------------------------------------------------------------------
# Pose distributions
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class JointDistribution:
    """Distribution of one joint angle (rad).

    ``kind`` "uniform": ``a`` = low, ``b`` = high, drawn in [low, high).
    ``kind`` "normal": ``a`` = mean, ``b`` = standard deviation.
    Raises ValueError for an unknown kind, non-finite values, low >= high,
    a negative deviation, or a range the core cannot take (|angle| > 1024 rad,
    for the normal case within 10 standard deviations).
    """

    kind: Literal["uniform", "normal"] = "uniform"
    a: float = -math.pi
    b: float = math.pi

    def __post_init__(self) -> None:
        if self.kind not in ("uniform", "normal"):
            raise ValueError(f"unknown joint distribution {self.kind!r} (uniform or normal)")
        if not (math.isfinite(self.a) and math.isfinite(self.b)):
            raise ValueError("joint distribution bounds must be finite")
        if self.kind == "uniform":
            if not self.a < self.b:
                raise ValueError(f"uniform joint range needs low < high, got [{self.a}, {self.b})")
            if max(abs(self.a), abs(self.b)) > JOINT_ANGLE_MAX_RAD:
                raise ValueError(f"joint range beyond +-{JOINT_ANGLE_MAX_RAD} rad")
        else:
            if self.b < 0:
                raise ValueError(f"normal joint standard deviation must be >= 0, got {self.b}")
            if abs(self.a) + 10.0 * self.b > JOINT_ANGLE_MAX_RAD:
                raise ValueError(
                    f"normal joint distribution reaches beyond +-{JOINT_ANGLE_MAX_RAD} rad"
                )

    @classmethod
    def uniform(cls, low: float, high: float) -> JointDistribution:
        """Uniform in [low, high) rad."""
        return cls("uniform", float(low), float(high))

    @classmethod
    def normal(cls, mean: float, sd: float) -> JointDistribution:
        """Normal with mean and standard deviation in rad."""
        return cls("normal", float(mean), float(sd))

    def describe(self) -> str:
        """Human-readable form in degrees."""
        if self.kind == "uniform":
            return f"uniform[{math.degrees(self.a):g}, {math.degrees(self.b):g}) deg"
        return f"normal({math.degrees(self.a):g}, {math.degrees(self.b):g}) deg"


DEFAULT_JOINTS: tuple[JointDistribution, ...] = (JointDistribution(),) * JOINTS


def _joints(joints: Sequence[JointDistribution] | None) -> tuple[JointDistribution, ...]:
    if joints is None:
        return DEFAULT_JOINTS
    out = tuple(joints)
    if len(out) != JOINTS or not all(isinstance(j, JointDistribution) for j in out):
        raise ValueError(f"need {JOINTS} JointDistribution values, got {len(out)}")
    return out


def _entropy(seed: int | None) -> int:
    if seed is None:
        e = np.random.SeedSequence().entropy
        assert isinstance(e, int)
        return e
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


#: A chunk of poses as drawn: (poses, None, None), or for all-uniform joints
#: (unit deviates, scale, offset) with poses = unit * scale + offset.
_Chunk = tuple[FloatArray, FloatArray | None, FloatArray | None]


def _draw(
    entropy: int, run: int, chunk: int, n: int, joints: Sequence[JointDistribution]
) -> _Chunk:
    rng = np.random.Generator(
        np.random.PCG64(np.random.SeedSequence(entropy, spawn_key=(run, chunk)))
    )
    if all(j.kind == "uniform" for j in joints):  # fast path: deviates, scaled later
        u = np.empty((n, JOINTS), dtype=np.float64)
        rng.random(out=u)
        return u, np.array([j.b - j.a for j in joints]), np.array([j.a for j in joints])
    out = np.empty((n, JOINTS), dtype=np.float64)
    uni = [i for i, j in enumerate(joints) if j.kind == "uniform"]
    nor = [i for i, j in enumerate(joints) if j.kind == "normal"]
    if uni:
        lo = np.array([joints[i].a for i in uni])
        w = np.array([joints[i].b - joints[i].a for i in uni])
        u = rng.random((n, len(uni)))
        u *= w
        u += lo
        out[:, uni] = u
    if nor:
        mu = np.array([joints[i].a for i in nor])
        sd = np.array([joints[i].b for i in nor])
        out[:, nor] = mu + sd * rng.standard_normal((n, len(nor)))
    return out, None, None


def draw_chunk(
    entropy: int, run: int, chunk: int, n: int, joints: Sequence[JointDistribution]
) -> FloatArray:
    """The poses (n, 6) of one chunk: a pure function of its arguments."""
    th, scale, offset = _draw(entropy, run, chunk, n, joints)
    if scale is not None and offset is not None:
        th *= scale
        th += offset
    return th


def draw_poses(
    n: int,
    joints: Sequence[JointDistribution] | None = None,
    seed: int = 0,
    run: int = 0,
) -> FloatArray:
    """The n poses (n, 6) that a Monte Carlo run with this seed uses (rad).

    Raises ValueError for n < 0 or a bad seed.
    """
    if n < 0:
        raise ValueError(f"number of poses must be >= 0, got {n}")
    js = _joints(joints)
    e = _entropy(seed)
    parts = [draw_chunk(e, run, k, min(CHUNK, n - k * CHUNK), js) for k in range(-(-n // CHUNK))]
    return np.concatenate(parts) if parts else np.empty((0, JOINTS))


# --------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class CoefficientResult:
    """Mean absolute error-transfer coefficients over a set of poses.

    Arrays are (3, 25): rows x, y, z; columns :data:`aacmm.core.PARAM_NAMES`.
    ``mean_abs`` is the mean of |J| (mm/rad for theta, alpha; mm/mm for d,
    a, l), ``std_abs`` its sample standard deviation over the poses and
    ``sem`` the standard error of the mean. ``unit_norm_max_dev`` is the
    largest | ||J[:, k]|| - 1 | over the d, a, l columns and
    ``dfz_dtheta1_max`` the largest |df_z/dtheta_1|, both over the first
    ``checked_poses`` poses. Adaptive runs fill ``runs``, ``converged`` and
    ``tolerance`` (the JCGM 101 numerical tolerance delta per entry).
    """

    n: int
    mean_abs: FloatArray
    std_abs: FloatArray
    sem: FloatArray
    source: str
    seed: int | None
    joints: tuple[str, ...]
    unit_norm_max_dev: float
    dfz_dtheta1_max: float
    checked_poses: int
    elapsed_s: float
    threads: int
    runs: int = 1
    converged: bool | None = None
    tolerance: FloatArray | None = field(default=None)

    def table2(self) -> FloatArray:
        """The (6, 6) Table 2 layout: rows joints 1..6, columns :data:`TABLE2_COLUMNS`."""
        return _table2(self.mean_abs)

    def table2_sem(self) -> FloatArray:
        """Standard errors in the Table 2 layout."""
        return _table2(self.sem)


def _table2(a: FloatArray) -> FloatArray:
    out = np.empty((JOINTS, len(TABLE2_COLUMNS)))
    for c, (row, off, _) in enumerate(TABLE2_COLUMNS):
        out[:, c] = a[row, off : off + JOINTS]
    return out


def paper_table2() -> FloatArray:
    """The paper's Table 2 (6, 6) in mm/rad, from the package's data copy."""
    text = resources.files("aacmm").joinpath("data", "paper_table2.csv").read_text("utf-8")
    rows = [
        r
        for r in csv.reader(line for line in text.splitlines() if line and not line.startswith("#"))
    ]
    header, body = rows[0], rows[1:]
    if [h for h, _ in zip(header[1:], TABLE2_COLUMNS, strict=True)] != [
        c[2].replace("/", "_") for c in TABLE2_COLUMNS
    ]:
        raise ValueError("paper_table2.csv: unexpected columns")  # pragma: no cover
    return np.array([[float(v) for v in r[1:]] for r in body], dtype=np.float64)


@dataclass(frozen=True)
class PaperComparison:
    """One Table 2 entry beside the paper's value.

    ``rel_dev`` is (ours - paper) / paper, or ``None`` where the paper's
    value is 0 (df_z/dtheta_1, compared as an absolute value instead).
    """

    joint: int
    column: str
    ours: float
    sem: float
    paper: float
    rel_dev: float | None


def compare_with_paper(result: CoefficientResult) -> list[PaperComparison]:
    """Every Table 2 entry of ``result`` beside the paper's value."""
    ours, sem, paper = result.table2(), result.table2_sem(), paper_table2()
    out = []
    for i in range(JOINTS):
        for c, (_, _, label) in enumerate(TABLE2_COLUMNS):
            p = float(paper[i, c])
            rel = None if p == 0.0 else (float(ours[i, c]) - p) / p
            out.append(PaperComparison(i + 1, label, float(ours[i, c]), float(sem[i, c]), p, rel))
    return out


def max_rel_deviation(result: CoefficientResult) -> tuple[float, PaperComparison]:
    """The largest |relative deviation| from the paper and its entry."""
    comps = [c for c in compare_with_paper(result) if c.rel_dev is not None]
    worst = max(comps, key=lambda c: abs(c.rel_dev or 0.0))
    return abs(worst.rel_dev or 0.0), worst


# --------------------------------------------------------------------------
# Accumulation
# --------------------------------------------------------------------------


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
    tasks: Iterable[Callable[[], _Chunk]],
    ex: ThreadPoolExecutor | None,
    progress: Progress,
    threads: int = 1,
) -> tuple[FloatArray, FloatArray, int]:
    """Run each task (it returns poses), sum |J| and J^2 in task order.

    Tasks are drawn from the iterable as they are needed (a bounded number in
    flight, :func:`aacmm.analysis._parallel.in_order`), so memory does not
    depend on their number.
    """

    def one(task: Callable[[], _Chunk]) -> tuple[FloatArray, FloatArray, int]:
        th, scale, offset = task()  # scaled in C: one pass over the poses less
        s, q = model.abs_jacobian_sums(th, scale, offset)
        return s, q, th.shape[0]

    s_tot = np.zeros((JAC_ROWS, JAC_COLS))
    q_tot = np.zeros((JAC_ROWS, JAC_COLS))
    n_tot = 0
    for s, q, n in in_order(ex, one, tasks, threads):  # in order: the sum ignores threads
        s_tot += s
        q_tot += q
        n_tot += n
        progress(n)
    return s_tot, q_tot, n_tot


def _chunk_tasks(
    entropy: int, run: int, n: int, joints: tuple[JointDistribution, ...]
) -> Iterator[Callable[[], _Chunk]]:
    """The chunks of a run of n poses, one task each, made as they are asked for."""

    def make(k: int) -> Callable[[], _Chunk]:
        m = min(CHUNK, n - k * CHUNK)
        return lambda: _draw(entropy, run, k, m, joints)

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
    norms = np.linalg.norm(j[:, :, 12:25], axis=1)
    return float(np.max(np.abs(norms - 1.0))), float(np.max(np.abs(j[:, 2, 0]))), th.shape[0]


def _positive_n(n: int, what: str = "number of poses N") -> int:
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n <= 0:
        raise ValueError(f"{what} must be a positive integer, got {n!r}")
    return int(n)


def error_transfer_coefficients(
    n: int = DEFAULT_N,
    joints: Sequence[JointDistribution] | None = None,
    seed: int | None = None,
    params: Params | None = None,
    threads: int | None = None,
    progress: Progress | None = None,
) -> CoefficientResult:
    """Mean |J| over ``n`` random poses (the paper's Monte Carlo study).

    ``joints``: six :class:`JointDistribution` (default: all uniform in
    [-pi, pi)); ``seed``: non-negative integer (``None``: a fresh one, recorded
    in the result); ``params``: the arm (default: paper Table 1); ``threads``:
    worker threads (default: all cores; the result does not depend on it);
    ``progress``: called with the number of poses of each finished chunk.
    Memory does not grow with n: chunks of :data:`CHUNK` poses are drawn as
    the threads need them.

    Raises ValueError for n <= 0 or any bad argument.
    """
    n = _positive_n(n)
    js = _joints(joints)
    e = _entropy(seed)
    nt = _threads(threads)
    model = Model(params or Params())
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
    )


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
    params: Params | None = None,
    threads: int | None = None,
    progress: Progress | None = None,
) -> CoefficientResult:
    """Adaptive Monte Carlo, JCGM 101 (GUM Supplement 1) section 7.9.

    Runs of ``block`` poses (M = 10^4 by default, as 7.9.4 a) are drawn
    until, for every one of the 75 mean |J| entries, twice the standard
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
    js = _joints(joints)
    e = _entropy(seed)
    nt = _threads(threads)
    model = Model(params or Params())
    t0 = time.perf_counter()
    runs = 0
    ybar = np.zeros((JAC_ROWS, JAC_COLS))
    m2 = np.zeros((JAC_ROWS, JAC_COLS))
    s_tot = np.zeros((JAC_ROWS, JAC_COLS))
    q_tot = np.zeros((JAC_ROWS, JAC_COLS))
    n_tot = 0
    converged = False
    delta = np.zeros((JAC_ROWS, JAC_COLS))
    report = progress or _no_progress

    def run_sums(h: int) -> tuple[FloatArray, FloatArray, int]:
        return _accumulate(model, _chunk_tasks(e, h, block, js), None, _no_progress)

    # Runs go to the threads `nt` at a time, each run whole on one thread, and
    # are examined in order: the stopping run, and so the result, is the same
    # as with one thread (runs computed past it are discarded).
    max_runs = max(1, max_trials // block)
    with thread_pool(min(nt, max_runs)) as ex:
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
    )


def coefficients_over_poses(
    theta_rad: FloatArray,
    params: Params | None = None,
    threads: int | None = None,
    source: str = "poses",
    progress: Progress | None = None,
) -> CoefficientResult:
    """Mean |J| over given poses (n, 6) in rad, e.g. from a measurement log.

    Raises ValueError for an empty or mis-shaped array, KinematicsError for a
    pose the core rejects.
    """
    th = np.ascontiguousarray(theta_rad, dtype=np.float64)
    if th.ndim != 2 or th.shape[1] != JOINTS:
        raise ValueError(f"poses must have shape (n, {JOINTS}), got {th.shape}")
    n = th.shape[0]
    if n == 0:
        raise ValueError("no poses to analyse")
    nt = _threads(threads)
    model = Model(params or Params())
    t0 = time.perf_counter()

    def make(k: int) -> Callable[[], _Chunk]:
        return lambda: (th[k * CHUNK : (k + 1) * CHUNK], None, None)

    tasks = (make(k) for k in range(-(-n // CHUNK)))
    workers = min(nt, -(-n // CHUNK))
    with thread_pool(workers) as ex:
        s, q, got = _accumulate(model, tasks, ex, progress or _no_progress, workers)
    elapsed = time.perf_counter() - t0
    mean, std, sem = _stats(s, q, got)
    dev, dz, checked = _checks(model, th)
    return CoefficientResult(
        got, mean, std, sem, source, None, ("logged",) * JOINTS, dev, dz, checked, elapsed, nt
    )


# --------------------------------------------------------------------------
# Reports
# --------------------------------------------------------------------------


def format_report(result: CoefficientResult) -> str:
    """The terminal report: Table 2 layout beside the paper, and the checks."""
    ours, sem, paper = result.table2(), result.table2_sem(), paper_table2()
    lines = [
        f"Mean |error transfer coefficient| (mm/rad) over {result.n} poses ({result.source})",
        f"joints: {', '.join(result.joints) if len(set(result.joints)) > 1 else result.joints[0]}"
        + (f"; seed {result.seed}" if result.seed is not None else ""),
    ]
    if result.converged is not None:
        lines.append(
            f"adaptive (JCGM 101 7.9): {result.runs} runs, {result.n} trials, "
            + ("converged" if result.converged else "NOT converged (max trials reached)")
        )
    head = f"{'i':>2}  {'':6}" + "".join(f"{c[2]:>12}" for c in TABLE2_COLUMNS)
    lines += ["", head, "-" * len(head)]
    for i in range(JOINTS):
        lines.append(f"{i + 1:>2}  {'mean':6}" + "".join(f"{v:12.2f}" for v in ours[i]))
        lines.append(f"{'':>2}  {'+-se':6}" + "".join(f"{v:12.2f}" for v in sem[i]))
        lines.append(f"{'':>2}  {'paper':6}" + "".join(f"{v:12.2f}" for v in paper[i]))
        devs = []
        for c in range(len(TABLE2_COLUMNS)):
            devs.append(
                f"{'(abs)':>12}"
                if paper[i, c] == 0.0
                else f"{100.0 * (ours[i, c] - paper[i, c]) / paper[i, c]:+11.2f}%"
            )
        lines.append(f"{'':>2}  {'dev':6}" + "".join(devs))
    worst, entry = max_rel_deviation(result)
    lines += [
        "",
        f"max |relative deviation| from the paper: {100.0 * worst:.2f} % "
        f"(joint {entry.joint}, {entry.column})",
        f"Eq. 11-13: | ||dp/dd_i||, ||dp/da_i||, ||dp/dl|| - 1 | <= "
        f"{result.unit_norm_max_dev:.1e} over {result.checked_poses} poses (norm 1)",
        f"df_z/dtheta_1 = 0: max |df_z/dtheta_1| = {result.dfz_dtheta1_max:g} over "
        f"{result.checked_poses} poses, mean |.| = {result.mean_abs[2, 0]:g} over all {result.n}",
        f"compute: {result.elapsed_s * 1e3:.1f} ms on {result.threads} thread(s), "
        f"{result.n / max(result.elapsed_s, 1e-9) / 1e6:.2f} Mposes/s",
    ]
    return "\n".join(lines)


def csv_text(result: CoefficientResult) -> str:
    """All 75 coefficients as CSV text, one row per (axis, parameter), with the paper's value."""
    paper = paper_table2()
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(["axis", "parameter", "unit", "mean_abs", "std", "sem", "paper", "rel_dev"])
    for r, axis in enumerate(AXES):
        for k, name in enumerate(PARAM_NAMES):
            pv: float | None = None
            if k < 12:
                col = (3 if k < 6 else 0) + r
                pv = float(paper[k % 6, col])
            rel = "" if pv is None or pv == 0.0 else f"{(result.mean_abs[r, k] - pv) / pv:.6g}"
            w.writerow(
                [
                    axis,
                    name,
                    f"mm/{PARAM_UNITS[k]}",
                    f"{result.mean_abs[r, k]:.10g}",
                    f"{result.std_abs[r, k]:.6g}",
                    f"{result.sem[r, k]:.6g}",
                    "" if pv is None else f"{pv:g}",
                    rel,
                ]
            )
    return buf.getvalue()


def to_json(result: CoefficientResult) -> dict[str, Any]:
    """A JSON-ready dict of the result (coefficients, Table 2, checks, metadata)."""
    comps = compare_with_paper(result)
    worst, _ = max_rel_deviation(result)
    coeffs = {
        name: {
            axis: {
                "mean_abs": float(result.mean_abs[r, k]),
                "std": float(result.std_abs[r, k]),
                "sem": float(result.sem[r, k]),
            }
            for r, axis in enumerate(AXES)
        }
        for k, name in enumerate(PARAM_NAMES)
    }
    out: dict[str, Any] = {
        "n": result.n,
        "source": result.source,
        "seed": result.seed,
        "joints": list(result.joints),
        "threads": result.threads,
        "elapsed_s": result.elapsed_s,
        "units": {"theta": "mm/rad", "alpha": "mm/rad", "d": "mm/mm", "a": "mm/mm", "l": "mm/mm"},
        "coefficients": coeffs,
        "table2": [
            {
                "joint": c.joint,
                "column": c.column,
                "ours": c.ours,
                "sem": c.sem,
                "paper": c.paper,
                "rel_dev": c.rel_dev,
            }
            for c in comps
        ],
        "max_abs_rel_dev": worst,
        "checks": {
            "unit_norm_max_dev": result.unit_norm_max_dev,
            "dfz_dtheta1_max_abs": result.dfz_dtheta1_max,
            "checked_poses": result.checked_poses,
        },
    }
    if result.converged is not None:
        out["adaptive"] = {
            "runs": result.runs,
            "trials": result.n,
            "converged": result.converged,
            "max_tolerance": float(np.max(result.tolerance))
            if result.tolerance is not None
            else None,
        }
    return out


def joints_title(joints: Sequence[str]) -> str:
    """The joint distribution in words, joints sharing one grouped:
    ``all joints uniform[-180, 180) deg`` or
    ``joint 2 normal(0, 10) deg; joints 1, 3-6 uniform[-180, 180) deg``."""
    groups: dict[str, list[int]] = {}
    for i, d in enumerate(joints, start=1):
        groups.setdefault(d, []).append(i)
    if len(groups) == 1:
        return f"all joints {joints[0]}"

    def span(ids: list[int]) -> str:
        runs: list[list[int]] = []
        for i in ids:
            if runs and i == runs[-1][-1] + 1:
                runs[-1].append(i)
            else:
                runs.append([i])
        return ", ".join(str(r[0]) if len(r) == 1 else f"{r[0]}-{r[-1]}" for r in runs)

    parts = sorted(groups.items(), key=lambda kv: len(kv[1]))
    return "; ".join(f"joint{'s' if len(ids) > 1 else ''} {span(ids)} {d}" for d, ids in parts)


def figure(result: CoefficientResult) -> Any:
    """A matplotlib Figure: the alpha and theta coefficients per joint and axis.

    Bars: mean |coefficient| of this run (q_i = alpha_i left, theta_i
    right), with error bars of +-1 standard error of the mean (thin black
    lines, no caps); the paper's Table 2 values as white diamonds with a
    black edge, so they cannot be mistaken for the error bars. The title
    names the poses and their distribution. Built without pyplot (no global
    state; safe from threads); save it with :func:`aacmm.fileio.save_figure`.
    """
    from matplotlib.artist import Artist
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    ours, sem, paper = result.table2(), result.table2_sem(), paper_table2()
    fig = Figure(figsize=(11, 5.0), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    x = np.arange(1, JOINTS + 1)
    width = 0.26
    colors = ("tab:blue", "tab:orange", "tab:green")
    for p, (ax, g) in enumerate(zip(axes, (r"\alpha", r"\theta"), strict=True)):
        for r in range(len(AXES)):
            c = 3 * p + r
            xs = x + (r - 1) * width
            ax.bar(xs, ours[:, c], width, color=colors[r])
            ax.errorbar(xs, ours[:, c], yerr=sem[:, c], fmt="none", ecolor="black", elinewidth=1)
            ax.plot(
                xs,
                paper[:, c],
                linestyle="none",
                marker="D",
                markersize=5,
                markerfacecolor="white",
                markeredgecolor="black",
            )
        ax.set_title(rf"Mean |error transfer coefficient| of ${g}_i$ (mm/rad)")
        ax.set_xlabel("joint $i$")
        ax.set_xticks(x)
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylabel("mm/rad")
    handles: list[Artist] = [
        Patch(color=colors[r], label=rf"$|\partial f_{a} / \partial q_i|$, this run")
        for r, a in enumerate(AXES)
    ]
    handles += [
        Line2D([], [], color="black", linewidth=1, label=r"error bar: $\pm 1$ standard error"),
        Line2D(
            [],
            [],
            linestyle="none",
            marker="D",
            markerfacecolor="white",
            markeredgecolor="black",
            label="paper, Table 2",
        ),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=5, fontsize=8, frameon=False)
    seed = f", seed {result.seed}" if result.seed is not None else ""
    title = f"{result.n} poses ({result.source}{seed}); {joints_title(result.joints)}"
    fig.suptitle("\n".join(textwrap.wrap(title, 150)), fontsize=9)
    return fig
