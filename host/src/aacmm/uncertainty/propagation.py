"""Probe-point uncertainty by Monte Carlo (JCGM 101) and linear propagation
(GUM): :func:`propagate` and its helpers. The method, the memory rules and the
errors are described in the package's docstring (:mod:`aacmm.uncertainty`).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from aacmm.core import (
    FloatArray,
    Model,
    perturbed_points,
)
from aacmm.uncertainty.parallel import in_order
from aacmm.uncertainty.parallel import pool as parallel_pool
from aacmm.uncertainty.report import (
    BudgetEntry,
    PoseResult,
    UncertaintyResult,
)
from aacmm.uncertainty.runlimits import RunLimitError, available_memory
from aacmm.uncertainty.spec import (
    UncertaintySpec,
    group_names,
    param_group,
)

__all__ = [
    "BYTES_PER_POSE",
    "DEFAULT_TRIALS",
    "DEFAULT_WORKSPACE",
    "HIST_BINS",
    "K95",
    "MEMORY_BUDGET",
    "TRIAL_CHUNK",
    "MemoryLimitError",
    "Progress",
    "draw_deltas",
    "propagate",
]

#: 95 % coverage factor of a normal distribution.
K95 = 1.959963984540054
DEFAULT_TRIALS = 100_000
DEFAULT_WORKSPACE = 100
#: Trials per random stream and per task.
TRIAL_CHUNK = 8192
#: Bytes of deviations kept at once for exact statistics (and so the pose block).
MEMORY_BUDGET = 256 << 20
#: Histogram bins per pose and series once the trials exceed the budget.
HIST_BINS = 16384
#: Poses per block in the histogram passes.
_HIST_POSE_BLOCK = 16
#: Memory a pose takes in the result and the linear propagation (bytes, measured
#: order of magnitude: the PoseResult's arrays and objects, the Jacobian and its split).
BYTES_PER_POSE = 4096

T = TypeVar("T")

#: Progress callback: (trial-poses just done, total trial-poses of the run).
Progress = Callable[[int, int], None]


class MemoryLimitError(RunLimitError):
    """The request cannot fit in the memory available."""


def _delta(u: FloatArray, ndig: int) -> FloatArray:
    out = np.zeros_like(u)
    nz = u > 0
    out[nz] = 0.5 * 10.0 ** (np.floor(np.log10(u[nz])) - ndig + 1)
    return out


class _Sampler:
    """Draws chunks of parameter deviations (m, P) for a spec."""

    def __init__(self, spec: UncertaintySpec) -> None:
        self.spec = spec
        self.root: FloatArray | None = None
        if spec.covariance is not None:  # correlated normal: x = L z with L L^T = covariance
            lam, vec = np.linalg.eigh(spec.covariance)
            self.root = vec * np.sqrt(np.clip(lam, 0.0, None))

    def chunk(self, seed: int, c: int, m: int) -> FloatArray:
        """The deviations of chunk c (m trials): a pure function of its arguments."""
        rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(c,))))
        if self.root is not None:
            return np.asarray(rng.standard_normal((m, len(self.spec.items))) @ self.root.T)
        out = np.zeros((m, len(self.spec.items)))
        for k, item in enumerate(self.spec.items):
            if item.u > 0:
                out[:, k] = item.sample(rng, m)
        return out


def draw_deltas(spec: UncertaintySpec, trials: int, seed: int) -> FloatArray:
    """The parameter deviations (trials, P) that :func:`propagate` uses with ``seed``."""
    s = _Sampler(spec)
    parts = [
        s.chunk(seed, c, min(TRIAL_CHUNK, trials - c * TRIAL_CHUNK))
        for c in range(-(-trials // TRIAL_CHUNK))
    ]
    return np.concatenate(parts) if parts else np.empty((0, len(spec.items)))


@dataclass(frozen=True)
class _Run:
    """What the block statistics need of a run: the deviations of chunk c
    (``dev_of(c)`` -> (c, (m, k, 3))), the number of chunks, the threads, and
    the progress tick (trial-poses done)."""

    dev_of: Callable[[int], tuple[int, FloatArray]]
    chunks: int
    pool: ThreadPoolExecutor | None
    threads: int
    tick: Callable[[int], None]

    def map(self, fn: Callable[[int], T], items: Iterable[int]) -> Iterator[T]:
        """fn over the items in order, on the threads (aacmm.uncertainty.parallel)."""
        return in_order(self.pool, fn, items, self.threads)


class _Block:
    """Monte Carlo statistics of one block of poses: (k, 3) arrays and (k,) radii."""

    def __init__(self, k: int) -> None:
        self.u_mc = np.zeros((k, 3))
        self.bias = np.zeros((k, 3))
        self.q = np.zeros((2, k, 3))  # 2.5 % and 97.5 % quantiles
        self.r95 = np.zeros(k)


class _Moments:
    """Mean and sum of squared deviations (k, 3) merged chunk by chunk, in
    chunk order (Chan, Golub and LeVeque's pairwise update)."""

    def __init__(self, k: int) -> None:
        self.n = 0
        self.mean = np.zeros((k, 3))
        self.m2 = np.zeros((k, 3))

    @staticmethod
    def of(d: FloatArray) -> tuple[int, FloatArray, FloatArray]:
        mu = d.mean(axis=0)
        return d.shape[0], mu, ((d - mu) ** 2).sum(axis=0)

    def add(self, m: int, mu: FloatArray, sq: FloatArray) -> None:
        delta = mu - self.mean
        tot = self.n + m
        self.mean = self.mean + delta * (m / tot)
        self.m2 = self.m2 + sq + delta**2 * (self.n * m / tot)
        self.n = tot

    def std(self) -> FloatArray:
        out: FloatArray = np.sqrt(self.m2 / (self.n - 1))
        return out


def _series(d: FloatArray) -> FloatArray:
    """(m, k, 4): the three axis deviations and the distance to the nominal point."""
    out = np.empty((d.shape[0], d.shape[1], 4))
    out[:, :, :3] = d
    np.sqrt(np.einsum("mka,mka->mk", d, d), out=out[:, :, 3])
    return out


def _quantiles_in_place(a: FloatArray, qs: tuple[float, ...]) -> FloatArray:
    """Quantiles along the last axis, numpy's default (linear) definition, with
    one partition in place (no copy of ``a``): shape (len(qs), ...)."""
    n = a.shape[-1]
    ranks = [q * (n - 1) for q in qs]
    lows = [min(math.floor(r), n - 1) for r in ranks]
    kth = sorted({i for lo in lows for i in (lo, min(lo + 1, n - 1))})
    a.partition(kth, axis=-1)
    out = []
    for r, lo in zip(ranks, lows, strict=True):
        hi = min(lo + 1, n - 1)
        out.append(a[..., lo] + (r - lo) * (a[..., hi] - a[..., lo]))
    return np.stack(out)


def _exact_block(run: _Run, k: int, trials: int) -> _Block:
    """Statistics from every deviation of the block, kept at once: rows
    (k, 4, trials) of the three axes and the radius. Each chunk task writes
    its own columns; the quantiles are partitions in place, pose by pose on
    the threads."""
    rows = np.empty((k, 4, trials))
    mom = _Moments(k)

    def chunk(c: int) -> tuple[int, FloatArray, FloatArray]:
        _, d = run.dev_of(c)
        m = d.shape[0]
        cols = rows[:, :, c * TRIAL_CHUNK : c * TRIAL_CHUNK + m]
        cols[:, :3, :] = d.transpose(1, 2, 0)
        np.sqrt(np.einsum("mka,mka->km", d, d), out=cols[:, 3, :])
        return _Moments.of(d)

    for mo in run.map(chunk, range(run.chunks)):
        mom.add(*mo)
        run.tick(mo[0] * k)

    def quantiles(j: int) -> tuple[FloatArray, float]:
        q = _quantiles_in_place(rows[j, :3, :], (0.025, 0.975))
        return q, float(_quantiles_in_place(rows[j, 3, :], (0.95,))[0])

    out = _Block(k)
    out.u_mc = mom.std()
    out.bias = mom.mean
    for j, (q, r95) in enumerate(run.map(quantiles, range(k))):
        out.q[:, j, :] = q
        out.r95[j] = r95
    return out


def _hist_quantile(counts: Any, lo: FloatArray, hi: FloatArray, q: float, n: int) -> FloatArray:
    """The q quantile (numpy's default: rank q (n - 1)) from histograms (..., bins).

    The values of a bin are taken as evenly spread over it: the result is
    within one bin width of the exact order statistic.
    """
    cum = np.cumsum(counts, axis=-1)
    rank = q * (n - 1)
    k = np.argmax(cum > rank, axis=-1)  # first bin whose cumulative count passes the rank
    below = (
        np.take_along_axis(cum, k[..., None], axis=-1)[..., 0]
        - np.take_along_axis(counts, k[..., None], axis=-1)[..., 0]
    )
    inside = np.take_along_axis(counts, k[..., None], axis=-1)[..., 0]
    frac = (rank - below + 0.5) / np.maximum(inside, 1)
    width = (hi - lo) / counts.shape[-1]
    out: FloatArray = lo + (k + np.clip(frac, 0.0, 1.0)) * width
    return np.where(hi > lo, out, lo)


def _histogram_block(run: _Run, k: int, trials: int) -> _Block:
    """Statistics in two passes over the chunks, memory independent of the trials."""
    # pass 1: the moments and the extremes of the four series
    mom = _Moments(k)
    lo = np.full((k, 4), np.inf)
    hi = np.full((k, 4), -np.inf)

    def moments(c: int) -> tuple[tuple[int, FloatArray, FloatArray], FloatArray, FloatArray]:
        _, d = run.dev_of(c)
        s = _series(d)
        return _Moments.of(d), s.min(axis=0), s.max(axis=0)

    for mo, smin, smax in run.map(moments, range(run.chunks)):
        mom.add(*mo)
        lo = np.minimum(lo, smin)
        hi = np.maximum(hi, smax)
        run.tick(mo[0] * k)
    # pass 2: histograms of the four series between the extremes
    span = np.where(hi > lo, hi - lo, 1.0)
    offsets = np.arange(k * 4).reshape(k, 4) * HIST_BINS

    def histogram(c: int) -> Any:
        _, d = run.dev_of(c)
        b: Any = ((_series(d) - lo) / span * HIST_BINS).astype(np.int64)
        np.clip(b, 0, HIST_BINS - 1, out=b)
        b += offsets
        return d.shape[0], np.bincount(b.ravel(), minlength=k * 4 * HIST_BINS)

    flat = np.zeros(k * 4 * HIST_BINS, dtype=np.int64)
    for m, h in run.map(histogram, range(run.chunks)):
        flat += h
        run.tick(m * k)
    counts = flat.reshape(k, 4, HIST_BINS)
    out = _Block(k)
    out.u_mc = mom.std()
    out.bias = mom.mean
    for i, q in enumerate((0.025, 0.975)):
        out.q[i] = _hist_quantile(counts[:, :3], lo[:, :3], hi[:, :3], q, mom.n)
    out.r95 = _hist_quantile(counts[:, 3], lo[:, 3], hi[:, 3], 0.95, mom.n)
    return out


def _check(name: str, v: object, lo: int) -> None:
    if isinstance(v, bool) or not isinstance(v, int) or v < lo:
        raise ValueError(f"{name} must be an integer >= {lo}, got {v!r}")


def propagate(
    spec: UncertaintySpec,
    trials: int = DEFAULT_TRIALS,
    workspace: int = DEFAULT_WORKSPACE,
    seed: int = 0,
    ndig: int = 1,
    threads: int | None = None,
    workspace_seed: int | None = None,
    progress: Progress | None = None,
    memory_budget: int = MEMORY_BUDGET,
    joint_ranges_rad: Sequence[tuple[float, float]] | None = None,
) -> UncertaintyResult:
    """Propagate the parameter uncertainties to the probe point, both ways.

    At the spec's poses and at ``workspace`` random poses (all joints uniform
    in [-pi, pi), or joint i uniform in ``joint_ranges_rad[i]`` = [low, high)
    rad when given: an arm model's ``sampling_ranges_rad()``, poses within its
    joint limits; seeded by ``workspace_seed``, default ``seed + 1``), with
    ``trials`` Monte Carlo draws (the same draws for every pose). ``ndig``
    sets the JCGM 101 section 8 tolerance; ``threads`` (default: all cores)
    computes chunks of trials in parallel (the result does not depend on it);
    ``progress(done, total)`` is called as chunks finish (units: trials x
    poses, each pass counted); ``memory_budget`` bounds the deviations kept
    at once (see the module).

    Raises ValueError for trials < 2, workspace < 0, no pose at all, ndig < 1,
    a bad seed, threads < 1, or joint ranges not one finite [low < high) per
    joint; MemoryLimitError if the poses cannot fit in the available memory;
    KinematicsError if a drawn arm is invalid (an uncertainty far too large for
    the parameter limits).
    """
    for name, v, lo in (
        ("trials", trials, 2),
        ("workspace", workspace, 0),
        ("ndig", ndig, 1),
        ("seed", seed, 0),
        ("memory_budget", memory_budget, 1),
    ):
        _check(name, v, lo)
    nt = max(1, os.cpu_count() or 1) if threads is None else threads
    if isinstance(nt, bool) or not isinstance(nt, int) or not 1 <= nt <= 256:
        raise ValueError(f"threads must be an integer in 1..256, got {threads!r}")
    n = spec.poses_rad.shape[0] + workspace
    if n == 0:
        raise ValueError("no poses: give poses in the spec or a workspace size > 0")
    need, avail = n * BYTES_PER_POSE, available_memory()
    if need > avail // 2:
        raise MemoryLimitError(
            f"{n} poses need about {need / 2**30:.1f} GiB for their results, more than "
            f"half the {avail / 2**30:.1f} GiB available: analyse fewer poses"
        )
    ws_seed = seed + 1 if workspace_seed is None else workspace_seed
    ranges = _joint_ranges(joint_ranges_rad, spec.joints)
    if ranges is None:  # the paper's default: every joint in [-pi, pi), as before
        ws = np.random.default_rng(ws_seed).uniform(-math.pi, math.pi, (workspace, spec.joints))
    else:
        r = np.asarray(ranges)
        unit = np.random.default_rng(ws_seed).random((workspace, spec.joints))
        ws = r[:, 0] + (r[:, 1] - r[:, 0]) * unit
    poses = np.concatenate([spec.poses_rad, ws])
    t0 = time.perf_counter()
    u = spec.u_vector()
    model = Model(spec.params)
    p_nom, jac = model.points_jacobians(poses)
    # J Sigma J^T split by parameter: J_ak (Sigma J^T)_ka, which is J_ak^2 u_k^2 for
    # independent parameters and sums to the variance with correlations too
    split = jac * (jac @ spec.covariance_matrix())  # (n, 3, P)
    contrib_all = split.sum(axis=1)  # (n, P): sum over axes
    var_lin = split.sum(axis=2)  # (n, 3)
    sampler = _Sampler(spec)
    chunks = -(-trials // TRIAL_CHUNK)
    exact = trials * 32 <= memory_budget
    block = max(1, min(n, memory_budget // (trials * 32))) if exact else _HIST_POSE_BLOCK
    total = trials * n * (1 if exact else 2)

    def tick(m: int) -> None:
        if progress is not None:
            progress(m, total)

    results: list[PoseResult] = []
    with parallel_pool(min(nt, chunks)) as pool:
        for b in range(0, n, block):
            th = poses[b : b + block]
            nominal = p_nom[b : b + block]

            def dev_of(c: int, th: FloatArray = th, nominal: FloatArray = nominal) -> Any:
                m = min(TRIAL_CHUNK, trials - c * TRIAL_CHUNK)
                d = perturbed_points(spec.params, sampler.chunk(seed, c, m), th)
                d -= nominal[None, :, :]
                return c, d

            block_stats = _exact_block if exact else _histogram_block
            run = _Run(dev_of, chunks, pool, min(nt, chunks), tick)
            st = block_stats(run, th.shape[0], trials)
            for j in range(th.shape[0]):
                i = b + j
                ul = np.sqrt(var_lin[i])
                ci_l = np.stack([-K95 * ul, K95 * ul], axis=1)
                ci_m = st.q[:, j, :].T.copy()
                delta = _delta(ul, ndig)
                ok = bool(np.all(np.abs(ci_l - ci_m) <= delta[:, None]))
                results.append(
                    PoseResult(
                        poses[i].copy(),
                        p_nom[i].copy(),
                        ul,
                        st.u_mc[j].copy(),
                        st.bias[j].copy(),
                        ci_l,
                        ci_m,
                        float(np.sqrt(var_lin[i].sum())),
                        float(np.sqrt((st.u_mc[j] ** 2).sum())),
                        float(st.r95[j]),
                        contrib_all[i].copy(),
                        delta,
                        ok,
                    )
                )
    mean_contrib = contrib_all.mean(axis=0)
    total_var = float(mean_contrib.sum())
    sens = np.sqrt((jac**2).sum(axis=1).mean(axis=0))  # RMS column norm (P,)
    names, units = spec.param_names, spec.param_units
    budget = sorted(
        (
            BudgetEntry(
                name,
                units[k],
                float(u[k]),
                float(sens[k]),
                float(math.copysign(math.sqrt(abs(mean_contrib[k])), mean_contrib[k])),
                float(mean_contrib[k] / total_var) if total_var > 0 else 0.0,
            )
            for k, name in enumerate(names)
        ),
        key=lambda e: -e.share,
    )
    groups = {g: 0.0 for g in group_names(names)}
    for e in budget:
        groups[param_group(e.name)] += e.share
    return UncertaintyResult(
        spec,
        trials,
        seed,
        ndig,
        tuple(results),
        spec.poses_rad.shape[0],
        tuple(budget),
        groups,
        time.perf_counter() - t0,
        quantiles="exact" if exact else f"histogram ({HIST_BINS} bins between the extremes)",
        threads=nt,
        workspace_ranges_rad=ranges,
    )


def _joint_ranges(
    ranges: Sequence[tuple[float, float]] | None, joints: int
) -> tuple[tuple[float, float], ...] | None:
    """The workspace's joint ranges checked: N finite pairs low < high (None: none)."""
    if ranges is None:
        return None
    out = tuple((float(lo), float(hi)) for lo, hi in ranges)
    if len(out) != joints or not all(
        math.isfinite(lo) and math.isfinite(hi) and lo < hi for lo, hi in out
    ):
        raise ValueError(f"joint ranges need {joints} finite pairs [low, high) with low < high")
    return out
