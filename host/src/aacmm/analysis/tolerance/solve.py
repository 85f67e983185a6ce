"""Cost-optimal tolerances under linear variance constraints, and encoder choice.

The problem, for the allocated tolerances t (n,) and a choice of encoder per
joint (variances e (6,), costs):

    minimise   sum_i c_i t_i^-k_i  +  sum_j cost(encoder_j)
    subject to a_r . t^2 + enc_r . e + base_r <= 1     for every row r
               lo_i <= t_i <= hi_i

with a, enc >= 0 (each row is a normalised variance; see design.py). For a
fixed encoder choice this is convex (in v = t^2 the cost is convex and the
rows linear).

* One row (``over = "rms"``): the Lagrange conditions give, for the
  parameters not at a limit, t_i = (k_i c_i / (2 lambda a_i))^(1/(k_i+2)),
  clipped to [lo_i, hi_i]; the row sum is monotone in lambda, which is found
  by bisection on log lambda to double precision (:func:`solve_single`).
  With a common k and no limit active this is t_i proportional to
  (k c_i / a_i)^(1/(k+2)).
* Several rows (``over = "worst"``): SLSQP on log t with a working set of
  rows (the most loaded ones; violated rows are added until none is left),
  then a uniform shrink makes every row hold exactly (:func:`solve_rows`);
  the KKT multipliers follow by non-negative least squares.
* Encoders (:func:`optimise`): branch and bound over the catalogue
  combinations. For any weights w >= 0 summing to 1, every feasible point
  also meets the single aggregated row w . rows <= 1, so the one-row optimum
  of that row plus the encoder cost is a lower bound for a combination; with
  w = the optimal multipliers of one combination the bound is exact for it
  and tight for its neighbours. Combinations are solved in the order of
  their bounds until the next bound exceeds the best cost found: the result
  is the optimum over all combinations, not a heuristic.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import optimize

from aacmm.core import FloatArray
from aacmm.errors import InfeasibleError

MAX_COMBINATIONS = 1_000_000
_FEAS_TOL = 1e-12


class Infeasible(InfeasibleError):
    """No tolerance within the limits meets the rows (internal signal, always
    caught in this package)."""


@dataclass(frozen=True)
class Costs:
    """Cost model of the allocated tolerances: cost = c t^-k on [lo, hi] (hi may be inf)."""

    c: FloatArray
    k: FloatArray
    lo: FloatArray
    hi: FloatArray

    def total(self, t: FloatArray) -> float:
        return float(np.sum(self.each(t)))

    def each(self, t: FloatArray) -> FloatArray:
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            out: FloatArray = np.where(
                (self.c == 0) | np.isinf(t), 0.0, self.c / np.asarray(t, dtype=np.float64) ** self.k
            )
        return out


@dataclass(frozen=True)
class Rows:
    """Rows a . t^2 + enc . e + base <= 1: a (m, n), enc (m, 6), base (m,)."""

    a: FloatArray
    enc: FloatArray
    base: FloatArray

    def values(self, t: FloatArray, e: FloatArray) -> FloatArray:
        tt = np.where(np.isinf(t), 0.0, t)  # inf only where a is 0
        out: FloatArray = self.a @ (tt * tt) + self.enc @ e + self.base
        return out

    def aggregate(self, w: FloatArray) -> Rows:
        w = w / w.sum()
        return Rows((w @ self.a)[None, :], (w @ self.enc)[None, :], np.array([w @ self.base]))


# --------------------------------------------------------------------------
# One row
# --------------------------------------------------------------------------


def _single_vec(a: FloatArray, budgets: FloatArray, costs: Costs) -> FloatArray:
    """Optimal t (N, n) for the row a . t^2 <= budget, for each budget (N,); NaN rows if
    infeasible."""
    c, k, lo, hi = costs.c, costs.k, costs.lo, costs.hi
    nb = budgets.shape[0]
    t = np.empty((nb, a.shape[0]))
    fixed_hi = a == 0
    fixed_lo = (~fixed_hi) & ((c == 0) | (lo >= hi))
    free = ~(fixed_hi | fixed_lo)
    t[:, fixed_hi] = hi[fixed_hi]
    t[:, fixed_lo] = lo[fixed_lo]
    base = float(np.sum(a[fixed_lo] * lo[fixed_lo] ** 2))
    af, cf, kf, lof, hif = a[free], c[free], k[free], lo[free], hi[free]
    b = budgets - base
    minimum = float(np.sum(af * lof**2))
    bad = b < minimum * (1.0 - 1e-15) - 1e-300
    if not free.any():
        t[bad] = np.nan
        return t
    maximum = float(np.sum(af * hif**2)) if np.all(np.isfinite(hif)) else math.inf
    loose = b >= maximum
    logr = np.log(kf * cf / (2.0 * af))  # t_i = exp((logr_i - L) / (k_i + 2))
    with np.errstate(divide="ignore"):
        llo, lhi = np.log(lof), np.log(hif)
    # bracket for L = log lambda: at L_min the row exceeds b, at L_max it is below.
    # Below, t_i <= max(lo_i, r_i e^(-L/(k_i+2))) with log r_i = logr_i / (k_i+2), so
    # a_i r_i^2 e^(-2L/(k_i+2)) <= slack / n for every i puts the row under b.
    slack = np.maximum(b - minimum, 1e-300)
    l_max = np.max(
        0.5
        * (kf + 2.0)[None, :]
        * (
            math.log(af.size)
            + np.log(af)[None, :]
            + (2.0 * logr / (kf + 2.0))[None, :]
            - np.log(slack)[:, None]
        ),
        axis=1,
    )
    inf_hi = np.isinf(hif)
    if inf_hi.any():
        cand = (kf + 2.0)[inf_hi][None, :] * (
            logr[inf_hi][None, :] / (kf + 2.0)[inf_hi][None, :]
            - 0.5 * np.log(np.maximum(b, 1e-300)[:, None] / af[inf_hi][None, :])
        )
        l_min = cand.max(axis=1) - 1.0
    else:
        l_min = np.full(nb, np.min(logr - (kf + 2.0) * lhi) - 1.0)
    l_max = np.maximum(l_max, l_min) + 1.0

    def tol_at(lv: FloatArray) -> tuple[FloatArray, FloatArray]:
        """t (N, n) at L = log lambda, and which t are not at a limit."""
        y = (logr[None, :] - lv[:, None]) / (kf + 2.0)[None, :]
        inside = (y > llo[None, :]) & (y < lhi[None, :])
        return np.exp(np.clip(y, llo[None, :], lhi[None, :])), inside

    # Safeguarded Newton on L, row by row: the row sum g(L) falls monotonically,
    # dg/dL = -sum over the t not at a limit of 2 a_i t_i^2 / (k_i + 2); a step
    # leaving the bracket [lo_l, hi_l] (g > b at lo_l, g <= b at hi_l) bisects.
    # Converged rows leave the iteration.
    lo_l, hi_l = l_min.copy(), l_max.copy()
    lv = 0.5 * (lo_l + hi_l)
    w = 2.0 / (kf + 2.0)
    todo = np.flatnonzero(~(bad | loose))
    for _ in range(200):
        if todo.size == 0:
            break
        tt, inside = tol_at(lv[todo])
        at2 = af[None, :] * tt**2
        g = at2.sum(axis=1) - b[todo]
        lo_l[todo] = np.where(g > 0, lv[todo], lo_l[todo])
        hi_l[todo] = np.where(g > 0, hi_l[todo], lv[todo])
        slope = -(at2 * inside * w[None, :]).sum(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            nxt = lv[todo] - g / slope
        out = ~np.isfinite(nxt) | (nxt <= lo_l[todo]) | (nxt >= hi_l[todo])
        nxt = np.where(out, 0.5 * (lo_l[todo] + hi_l[todo]), nxt)
        moving = np.abs(nxt - lv[todo]) > 1e-15 * np.maximum(1.0, np.abs(lv[todo]))
        lv[todo] = nxt
        todo = todo[moving]
    # the feasible side of the root: a few ulps up from the converged point
    for _ in range(40):
        tt, _ = tol_at(lv)
        over = (af[None, :] * tt**2).sum(axis=1) > b
        if not over.any():
            break
        lv = np.where(over, np.minimum(lv + 4e-16 * np.maximum(1.0, np.abs(lv)), hi_l), lv)
    tt, _ = tol_at(lv)
    ok = (af[None, :] * tt**2).sum(axis=1) <= b
    hi_l = np.where(ok, lv, hi_l)
    tf, _ = tol_at(hi_l)
    tf[loose] = hif
    t[:, free] = tf
    t[bad] = np.nan
    return t


def solve_single(a: FloatArray, budget: float, costs: Costs) -> FloatArray:
    """Optimal t (n,) for one row a . t^2 <= budget. Raises Infeasible."""
    t: FloatArray = _single_vec(np.asarray(a, dtype=np.float64), np.array([budget]), costs)[0]
    if np.isnan(t).any():
        raise Infeasible
    return t


def single_costs(a: FloatArray, budgets: FloatArray, costs: Costs) -> FloatArray:
    """The optimal one-row cost for each budget (N,); inf where infeasible."""
    out = np.full(budgets.shape[0], math.inf)
    chunk = max(1, 200_000 // max(1, a.shape[0]))
    for s in range(0, budgets.shape[0], chunk):
        t = _single_vec(a, budgets[s : s + chunk], costs)
        ok = ~np.isnan(t).any(axis=1)
        out[s : s + chunk][ok] = costs.each(t[ok]).sum(axis=1)
    return out


# --------------------------------------------------------------------------
# Several rows
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class RowSolution:
    """t (n,), KKT multipliers mu (m,) >= 0 of the rows, tolerance cost."""

    t: FloatArray
    mu: FloatArray
    cost: float


def _shrink_to_feasible(
    rows: Rows, b: FloatArray, t: FloatArray, lo: FloatArray, free: npt.NDArray[np.bool_]
) -> FloatArray:
    """Scale the free tolerances down (not below lo) until every row holds."""

    def tt(s: float) -> FloatArray:
        out = t.copy()
        out[free] = np.maximum(lo[free], s * t[free])
        return out

    if np.all(rows.a @ np.where(np.isinf(t), 0, t) ** 2 <= b * (1 + _FEAS_TOL)):
        return t
    s_lo, s_hi = 0.0, 1.0
    for _ in range(100):
        mid = 0.5 * (s_lo + s_hi)
        if np.all(rows.a @ np.where(np.isinf(t), 0, tt(mid)) ** 2 <= b):
            s_lo = mid
        else:
            s_hi = mid
    return tt(s_lo)


def solve_rows(
    rows: Rows, e: FloatArray, costs: Costs, start: FloatArray | None = None
) -> RowSolution:
    """Optimal t for several rows with encoder variances ``e``. Raises Infeasible.

    ``start``: a nearby solution (e.g. of the previous coverage factors) to
    start from instead of the one-row solution of the mean row.
    """
    b = 1.0 - rows.base - rows.enc @ e
    a = rows.a
    lo, hi = costs.lo, costs.hi
    lo_use = np.where(a.any(axis=0), lo, 0.0)
    if np.any(a @ lo_use**2 > b * (1 + _FEAS_TOL)):
        raise Infeasible
    m = a.shape[0]
    if m == 1:
        t = solve_single(a[0], float(b[0]), costs)
        return RowSolution(t, _multipliers(rows, b, t, costs), costs.total(t))
    w0 = np.ones(m) / m
    t0 = solve_single(w0 @ a, float(w0 @ b), costs)
    free = a.any(axis=0) & (costs.c > 0) & (lo < hi)
    if start is not None and start.shape == t0.shape:
        t0 = np.where(free & np.isfinite(start), np.clip(start, lo, hi), t0)
    t0 = _shrink_to_feasible(rows, b, t0, lo, free)
    idx = np.flatnonzero(free)
    if idx.size == 0:
        return RowSolution(t0, np.zeros(m), costs.total(t0))
    with np.errstate(divide="ignore"):
        cap = np.sqrt(np.min(np.where(a[:, idx] > 0, b[:, None] / a[:, idx], np.inf), axis=0))
    ub = np.log(np.minimum(hi[idx], cap))
    lb = np.log(np.maximum(lo[idx], np.minimum(hi[idx], cap) * 1e-12))
    rest = t0.copy()
    tt_rest = np.where(np.isinf(rest), 0.0, rest)
    tt_rest[idx] = 0.0
    b_free = np.maximum(b - a @ tt_rest**2, 1e-300)  # budget left for the free parameters
    cf, kf = costs.c[idx], costs.k[idx]
    f0 = float(np.sum(cf * t0[idx] ** -kf))

    def fun(y: FloatArray) -> float:
        return float(np.sum(cf * np.exp(-kf * y)) / f0)

    def jac(y: FloatArray) -> FloatArray:
        out: FloatArray = -kf * cf * np.exp(-kf * y) / f0
        return out

    values = (a[:, idx] @ t0[idx] ** 2) / b_free
    work = set(np.argsort(values)[-8:].tolist()) | set(np.flatnonzero(values > 0.99).tolist())
    y = np.log(np.clip(t0[idx], np.exp(lb), np.exp(ub)))
    for _ in range(60):
        wl = np.array(sorted(work))
        aw = a[np.ix_(wl, idx)] / b_free[wl, None]
        res = optimize.minimize(
            fun,
            y,
            jac=jac,
            method="SLSQP",
            bounds=list(zip(lb, ub, strict=True)),
            constraints=[
                {
                    "type": "ineq",
                    "fun": lambda yy, aw=aw: 1.0 - aw @ np.exp(2 * yy),
                    "jac": lambda yy, aw=aw: -2.0 * aw * np.exp(2 * yy)[None, :],
                }
            ],
            options={"ftol": 1e-15, "maxiter": 2000},
        )
        y = np.clip(res.x, lb, ub)
        values = (a[:, idx] @ np.exp(2 * y)) / b_free
        viol = np.flatnonzero(values > 1 + 1e-9)
        new = set(viol[np.argsort(values[viol])[-10:]].tolist()) - work
        if not new:
            break
        work |= new
    t = t0.copy()
    t[idx] = np.exp(y)
    t = _shrink_to_feasible(rows, b, t, lo, free)
    return RowSolution(t, _multipliers(rows, b, t, costs), costs.total(t))


def _multipliers(rows: Rows, b: FloatArray, t: FloatArray, costs: Costs) -> FloatArray:
    """KKT multipliers mu >= 0 of the rows a_r . t^2 + enc_r . e + base_r <= 1."""
    a = rows.a
    m = a.shape[0]
    tt = np.where(np.isinf(t), 0.0, t)
    load = (a @ tt**2) / b
    active = np.flatnonzero(load > 1 - 1e-6)
    interior = (
        (costs.c > 0) & (t > costs.lo * (1 + 1e-9)) & (t < costs.hi * (1 - 1e-9)) & a.any(axis=0)
    )
    mu = np.zeros(m)
    if active.size == 0 or not interior.any():
        return mu
    # d/dt_i: -k c t^-(k+1) + sum_r mu_r 2 a_ri t_i / b_r = 0, times t_i:
    ii = np.flatnonzero(interior)
    mat = 2.0 * a[np.ix_(active, ii)].T * tt[ii, None] ** 2 / b[None, active]
    rhs = costs.k[ii] * costs.c[ii] * tt[ii] ** -costs.k[ii]
    sol, _ = optimize.nnls(mat, rhs)
    mu[active] = sol / b[active]  # multipliers of the rows as written (values <= 1)
    return mu


# --------------------------------------------------------------------------
# Encoder choice
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class Candidate:
    """An encoder that fits a joint: its index in the catalogue, reading variance, cost."""

    index: int
    variance: float
    cost: float


def prune(cands: list[Candidate]) -> list[Candidate]:
    """Drop the encoders that another one beats on both variance and cost."""
    keep = []
    for c in cands:
        dominated = any(
            (o.variance <= c.variance and o.cost <= c.cost)
            and (o.variance < c.variance or o.cost < c.cost or o.index < c.index)
            for o in cands
            if o is not c
        )
        if not dominated:
            keep.append(c)
    return keep


@dataclass(frozen=True)
class Allocated:
    """Result of :func:`optimise`: tolerances, encoder choice (catalogue indices
    per joint, or empty), encoder variances, costs, multipliers, search statistics."""

    t: FloatArray
    choice: tuple[int, ...]
    e: FloatArray
    tolerance_cost: float
    encoder_cost: float
    mu: FloatArray
    combinations: int
    solved: int


def optimise(
    rows: Rows,
    costs: Costs,
    candidates: list[list[Candidate]] | None,
    start: tuple[tuple[int, ...], FloatArray] | None = None,
) -> Allocated:
    """The cost-optimal tolerances and encoder choice (see the module docstring).

    ``candidates``: per joint the encoders that fit (None or [] : no
    encoders). ``start``: (encoder choice, tolerances) of a nearby problem's
    solution, to start that combination's solve from. Raises Infeasible if
    no combination meets the rows, ValueError if the catalogue has more than
    MAX_COMBINATIONS combinations.
    """
    joints = len(rows.enc[0]) if rows.enc.ndim == 2 else 6
    if not candidates:
        sol = solve_rows(rows, np.zeros(joints), costs, start[1] if start else None)
        return Allocated(sol.t, (), np.zeros(joints), sol.cost, 0.0, sol.mu, 1, 1)
    sizes = [len(c) for c in candidates]
    n_comb = math.prod(sizes)
    if n_comb > MAX_COMBINATIONS:
        raise ValueError(
            f"{n_comb} encoder combinations (after dropping dominated entries): "
            f"at most {MAX_COMBINATIONS}; restrict the joints entries"
        )
    grid = np.array(list(itertools.product(*[range(s) for s in sizes])), dtype=np.int64)
    var = np.stack(
        [np.array([c.variance for c in cj])[grid[:, j]] for j, cj in enumerate(candidates)], 1
    )
    enc_cost = sum(np.array([c.cost for c in cj])[grid[:, j]] for j, cj in enumerate(candidates))
    enc_cost = np.asarray(enc_cost, dtype=np.float64)

    def bound(w: FloatArray) -> FloatArray:
        agg = rows.aggregate(w)
        budgets = 1.0 - agg.base[0] - var @ agg.enc[0]
        return enc_cost + single_costs(agg.a[0], budgets, costs)

    m = rows.a.shape[0]
    lb = bound(np.ones(m))
    done = np.zeros(n_comb, dtype=bool)
    best: tuple[float, int, RowSolution] | None = None
    solved = 0
    while True:
        open_lb = np.where(done, np.inf, lb)
        i = int(np.argmin(open_lb))
        if not math.isfinite(open_lb[i]):
            break
        if best is not None and open_lb[i] >= best[0] * (1 - 1e-10):
            break
        done[i] = True
        try:
            choice_i = tuple(candidates[j][int(grid[i, j])].index for j in range(len(candidates)))
            warm = start[1] if start is not None and start[0] == choice_i else None
            sol = solve_rows(rows, var[i], costs, warm)
        except Infeasible:
            continue
        solved += 1
        total = sol.cost + float(enc_cost[i])
        if best is None or total < best[0]:
            best = (total, i, sol)
        if m > 1 and sol.mu.sum() > 0:
            lb = np.maximum(lb, bound(sol.mu))
    if best is None:
        raise Infeasible
    _, i, sol = best
    choice = tuple(candidates[j][int(grid[i, j])].index for j in range(len(candidates)))
    return Allocated(
        sol.t, choice, var[i].copy(), sol.cost, float(enc_cost[i]), sol.mu, n_comb, solved
    )
