"""Monte Carlo check of an allocation: build many arms, measure, count.

Each trial is one arm: every parameter error drawn within its allocated (or
fixed) tolerance from its distribution, passed through the calibration map
for a calibrated arm (plus a draw of the calibration's own error), every
joint read by its chosen encoder (accuracy error within +-accuracy, and
quantisation within half a count, drawn afresh for every reading), every
probed point with the residual model error (normal, isotropic). The probe
points come from the firmware's C core with the perturbed parameters
(``aacmm.core.perturbed_points``), not from the linear model the allocation
used, so the check also covers the linearisation.

At each checked row (pose, or pair of poses for a length) it reports the
fraction of arms whose error is within the limit (standard error
sqrt(f (1 - f) / N)) and the Monte Carlo value of the target quantity: the
``coverage`` quantile of the error (its standard error from the order
statistics around it). For ``over = "worst"`` the target holds when the
smallest fraction is at least the coverage; for ``"rms"`` when the RMS over
rows of quantile/limit is at most 1 (standard error from 10 batches). A
design that sits exactly on its target (normal errors) scatters about it, so
the verdict has three values: ``met``; ``within noise`` (short of it by at
most two standard errors); ``not met``.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from aacmm.analysis.tolerance.allocation import Allocation
from aacmm.analysis.tolerance.request import ToleranceSpec
from aacmm.core import JAC_COLS, FloatArray, perturbed_points
from aacmm.uncertainty.runlimits import check_memory, format_count
from aacmm.uncertainty.spec import ParamUncertainty

DEFAULT_TRIALS = 100_000
_BLOCK_VALUES = 2_000_000  # trials x rows per block at most
_BATCHES = 10


@dataclass(frozen=True)
class CheckResult:
    """Result of :func:`monte_carlo_check` (lengths in mm).

    ``rows``: the checked rows (indices into the allocation's rows);
    ``within``/``within_se``: fraction of arms within the limit per row and
    its standard error; ``u_mc``/``u_mc_se``: the coverage quantile of the
    error per row and its standard error; ``ratio``/``ratio_se``: max
    (worst) or RMS (rms) of u_mc/limit; ``worst_within``/``worst_within_se``:
    the smallest fraction and its standard error; ``met``: the target holds
    (estimate); ``verdict``: ``met``, ``within noise`` or ``not met``.
    """

    trials: int
    seed: int
    coverage: float
    over: str
    rows: np.ndarray
    limit_mm: FloatArray
    within: FloatArray
    within_se: FloatArray
    u_mc: FloatArray
    u_mc_se: FloatArray
    ratio: float
    ratio_se: float
    worst_within: float
    worst_within_se: float
    worst_row: int
    met: bool
    verdict: str
    elapsed_s: float


def _draw(alloc: Allocation, trials: int, rng: np.random.Generator) -> FloatArray:
    """Parameter errors (trials, P) of the arms after calibration (if any)."""
    dq = np.zeros((trials, len(alloc.params)))
    for i, p in enumerate(alloc.params):
        if p.status == "calibrated" or not math.isfinite(p.tolerance) or p.u == 0.0:
            continue  # removed by calibration, or not seen by the target
        dq[:, i] = ParamUncertainty(p.name, p.u, p.distribution).sample(rng, trials)
    cal = alloc.design.calibration
    if cal is not None:
        dq = dq @ alloc.design.error_map.T
        w, vec = np.linalg.eigh(cal.covariance)
        root = vec * np.sqrt(np.clip(w, 0.0, None))
        dq += rng.standard_normal((trials, len(alloc.params))) @ root.T
    return dq


def _readings(alloc: Allocation, trials: int, rng: np.random.Generator) -> FloatArray:
    """Encoder reading errors (trials, P) in rad on the theta columns (the first N):
    accuracy plus quantisation."""
    out = np.zeros((trials, len(alloc.params)))
    for r in alloc.encoders:
        enc = r.encoder
        acc = ParamUncertainty(
            "theta1", enc.accuracy_arcsec * _factor(enc.distribution), enc.distribution
        ).sample(rng, trials)
        half = 0.5 * enc.resolution_arcsec
        out[:, r.joint - 1] = (acc + rng.uniform(-half, half, trials)) * math.pi / 648000.0
    return out


def _factor(dist: str) -> float:
    from aacmm.uncertainty.spec import TOLERANCE_FACTOR

    return TOLERANCE_FACTOR[dist]


def _quantile_se(x: FloatArray, p: float) -> tuple[FloatArray, FloatArray]:
    """The p-quantile along axis 0 and its standard error (order statistics
    one binomial standard deviation either side)."""
    n = x.shape[0]
    sd = math.sqrt(n * p * (1.0 - p))
    lo = max(0, math.floor(n * p - sd))
    hi = min(n - 1, math.ceil(n * p + sd))
    q = np.quantile(x, p, axis=0)
    part = np.partition(x, (lo, hi), axis=0)
    return q, 0.5 * (part[hi] - part[lo])


def check_memory_bytes(trials: int, rows: int, params: int = JAC_COLS) -> int:
    """Memory the check of ``trials`` arms at ``rows`` rows plans (bytes, an upper
    bound): the parameter errors and both readings (trials x P each, P = ``params``,
    25 for the paper's arm, and their sum), the errors (trials x rows) and their
    sorted copy, the points of a block."""
    return 8 * trials * (4 * params + 2 * rows) + 8 * 3 * 4 * _BLOCK_VALUES


#: Arms of the pilot check that times a long one (:func:`estimate_check_seconds`).
PILOT_TRIALS = 2000


def check_rows(spec: ToleranceSpec, rows: int | None = None) -> int:
    """Rows the check of ``spec`` evaluates (``rows``: at most that many), known
    without the allocation: the workspace poses, or its pairs for a length."""
    from aacmm.analysis.tolerance.design import build_design

    n = int(build_design(spec).limit_mm.size)
    return n if rows is None else min(n, rows)


def check_memory_limit(spec: ToleranceSpec, trials: int, rows: int | None = None) -> None:
    """Refuse at once a check that would need more than half the memory available.

    Raises:
        RunLimitError: with the estimate (a ValueError).
    """
    k = check_rows(spec, rows)
    check_memory(
        check_memory_bytes(trials, k, len(spec.costs)),
        f"the Monte Carlo check of {format_count(trials)} arms at {k} rows",
        "use fewer --trials or --check-rows",
    )


def estimate_check_seconds(
    alloc: Allocation, trials: int, rows: int | None = None, threads: int | None = None
) -> float:
    """Seconds the check of ``trials`` arms takes on this machine now: a check of
    :data:`PILOT_TRIALS` arms, timed and scaled (the time is linear in the arms)."""
    if trials <= PILOT_TRIALS:
        return 0.0
    t0 = time.perf_counter()
    monte_carlo_check(alloc, PILOT_TRIALS, seed=0, rows=rows, threads=threads)
    return (time.perf_counter() - t0) * trials / PILOT_TRIALS


def monte_carlo_check(
    alloc: Allocation,
    trials: int = DEFAULT_TRIALS,
    seed: int = 0,
    rows: int | None = None,
    threads: int | None = None,
    progress: Callable[[float], None] | None = None,
) -> CheckResult:
    """Draw ``trials`` arms within the allocation and check the target.

    ``rows``: check only the that many rows with the highest design value
    (default: every row); ``progress`` is called with the fraction done
    after every block of rows (it may raise to stop the check). Raises
    ValueError for trials < 100, rows < 1, a bad seed or threads < 1;
    :class:`~aacmm.uncertainty.runlimits.RunLimitError` (a ValueError) when
    the check would need more than half the memory available
    (:func:`check_memory_bytes`); KinematicsError if a drawn arm is invalid.
    """
    for name, v, lo in (("trials", trials, 100), ("seed", seed, 0)):
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise ValueError(f"{name} must be an integer >= {lo}, got {v!r}")
    nt = max(1, os.cpu_count() or 1) if threads is None else threads
    if isinstance(nt, bool) or not isinstance(nt, int) or nt < 1:
        raise ValueError(f"threads must be a positive integer, got {threads!r}")
    t0 = time.perf_counter()
    design = alloc.design
    spec = alloc.spec
    p = spec.target.coverage
    order = np.argsort(-(alloc.row_u_mm / alloc.limit_mm), kind="stable")
    if rows is not None:
        if isinstance(rows, bool) or not isinstance(rows, int) or rows < 1:
            raise ValueError(f"rows must be a positive integer, got {rows!r}")
        order = order[:rows]
    checked = np.sort(order)
    check_memory(
        check_memory_bytes(trials, checked.size, len(spec.costs)),
        f"the Monte Carlo check of {format_count(trials)} arms at {checked.size} rows",
        "use fewer --trials or --check-rows",
    )
    ss = np.random.SeedSequence(seed)
    r_par, r_enc_a, r_enc_b, r_res = (np.random.default_rng(s) for s in ss.spawn(4))
    dq = _draw(alloc, trials, r_par)
    enc_a = _readings(alloc, trials, r_enc_a)
    length = spec.target.quantity == "length"
    enc_b = _readings(alloc, trials, r_enc_b) if length else enc_a
    res_sd = spec.residual_u_mm / math.sqrt(3.0)
    parts = np.array_split(np.arange(trials), nt)
    limit = design.limit_mm[checked]
    errors = np.empty((trials, checked.size))

    def points(delta: FloatArray, poses: FloatArray, ex: ThreadPoolExecutor) -> FloatArray:
        chunks = ex.map(lambda idx: perturbed_points(spec.params, delta[idx], poses), parts)
        return np.concatenate(list(chunks))

    block = max(1, min(checked.size, _BLOCK_VALUES // trials))
    with ThreadPoolExecutor(max_workers=nt) as ex:
        for b in range(0, checked.size, block):
            rr = checked[b : b + block]
            ia, ib = design.pairs[rr, 0], design.pairs[rr, 1]
            pa = points(dq + enc_a, design.poses[ia], ex)
            if res_sd > 0:
                pa += res_sd * r_res.standard_normal(pa.shape)
            if length:
                pb = points(dq + enc_b, design.poses[ib], ex)
                if res_sd > 0:
                    pb += res_sd * r_res.standard_normal(pb.shape)
                err = np.abs(np.linalg.norm(pa - pb, axis=2) - design.lengths_mm[rr])
            else:
                err = np.linalg.norm(pa - design.points[ia][None, :, :], axis=2)
            errors[:, b : b + rr.size] = err
            if progress is not None:
                progress((b + rr.size) / checked.size)
    within = (errors <= limit[None, :]).mean(axis=0)
    within_se = np.sqrt(within * (1.0 - within) / trials)
    u_mc, u_se = _quantile_se(errors, p)
    over = spec.target.over

    def stat(q: FloatArray) -> float:
        r = q / limit
        return float(np.sqrt(np.mean(r**2)) if over == "rms" else np.max(r))

    ratio = stat(u_mc)
    if over == "rms":
        batches = np.array_split(np.arange(trials), _BATCHES)
        vals = [stat(np.quantile(errors[bi], p, axis=0)) for bi in batches]
        ratio_se = float(np.std(vals, ddof=1) / math.sqrt(_BATCHES))
        met = ratio <= 1.0
        near = ratio <= 1.0 + 2.0 * ratio_se
    else:
        worst = int(np.argmax(u_mc / limit))
        ratio_se = float(u_se[worst] / limit[worst])
    w = int(np.argmin(within))
    if over == "worst":
        met = bool(within[w] >= p)
        near = bool(within[w] >= p - 2.0 * within_se[w])
    verdict = "met" if met else ("within noise" if near else "not met")
    return CheckResult(
        trials,
        seed,
        p,
        over,
        checked,
        limit,
        within,
        within_se,
        u_mc,
        u_se,
        ratio,
        ratio_se,
        float(within[w]),
        float(within_se[w]),
        int(checked[w]),
        met,
        verdict,
        time.perf_counter() - t0,
    )
