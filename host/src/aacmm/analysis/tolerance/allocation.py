"""From a spec to the cost-optimal tolerances, encoders and budget.

:func:`allocate` builds the linearised problem (design.py), checks that the
target can be met at all, solves it (solve.py), refines the coverage factor
of the 3-D point radius to the shape of each pose's covariance, and returns
an :class:`Allocation` with the tolerance and status of every parameter, the
encoder per joint and the budget.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from aacmm.analysis.tolerance.calibrated import CalibrationModel
from aacmm.analysis.tolerance.design import Design, build_design
from aacmm.analysis.tolerance.request import ARCSEC_RAD, Encoder, ToleranceSpec
from aacmm.analysis.tolerance.solve import (
    Allocated,
    Candidate,
    Costs,
    Infeasible,
    Rows,
    optimise,
    prune,
)
from aacmm.core import FloatArray
from aacmm.errors import InfeasibleError
from aacmm.uncertainty.spec import SpecError

#: statuses of a parameter in the result
STATUSES = ("allocated", "at min", "at max", "fixed", "calibrated", "no effect")
_PHASE1_ITERATIONS = 6
_PHASE2_ITERATIONS = 40
_KAPPA_TOL = 1e-6


@dataclass(frozen=True)
class ParamResult:
    """One parameter in the allocation.

    ``tolerance``: half-width in ``unit`` (inf: any value, the target does
    not see it); ``u``: standard uncertainty in rad or mm; ``status``: one
    of :data:`STATUSES`; ``sensitivity``: RMS over the target rows of the
    row's sensitivity to the parameter, in length unit per ``unit``;
    ``cost``: c / t^k; ``contribution_mm`` and ``share``: its part of the
    budget (see :class:`Allocation`).
    """

    name: str
    unit: str
    tolerance: float
    u: float
    distribution: str
    status: str
    sensitivity: float
    cost: float
    contribution_mm: float
    share: float
    t_min: float
    t_max: float


@dataclass(frozen=True)
class EncoderResult:
    """The encoder chosen for one joint and its part of the budget."""

    joint: int
    encoder: Encoder
    u_rad: float
    contribution_mm: float
    share: float


@dataclass(frozen=True)
class Allocation:
    """The result of :func:`allocate`.

    Rows are the poses (point target) or the pairs of poses (length target).
    ``row_u_mm`` is each row's design value kappa sqrt(tr Sigma) (the
    expanded uncertainty of the point, or of the length error), ``limit_mm``
    what it may be, ``kappa`` the coverage factor used. ``ratio``: max
    (worst) or RMS (rms) of row_u/limit; the target holds if <= 1.
    ``value_mm``: the design value at the governing row (worst) or the RMS
    over rows (rms). The budget (``share``, ``contribution_mm`` of every
    parameter, encoder and fixed term) is the variance at the governing row
    (worst) or the mean of the normalised variances over rows (rms);
    contributions add in quadrature to ``value_mm``.
    """

    spec: ToleranceSpec
    design: Design
    params: tuple[ParamResult, ...]
    encoders: tuple[EncoderResult, ...]
    t: FloatArray
    v: FloatArray
    e: FloatArray
    tolerance_cost: float
    encoder_cost: float
    row_u_mm: FloatArray
    limit_mm: FloatArray
    kappa: FloatArray
    ratio: float
    value_mm: float
    governing_row: int
    fixed_terms: dict[str, tuple[float, float]]
    iterations: int
    combinations: int
    solved: int
    elapsed_s: float

    @property
    def total_cost(self) -> float:
        return self.tolerance_cost + self.encoder_cost

    @property
    def needs_tolerance(self) -> tuple[str, ...]:
        """Parameters whose manufacturing tolerance matters (allocated, at a limit, fixed)."""
        return tuple(
            p.name for p in self.params if p.status in ("allocated", "at min", "at max", "fixed")
        )

    @property
    def set_by_calibration(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params if p.status == "calibrated")


@dataclass(frozen=True)
class _Terms:
    """The problem in tolerance units: rows of tr Sigma = at t^2 + he e + base."""

    at: FloatArray  # (m, P): coefficient on t_i^2 (0 for fixed parameters)
    a: FloatArray  # (m, P): coefficient on v_i
    he: FloatArray  # (m, N)
    base: FloatArray  # (m,): fixed tolerances + calibration + residual
    v_fixed: FloatArray  # (P,)
    alloc: np.ndarray  # (P,) bool
    costs: Costs  # over the allocated parameters
    u_per_t: FloatArray  # (P,)


def _terms(spec: ToleranceSpec, design: Design) -> _Terms:
    a, he, f = design.trace_coefficients()
    upt = np.array([c.u_per_t for c in spec.costs])
    alloc = np.array([c.allocated for c in spec.costs])
    v_fixed = np.array(
        [(c.u_per_t * c.fixed) ** 2 if c.fixed is not None else 0.0 for c in spec.costs]
    )
    at = np.where(alloc[None, :], a * upt[None, :] ** 2, 0.0)
    base = f + a @ v_fixed
    sel = [c for c in spec.costs if c.allocated]
    costs = Costs(
        np.array([c.c for c in sel]),
        np.array([c.k for c in sel]),
        np.array([c.t_min for c in sel]),
        np.array([c.t_max for c in sel]),
    )
    return _Terms(at, a, he, base, v_fixed, alloc, costs, upt)


def _candidates(spec: ToleranceSpec) -> list[list[Candidate]] | None:
    if not spec.encoders:
        return None
    out = []
    for j in range(1, spec.joints + 1):
        cands = [
            Candidate(i, e.u_rad**2, e.cost) for i, e in enumerate(spec.encoders) if j in e.joints
        ]
        out.append(prune(cands))
    return out


def _rows(terms: _Terms, kappa: FloatArray, limit: FloatArray, over: str) -> Rows:
    s = (kappa / limit) ** 2
    rows = Rows((terms.at * s[:, None])[:, terms.alloc], terms.he * s[:, None], terms.base * s)
    if over == "rms":
        return rows.aggregate(np.ones(kappa.shape[0]))
    return rows


def _variances(terms: _Terms, t_alloc: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Full t (P,) in tolerance units (fixed ones filled in) and v (P,)."""
    t = np.zeros(terms.alloc.shape[0])
    t[terms.alloc] = t_alloc
    v = terms.v_fixed.copy()
    tt = np.where(np.isinf(t_alloc), 0.0, t_alloc)  # inf only where nothing sees it
    v[terms.alloc] = (terms.u_per_t[terms.alloc] * tt) ** 2
    return t, v


def _row_u(
    design: Design, v: FloatArray, e: FloatArray, start: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    cov = design.covariances(v, e)
    kappa = design.kappa(cov, start)
    return kappa * np.sqrt(np.einsum("rdd->r", cov)), kappa


def _ratio(u: FloatArray, limit: FloatArray, over: str) -> float:
    r = u / limit
    return float(np.sqrt(np.mean(r**2)) if over == "rms" else np.max(r))


def _infeasible_message(
    spec: ToleranceSpec, design: Design, terms: _Terms, e_min: FloatArray, ratio: float
) -> str:
    t_lo = np.array([c.t_min for c in spec.costs])[terms.alloc]
    _, v = _variances(terms, t_lo)
    u, _ = _row_u(design, v, e_min)
    t = spec.target
    unit, scale = spec.length_unit, spec.length_scale
    what = "U" if t.quantity == "point" else "length error"
    where = "at the worst pose" if t.quantity == "point" else "at the worst length"
    over = where if t.over == "worst" else "as an RMS over the workspace"
    goal = f"{t.value_mm / scale:g} {unit}"
    if t.quantity == "length" and t.per_metre_mm:
        goal += f" + {t.per_metre_mm / scale:g} {unit}/m"
    r = int(np.argmax(u / design.limit_mm))
    msg = (
        f"target {what} <= {goal} {over} is infeasible: with every allocated tolerance at "
        f"its process minimum"
        + (", the fixed ones as given" if not terms.alloc.all() else "")
        + (" and the most accurate encoder on every joint" if spec.encoders else "")
        + f", the best reachable is {ratio:.3g} x the target "
        f"({u[r] / scale:.4g} {unit} vs {design.limit_mm[r] / scale:.4g} at {_where(design, r)})"
    )
    if spec.encoders:
        ue, _ = _row_u(design, np.zeros(v.shape[0]), e_min)
        ratio_e = _ratio(ue, design.limit_mm, t.over)
        if ratio_e >= 1.0:
            msg += (
                f"; the encoders alone give {ratio_e:.3g} x the target: no catalogue "
                "entry is accurate enough"
            )
        else:
            msg += f"; the encoders alone use {100 * ratio_e**2:.0f} % of the variance budget"
    return msg


def _where(design: Design, r: int) -> str:
    if design.spec.target.quantity == "point":
        return f"pose {r + 1}"
    i, j = design.pairs[r]
    return f"the {design.lengths_mm[r]:.0f} mm length between poses {i + 1} and {j + 1}"


def allocate(spec: ToleranceSpec, calibration: CalibrationModel | None = None) -> Allocation:
    """The cost-optimal tolerance of every parameter and encoder of every joint.

    ``calibration``: allocate for a calibrated arm (see calibrated.py);
    default: the spec's ``[calibration]`` plan, if it has one.
    Raises InfeasibleError (with the best reachable value) if no allocation
    within the limits meets the target; ValueError for an unusable
    workspace (no pair long enough for a length target) or a catalogue with
    too many combinations.
    """
    t0 = time.perf_counter()
    if calibration is None and spec.calibration is not None:
        try:
            calibration = CalibrationModel.from_plan(
                spec.calibration, spec.params, spec.operator_limits()
            )
        except ValueError as e:
            raise SpecError(f"{spec.source}: [calibration].plan: {e}") from e
    design = build_design(spec, calibration)
    terms = _terms(spec, design)
    cands = _candidates(spec)
    over = spec.target.over
    limit = design.limit_mm
    e_min = np.zeros(spec.joints)
    if cands:
        e_min = np.array([min(c.variance for c in cj) for cj in cands])
    # Feasibility at the best point (every tolerance at its minimum, the best
    # encoders): every row's variance only grows from there (and for a normal
    # distribution the coverage radius with it, Anderson's theorem).
    t_lo = np.array([c.t_min for c in spec.costs])[terms.alloc]
    _, v_lo = _variances(terms, t_lo)
    u_lo, kappa_lo = _row_u(design, v_lo, e_min)
    ratio_lo = _ratio(u_lo, limit, over)
    if ratio_lo > 1.0:
        raise InfeasibleError(_infeasible_message(spec, design, terms, e_min, ratio_lo))
    solved = 0
    last: dict[tuple[int, ...], FloatArray] = {}  # warm starts per encoder choice

    def step(k: FloatArray, c: list[list[Candidate]] | None) -> tuple[Allocated, FloatArray]:
        nonlocal solved
        warm = next(((ch, t) for ch, t in reversed(last.items())), None)
        try:
            sol = optimise(_rows(terms, k, limit, over), terms.costs, c, warm)
        except Infeasible:
            # factors from another shape can make even the best point miss; those of
            # the best point's own shape cannot (it passed the check above)
            kk = np.minimum(k, kappa_lo)
            sol = optimise(_rows(terms, kk, limit, over), terms.costs, c, warm)
        solved += sol.solved
        last.pop(sol.choice, None)
        last[sol.choice] = sol.t
        _, v = _variances(terms, sol.t)
        return sol, _row_u(design, v, sol.e, k)[1]

    # Phase 1: the encoder choice and the coverage factors together, starting from
    # the factors of the best point's shape. The factors depend on the solution's
    # covariance shape; a discrete choice can cycle between near-equal
    # combinations, so if it has not settled after a few rounds each combination
    # seen is finished on its own (phase 2) and the cheapest kept.
    def step_all(k: FloatArray) -> tuple[Allocated, FloatArray]:
        return step(k, cands)

    sol, _, it, converged, visited = _fixed_point(step_all, kappa_lo.copy(), _PHASE1_ITERATIONS)
    combinations = sol.combinations
    runs = [sol] if converged else []
    if not converged:
        for choice in dict.fromkeys(visited):
            only = (
                [[c for c in cj if c.index == choice[j]] for j, cj in enumerate(cands)]
                if cands
                else None
            )
            try:
                sol_c, _, n, _, _ = _fixed_point(
                    functools.partial(step, c=only), kappa_lo.copy(), _PHASE2_ITERATIONS
                )
            except Infeasible:
                continue  # this choice cannot meet the target with its own factors
            it += n
            runs.append(sol_c)
    finished: list[tuple[float, Allocated, FloatArray]] = []
    for s in runs:
        t_ok = _exact_feasible(design, terms, s.t, s.e, over)
        if t_ok is not None:
            finished.append((terms.costs.total(t_ok) + s.encoder_cost, s, t_ok))
    if not finished:
        raise InfeasibleError(
            "no allocation meets the target with the exact coverage radius (the best "
            "point passes, but no solution found near it does): loosen the target slightly"
        )
    _, sol, t_alloc = min(finished, key=lambda f: f[0])
    t_full, v = _variances(terms, t_alloc)
    u, kappa = _row_u(design, v, sol.e)
    return _result(
        spec,
        design,
        terms,
        t_full,
        v,
        sol.e,
        sol.choice,
        u,
        kappa,
        it,
        combinations,
        solved,
        time.perf_counter() - t0,
    )


def _fixed_point(
    step: Callable[[FloatArray], tuple[Allocated, FloatArray]], kappa: FloatArray, max_it: int
) -> tuple[Allocated, FloatArray, int, bool, list[tuple[int, ...]]]:
    """Iterate kappa -> factors of the solution for kappa until they agree.

    Secant acceleration: with d_n = F(x_n) - x_n and one slope for all rows,
    estimated from the last two steps, x_(n+1) = x_n - d_n / slope (plain
    x_(n+1) = F(x_n) when the slope is implausible or the encoder choice
    just changed). Returns the last solution, its factors, the number of
    iterations, whether they converged, and the encoder choices seen.
    """
    choices: list[tuple[int, ...]] = []
    prev: tuple[FloatArray, FloatArray] | None = None
    for n in range(1, max_it + 1):
        sol, f = step(kappa)
        d = f - kappa
        if np.max(np.abs(d) / kappa) < _KAPPA_TOL:
            choices.append(sol.choice)
            return sol, f, n, True, choices
        if sol.choice in choices[:-1]:  # back to an earlier choice: a cycle
            choices.append(sol.choice)
            return sol, f, n, False, choices
        nxt = f
        if prev is not None and choices and sol.choice == choices[-1]:
            dx, dd = kappa - prev[0], d - prev[1]
            den = float(dx @ dx)
            slope = float(dd @ dx) / den if den > 0 else 0.0
            if -10.0 < slope < -0.1:
                nxt = kappa - d / slope
        choices.append(sol.choice)
        prev = (kappa, d)
        kappa = nxt
    return sol, f, max_it, False, choices


def _exact_feasible(
    design: Design, terms: _Terms, t_alloc: FloatArray, e: FloatArray, over: str
) -> FloatArray | None:
    """Shrink the allocated tolerances (uniformly, not below their minimum) until
    the exact coverage radius holds; None if even the minimum does not."""
    lo = terms.costs.lo
    seen = terms.at[:, terms.alloc].any(axis=0)
    free = (terms.costs.c > 0) & np.isfinite(t_alloc) & seen

    def shrunk(s: float) -> FloatArray:
        t = t_alloc.copy()
        t[free] = np.maximum(lo[free], s * t_alloc[free])
        return t

    def excess(s: float) -> float:
        _, v = _variances(terms, shrunk(s))
        u, _ = _row_u(design, v, e)
        return _ratio(u, design.limit_mm, over) - 1.0

    if excess(1.0) <= 1e-12:
        return t_alloc
    if excess(0.0) > 0.0:
        return None
    s = optimize.brentq(excess, 0.0, 1.0, xtol=1e-13, rtol=1e-13)
    while excess(s) > 0.0:
        s *= 1.0 - 1e-12
    return shrunk(s)


def _result(
    spec: ToleranceSpec,
    design: Design,
    terms: _Terms,
    t: FloatArray,
    v: FloatArray,
    e: FloatArray,
    choice: tuple[int, ...],
    u: FloatArray,
    kappa: FloatArray,
    iterations: int,
    combinations: int,
    solved: int,
    elapsed: float,
) -> Allocation:
    over = spec.target.over
    limit = design.limit_mm
    scale = spec.length_scale
    ratio = _ratio(u, limit, over)
    gov = int(np.argmax(u / limit))
    # budget weights per row: the governing row (worst) or the normalised mean (rms)
    if over == "worst":
        w = np.zeros(design.rows)
        w[gov] = kappa[gov] ** 2
        value_mm = float(u[gov])
    else:
        w = kappa**2 / design.rows * (limit.mean() / limit) ** 2
        value_mm = float(np.sqrt(np.mean(u**2)))
    p_var = w @ (terms.a * v[None, :])  # (P,)
    e_var = w @ (terms.he * e[None, :])  # (N,)
    cal_var = w @ (np.einsum("rdd->r", design.fixed_cov - design.residual_cov))
    res_var = w @ np.einsum("rdd->r", design.residual_cov)
    total = float(p_var.sum() + e_var.sum() + cal_var + res_var)
    total = total if total > 0 else 1.0
    # report the sensitivity per unit of tolerance, in the spec's length unit
    sens = np.sqrt(terms.a.mean(axis=0)) / scale * np.array([c.scale for c in spec.costs])
    identified = (
        design.calibration.identified_mask
        if design.calibration is not None
        else np.zeros(len(spec.costs), bool)
    )
    params = []
    for i, (name, c) in enumerate(zip(spec.param_names, spec.costs, strict=True)):
        ti = float(t[i]) if c.allocated else float(c.fixed or 0.0)
        seen = bool(np.any(terms.a[:, i] > 0))
        if identified[i]:
            status = "calibrated"  # whatever its tolerance, calibration sets it
        elif not seen:
            status = "no effect"
        elif not c.allocated:
            status = "fixed"
        elif ti <= c.t_min * (1 + 1e-9):
            status = "at min"
        elif ti >= c.t_max * (1 - 1e-9):
            status = "at max"
        else:
            status = "allocated"
        params.append(
            ParamResult(
                name,
                c.unit,
                ti,
                math.sqrt(v[i]),
                c.distribution,
                status,
                float(sens[i]),
                c.cost(ti),
                math.sqrt(max(p_var[i], 0.0)) * value_mm / math.sqrt(total),
                float(p_var[i] / total),
                c.t_min,
                c.t_max,
            )
        )
    encoders = tuple(
        EncoderResult(
            j + 1,
            spec.encoders[idx],
            spec.encoders[idx].u_rad,
            math.sqrt(max(e_var[j], 0.0)) * value_mm / math.sqrt(total),
            float(e_var[j] / total),
        )
        for j, idx in enumerate(choice)
    )
    fixed_terms = {
        name: (math.sqrt(max(x, 0.0)) * value_mm / math.sqrt(total), float(x / total))
        for name, x in (("calibration", cal_var), ("residual", res_var))
        if x > 0
    }
    tol_cost = float(sum(p.cost for p in params))
    enc_cost = float(sum(r.encoder.cost for r in encoders))
    return Allocation(
        spec,
        design,
        tuple(params),
        encoders,
        t,
        v,
        e,
        tol_cost,
        enc_cost,
        u,
        limit,
        kappa,
        ratio,
        value_mm,
        gov,
        fixed_terms,
        iterations,
        combinations,
        solved,
        elapsed,
    )


def arcsec(rad: float) -> float:
    """rad -> arc seconds (for reports)."""
    return rad / ARCSEC_RAD
