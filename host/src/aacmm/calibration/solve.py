"""The calibration solve: weighted Levenberg-Marquardt in the identifiable subspace.

:func:`calibrate` runs the whole procedure:

1. identifiability at the start parameters (:func:`~aacmm.calibration.identifiability.analyse`);
2. Levenberg-Marquardt (``scipy.optimize.least_squares``, MINPACK's ``lm``,
   with the analytic projected Jacobian) over the identifiable subspace only:
   with the ``fix`` strategy the unobservable directions are removed by holding
   a few parameters at their start values (theta1 offset and d1 first, as
   published AACMM calibrations do, then theta6 offset and alpha6 for the
   tip, then whatever carries the remaining null space); with ``min-norm`` the
   step is confined to the identifiable singular directions, so the change has
   no component in the null space (column-scaled metric);
3. identifiability again *at the solution* (the rank tolerance scales with the
   residuals, which are large at the start); if the rank or the held set
   changed, the solve is repeated from there, held parameters reset;
4. covariance ``(J^T W J)^-1`` of the free parameters (zero rows for held
   ones), correlations, the chi-square consistency check and, when it fails,
   a search for the unmodelled error (a once-per-revolution angle error of a
   joint, as encoder eccentricity gives);
5. outliers: each probed point (or length position) is tested with its
   normalised residual against a family-wise false-alarm rate; flagged points
   are only excluded (and the solve repeated) when ``reject=True``.

Nothing here prints: progress goes to an optional callback.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, stats

from aacmm.calibration.identifiability import DEFAULT_KAPPA, Identifiability, analyse
from aacmm.calibration.observations import LengthSet, Observations
from aacmm.calibration.problem import (
    KIND_LENGTH,
    CalibrationError,
    Evaluation,
    Problem,
    Residuals,
)
from aacmm.core import JOINTS, PARAM_GROUPS, PARAM_NAMES, FloatArray, Params

STRATEGIES = ("fix", "min-norm")
DEFAULT_ALPHA_CHI2 = 0.001
DEFAULT_ALPHA_OUTLIER = 0.01
_MAX_STAGES = 5
_MAX_REJECT_ROUNDS = 4


@dataclass(frozen=True)
class Progress:
    """One residual evaluation of the solver: stage (1, 2, ...), evaluation count, chi^2."""

    stage: int
    nfev: int
    chi2: float
    rms_mm: float
    free: int


@dataclass(frozen=True)
class Outlier:
    """A probed point (or length position) whose residual fails the outlier test.

    ``statistic``: sum of squared normalised residuals of its rows (rows = 3
    for a point constraint or reference, 1 otherwise), after the robust scale;
    ``p_value``: its chi-square tail probability; ``threshold``: the
    statistic the family-wise test allows; ``residual_mm``: size of the
    residual (distance to the seat, length error, ...).
    """

    constraint: str
    kind: str
    poses: tuple[int, ...]
    label: str
    position: int
    statistic: float
    threshold: float
    p_value: float
    residual_mm: float


@dataclass(frozen=True)
class Suspect:
    """A candidate unmodelled error found in the residuals of an inconsistent fit.

    ``name``: e.g. ``joint 3 once-per-revolution angle``; ``chi2_drop``: its
    significance given the other suspects (Wald statistic, chi-square with 2
    dof if it were absent); ``excess``: chi^2 - dof of the fit; ``amplitude``
    and ``amplitude_sd``: its size and standard uncertainty (rad);
    ``explained``: how much chi^2 the extended model (every joint) removes.
    """

    name: str
    chi2_drop: float
    excess: float
    amplitude: float
    unit: str
    amplitude_sd: float = 0.0
    explained: float = 0.0


@dataclass(frozen=True)
class ChiSquare:
    """The consistency check: chi^2 of the whitened residuals against its dof.

    ``verdict``: ``consistent``, ``incomplete`` (residuals too large for the
    stated uncertainties: an unmodelled error, or uncertainties understated),
    ``overstated`` (too small) or ``no dof``.
    """

    chi2: float
    dof: int
    p_value: float
    alpha: float
    verdict: str
    suspects: tuple[Suspect, ...] = ()

    @property
    def ratio(self) -> float:
        """chi^2 / dof: the a-posteriori variance factor."""
        return self.chi2 / self.dof if self.dof > 0 else math.nan

    @property
    def consistent(self) -> bool:
        return self.verdict in ("consistent", "overstated")

    def describe(self) -> str:
        if self.dof <= 0:
            return "chi-square check: no degrees of freedom left (as many unknowns as data)"
        head = (
            f"chi^2 = {self.chi2:.1f} for {self.dof} dof (ratio {self.ratio:.3f}, "
            f"p = {self.p_value:.3g})"
        )
        if self.verdict == "consistent":
            return f"{head}: residuals consistent with the stated uncertainties"
        if self.verdict == "overstated":
            return (
                f"{head}: residuals smaller than expected: the stated uncertainties are too large"
            )
        text = (
            f"{head}: MODEL INCOMPLETE -- residuals exceed the stated uncertainties "
            f"(p < {self.alpha:g}): an unmodelled error, or uncertainties understated"
        )
        if self.suspects:
            share = min(
                100.0, 100 * self.suspects[0].explained / max(self.suspects[0].excess, 1e-300)
            )
            joints = ", ".join(
                f"{s.name.split(' once')[0]} {s.amplitude * 1e6:.1f} +- "
                f"{s.amplitude_sd * 1e6:.1f} urad"
                for s in self.suspects
            )
            text += (
                f"; the residuals look like once-per-revolution angle errors (eccentric encoders): "
                f"{joints} (explaining {share:.0f} % of the excess)"
            )
        return text


@dataclass(frozen=True)
class CalibrationResult:
    """Everything a calibration found.

    ``params``: calibrated parameters; ``start``: where it began.
    ``free``: parameters that were estimated; ``held``: parameters held at
    their start values because the data cannot observe them (auto, 'fix'
    strategy) and ``fixed``: those the caller fixed. ``identifiability`` (at
    the solution) and ``identifiability_start``; ``covariance`` (25, 25),
    rad and mm, from the stated uncertainties (a priori), zero for held and
    fixed parameters; ``chi_square``; ``outliers`` found at the solution and
    ``rejected`` (excluded when ``reject=True``); ``before`` and ``after``:
    evaluations at start and solution; ``observations``: the data finally used.
    """

    params: Params
    start: Params
    strategy: str
    free: tuple[str, ...]
    held: tuple[str, ...]
    fixed: tuple[str, ...]
    identifiability: Identifiability
    identifiability_start: Identifiability
    covariance: FloatArray
    chi_square: ChiSquare
    outliers: tuple[Outlier, ...]
    rejected: tuple[Outlier, ...]
    before: Evaluation
    after: Evaluation
    observations: Observations
    problem: Problem
    history: tuple[Progress, ...]
    elapsed_s: float
    stages: int
    solver_status: str = ""
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def std(self) -> FloatArray:
        """Standard uncertainties (25,) of the parameters (0 for held/fixed)."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    @property
    def correlation(self) -> FloatArray:
        """Correlation matrix (25, 25); NaN rows/columns for held or fixed parameters."""
        sd = self.std
        with np.errstate(invalid="ignore", divide="ignore"):
            c = self.covariance / np.outer(sd, sd)
        c[sd == 0, :] = np.nan
        c[:, sd == 0] = np.nan
        return c

    @property
    def scaled_covariance(self) -> FloatArray:
        """Covariance scaled by max(1, chi^2/dof): honest when the check fails."""
        return self.covariance * max(1.0, self.chi_square.ratio if self.chi_square.dof else 1.0)

    def delta(self) -> FloatArray:
        """Calibrated minus start parameters (25,)."""
        return self.params.to_vector() - self.start.to_vector()

    def strongest_correlations(self, k: int = 5) -> list[tuple[str, str, float]]:
        """The ``k`` largest |correlations| between free parameters."""
        c = self.correlation
        pairs = []
        for i in range(25):
            for j in range(i + 1, 25):
                if np.isfinite(c[i, j]):
                    pairs.append((PARAM_NAMES[i], PARAM_NAMES[j], float(c[i, j])))
        pairs.sort(key=lambda t: -abs(t[2]))
        return pairs[:k]


def parse_names(names: Sequence[str]) -> tuple[str, ...]:
    """Parameter names from names and groups (``theta``, ``alpha``, ``d``, ``a``,
    ``tip`` = theta6 alpha6 d6 a6 l, ``all``), comma lists allowed; in column order.

    Raises ValueError for an unknown name.
    """
    from aacmm.calibration.identifiability import TIP_PARAMS

    out: set[str] = set()
    for item in names:
        for n in (x.strip() for x in str(item).split(",")):
            if not n:
                continue
            if n in PARAM_NAMES:
                out.add(n)
            elif n in PARAM_GROUPS[:4]:
                out |= {f"{n}{i}" for i in range(1, JOINTS + 1)}
            elif n == "tip":
                out |= set(TIP_PARAMS)
            elif n == "all":
                out |= set(PARAM_NAMES)
            else:
                raise ValueError(
                    f"unknown parameter {n!r} (theta1..6, alpha1..6, d1..6, a1..6, l, or a "
                    "group: theta, alpha, d, a, tip, all)"
                )
    return tuple(n for n in PARAM_NAMES if n in out)


class _Solver:
    """One least-squares run over a parametrisation x -> 25 parameters."""

    def __init__(
        self,
        problem: Problem,
        base: FloatArray,
        basis: FloatArray,
        stage: int,
        progress: Callable[[Progress], None] | None,
        history: list[Progress],
    ) -> None:
        self.problem = problem
        self.base = base  # (25,)
        self.basis = basis  # (25, k): dp = basis @ x
        self.stage = stage
        self.progress = progress
        self.history = history
        self._key: bytes | None = None
        self._ev: Evaluation | None = None
        self._rkey: bytes | None = None
        self._res: Residuals | None = None
        self.nfev = 0

    def params(self, x: FloatArray) -> Params:
        return Params.from_vector(self.base + self.basis @ x)

    def _note(self, res: Residuals) -> None:
        self.nfev += 1
        rms = float(np.sqrt(np.mean((res.r * self.problem.sigma) ** 2)))
        p = Progress(self.stage, self.nfev, res.chi2, rms, self.basis.shape[1])
        self.history.append(p)
        if self.progress is not None:
            self.progress(p)

    def fun(self, x: FloatArray) -> FloatArray:
        key = np.asarray(x, dtype=np.float64).tobytes()
        if key == self._key and self._ev is not None:
            return self._ev.r
        if key != self._rkey or self._res is None:
            self._res = self.problem.residuals(self.params(x))
            self._rkey = key
            self._note(self._res)
        return self._res.r

    def ev(self, x: FloatArray) -> Evaluation:
        key = np.asarray(x, dtype=np.float64).tobytes()
        if key != self._key or self._ev is None:
            self._ev = self.problem.evaluate(self.params(x))
            self._key = key
            if key != self._rkey:
                self._note(self._ev)
        return self._ev

    def run(self, max_nfev: int) -> tuple[FloatArray, str]:
        k = self.basis.shape[1]
        x0 = np.zeros(k)
        if k == 0:
            return x0, "nothing to solve"
        m = self.problem.m
        res = optimize.least_squares(
            self.fun,
            x0,
            jac=lambda x: self.ev(x).jac @ self.basis,
            method="lm" if m >= k else "trf",
            ftol=1e-15,
            xtol=1e-15,
            gtol=1e-15,
            max_nfev=max_nfev,
            x_scale=1.0,
        )
        if res.status == 0:  # evaluation limit: say so rather than pass it off as a solution
            raise CalibrationError(
                f"the solver did not converge in {max_nfev} evaluations (stage {self.stage}): "
                "check the data (outliers, wrong artefact values) or the start parameters"
            )
        return np.asarray(res.x), str(res.message)


def _stage_basis(
    ident: Identifiability, candidates: Sequence[int], strategy: str
) -> tuple[FloatArray, tuple[str, ...]]:
    """The parametrisation (25, k) of a stage and the parameters it holds."""
    scale = np.zeros(25)
    scale[list(ident.columns)] = ident.scale
    if strategy == "fix":
        held = set(ident.held)
        cols = [c for c in candidates if PARAM_NAMES[c] not in held]
        b = np.zeros((25, len(cols)))
        for j, c in enumerate(cols):
            b[c, j] = 1.0 / scale[c]  # x in mm at the tip
        return b, ident.held
    b = np.zeros((25, ident.rank))
    b[list(ident.columns), :] = ident.basis / ident.scale[:, None]
    return b, ()


def _covariance(ev: Evaluation, basis: FloatArray) -> FloatArray:
    """(25, 25) covariance of basis @ x from the whitened Jacobian (zero outside the basis).

    From the normal matrix: the basis spans identifiable directions only, so
    it is well conditioned (its condition number squares that of the scaled
    Jacobian, ~1e4, far from rounding trouble).
    """
    if basis.shape[1] == 0:
        return np.zeros((25, 25))
    a = ev.jac @ basis
    cov: FloatArray = basis @ np.linalg.inv(a.T @ a) @ basis.T
    return cov


def _dof(problem: Problem, ev: Evaluation, rank: int) -> int:
    return int(ev.r.size - problem.n_nuisance - rank)


def _chi_square(
    problem: Problem, ev: Evaluation, basis: FloatArray, rank: int, alpha: float
) -> ChiSquare:
    chi2 = ev.chi2
    dof = _dof(problem, ev, rank)
    if dof <= 0:
        return ChiSquare(chi2, dof, math.nan, alpha, "no dof")
    p = float(stats.chi2.sf(chi2, dof))
    if p < alpha:
        return ChiSquare(chi2, dof, p, alpha, "incomplete", _suspects(problem, ev, basis, dof))
    if float(stats.chi2.cdf(chi2, dof)) < alpha:
        return ChiSquare(chi2, dof, p, alpha, "overstated")
    return ChiSquare(chi2, dof, p, alpha, "consistent")


def _suspects(problem: Problem, ev: Evaluation, basis: FloatArray, dof: int) -> tuple[Suspect, ...]:
    """Once-per-revolution angle errors of the joints that the residuals show.

    The model extended by e_k(q) = s_k sin q_k + c_k cos q_k on every joint (what
    an eccentric encoder disc gives), fitted to the residuals jointly: the
    columns dp/dq_k sin q_k and dp/dq_k cos q_k, projected like the rest and
    made orthogonal to the identifiable columns (so the coefficients are
    those of the joint fit with the arm's parameters, Frisch-Waugh-Lovell).
    A joint is a suspect when its pair is significant given the others (Wald
    statistic over chi-square(2) at 1e-6); the suspects are returned only if
    the extended model explains at least half of the excess chi^2 - dof.
    """
    theta = problem.obs.theta_rad
    extra = np.zeros((theta.shape[0], 3, 2 * JOINTS))
    for k in range(JOINTS):
        col = ev.point_jac[:, :, k]  # dp/dq_k
        extra[:, :, 2 * k] = col * np.sin(theta[:, k])[:, None]
        extra[:, :, 2 * k + 1] = col * np.cos(theta[:, k])[:, None]
    ext = problem.evaluate(ev.params, extra_point_jac=extra)
    a = ev.jac @ basis
    b = ext.jac[:, 25:]
    if a.shape[1]:
        q, _ = np.linalg.qr(a)
        b = b - q @ (q.T @ b)
    excess = max(ev.chi2 - dof, 0.0)
    coef, *_ = np.linalg.lstsq(b, ev.r, rcond=None)
    fit = b @ coef
    explained = float(fit @ (2 * ev.r - fit))
    if explained < max(0.5 * excess, 25.0):
        return ()
    cov = np.linalg.pinv(b.T @ b)
    limit = float(stats.chi2.isf(1e-6, 2))
    out = []
    for k in range(JOINTS):
        ck = coef[2 * k : 2 * k + 2]
        vk = cov[2 * k : 2 * k + 2, 2 * k : 2 * k + 2]
        wald = float(ck @ np.linalg.pinv(vk) @ ck)
        if wald > limit:
            out.append(
                Suspect(
                    f"joint {k + 1} once-per-revolution angle",
                    wald,
                    excess,
                    float(np.hypot(*ck)),
                    "rad",
                    float(np.sqrt(np.trace(vk) / 2.0)),
                    explained,
                )
            )
    out.sort(key=lambda s: -s.chi2_drop)
    return tuple(out)


def find_outliers(
    problem: Problem, ev: Evaluation, alpha: float = DEFAULT_ALPHA_OUTLIER
) -> tuple[Outlier, ...]:
    """Probed points (or length positions) whose normalised residual is improbable.

    Each unit's statistic is sum(r_i^2 / (1 - h_i)) over its rows (chi-square
    with as many dof as rows if the stated uncertainties hold), divided by a
    robust scale (the median statistic over its expected median, at least 1,
    per kind) so that one understated uncertainty does not flag everything;
    a unit is flagged if its tail probability is below ``alpha`` / units
    (Bonferroni: ``alpha`` is the chance of any false alarm).
    """
    unit = ev.unit
    ok = unit >= 0
    denom = np.clip(1.0 - ev.h[ok], 1e-12, None)
    stat = np.bincount(unit[ok], weights=ev.r[ok] ** 2 / denom, minlength=problem.n_units)
    rows = np.bincount(unit[ok], minlength=problem.n_units)
    size = np.sqrt(
        np.bincount(unit[ok], weights=(ev.r[ok] * ev.sigma[ok]) ** 2, minlength=problem.n_units)
    )
    present = rows > 0
    n_units = int(present.sum())
    if n_units == 0:
        return ()
    scale = np.ones(problem.n_units)
    kinds = problem.unit_kind
    for kind in np.unique(kinds[present]):
        sel = present & (kinds == kind)
        dof = rows[sel]
        med = float(np.median(stat[sel] / stats.chi2.median(dof)))
        scale[sel] = max(1.0, med)
    t = stat / scale
    thr = np.zeros(problem.n_units)
    for dof in np.unique(rows[present]):
        thr[rows == dof] = float(stats.chi2.isf(alpha / n_units, dof))
    out = []
    for i in np.flatnonzero(present & (t > thr)):
        u = problem.unit(int(i))
        label = problem.obs.label(u.poses[0])
        if u.kind == KIND_LENGTH:
            label = f"{label} (length position {u.position})"
        out.append(
            Outlier(
                problem.obs.constraints[u.constraint].name,
                u.kind,
                u.poses,
                label,
                u.position,
                float(t[i]),
                float(thr[i]),
                float(stats.chi2.sf(t[i], rows[i])),
                float(size[i]),
            )
        )
    out.sort(key=lambda o: -o.statistic)
    return tuple(out)


def _candidates(free: Sequence[str] | None, fix: Sequence[str]) -> list[int]:
    names = parse_names(free) if free is not None else PARAM_NAMES
    fixed = set(parse_names(fix))
    cols = [PARAM_NAMES.index(n) for n in names if n not in fixed]
    if not cols:
        raise ValueError("no parameter left free to calibrate")
    return cols


def calibrate(
    obs: Observations,
    start: Params | None = None,
    *,
    free: Sequence[str] | None = None,
    fix: Sequence[str] = (),
    strategy: str = "fix",
    reject: bool = False,
    kappa: float = DEFAULT_KAPPA,
    alpha_chi2: float = DEFAULT_ALPHA_CHI2,
    alpha_outlier: float = DEFAULT_ALPHA_OUTLIER,
    max_nfev: int = 200,
    progress: Callable[[Progress], None] | None = None,
) -> CalibrationResult:
    """Identify the arm's parameters from ``obs``, starting at ``start`` (default Table 1).

    ``free``/``fix``: parameter names or groups to estimate / hold (default:
    all 25 free); ``strategy``: ``fix`` or ``min-norm`` for the unobservable
    directions (see the module doc); ``reject``: exclude outliers and solve
    again (otherwise they are only reported).

    Raises ObservationError (bad data), CalibrationError (no solution: the
    parameters left the valid range, degenerate constraints), ValueError (bad
    arguments).
    """
    if strategy not in STRATEGIES:
        raise ValueError(f"strategy must be one of {', '.join(STRATEGIES)}, got {strategy!r}")
    p0 = start or Params()
    p0.validate()
    cand = _candidates(free, fix)
    t0 = time.perf_counter()
    history: list[Progress] = []
    rejected: list[Outlier] = []
    current = obs
    notes: list[str] = []
    for _round in range(_MAX_REJECT_ROUNDS + 1):
        res = _solve(current, p0, cand, strategy, kappa, alpha_chi2, max_nfev, progress, history)
        outliers = find_outliers(res.problem, res.after, alpha_outlier)
        if not reject or not outliers:
            break
        drop = sorted({p for o in outliers for p in o.poses})
        rejected += list(outliers)
        current = current.without_poses(drop)
        if not current.constraints:
            raise CalibrationError("every observation was rejected as an outlier")
    else:
        notes.append(f"outlier rejection stopped after {_MAX_REJECT_ROUNDS} rounds")
    if strategy == "fix" and res.held:
        notes.append(
            "held at their start values (unobservable from these data): " + ", ".join(res.held)
        )
    return dataclasses.replace(
        res,
        outliers=outliers,
        rejected=tuple(rejected),
        history=tuple(history),
        elapsed_s=time.perf_counter() - t0,
        notes=tuple(notes),
    )


def _solve(
    obs: Observations,
    p0: Params,
    cand: list[int],
    strategy: str,
    kappa: float,
    alpha_chi2: float,
    max_nfev: int,
    progress: Callable[[Progress], None] | None,
    history: list[Progress],
) -> CalibrationResult:
    problem = Problem(obs)
    before = problem.evaluate(p0)
    ident0 = analyse(before, cand, kappa)
    if ident0.rank == 0:
        raise CalibrationError("the data identify no parameter (rank 0)")
    ident = ident0
    v0 = p0.to_vector()
    p = v0.copy()
    status = ""
    stages = 0
    basis = np.zeros((25, 0))
    for stage in range(1, _MAX_STAGES + 1):
        stages = stage
        basis, held = _stage_basis(ident, cand, strategy)
        if strategy == "fix":
            for n in held:
                k = PARAM_NAMES.index(n)
                p[k] = v0[k]  # never move an unobservable parameter
        solver = _Solver(problem, p, basis, stage, progress, history)
        x, status = solver.run(max_nfev)
        p = solver.base + basis @ x
        ev = problem.evaluate(Params.from_vector(p))
        new = analyse(ev, cand, kappa)
        settled = new.rank == ident.rank and (strategy != "fix" or new.held == ident.held)
        ident = new
        if settled:
            break
    if strategy == "min-norm":
        # remove any drift along the null space at the solution, polish in the identifiable
        # subspace; repeat while the (parameter-dependent) null space still moves
        cols = list(ident.columns)
        for _ in range(4):
            dz = (p - v0)[cols] * ident.scale
            drift = ident.null_basis @ (ident.null_basis.T @ dz)
            if np.linalg.norm(drift) <= 1e-13 * max(float(np.linalg.norm(dz)), 1e-300):
                break
            p[cols] -= drift / ident.scale
            basis, _ = _stage_basis(ident, cand, strategy)
            stages += 1
            solver = _Solver(problem, p, basis, stages, progress, history)
            x, status = solver.run(max_nfev)
            p = solver.base + basis @ x
            ident = analyse(problem.evaluate(Params.from_vector(p)), cand, kappa)
    params = Params.from_vector(p)
    after = problem.evaluate(params)
    basis, held = _stage_basis(ident, cand, strategy)
    cov = _covariance(after, basis)
    chi = _chi_square(problem, after, basis, ident.rank, alpha_chi2)
    free = [PARAM_NAMES[c] for c in cand if strategy != "fix" or PARAM_NAMES[c] not in held]
    return CalibrationResult(
        params=params,
        start=p0,
        strategy=strategy,
        free=tuple(free),
        held=held,
        fixed=tuple(n for n in PARAM_NAMES if PARAM_NAMES.index(n) not in cand),
        identifiability=ident,
        identifiability_start=ident0,
        covariance=cov,
        chi_square=chi,
        outliers=(),
        rejected=(),
        before=before,
        after=after,
        observations=obs,
        problem=problem,
        history=(),
        elapsed_s=0.0,
        stages=stages,
        solver_status=status,
    )


def predicted_covariance(
    obs: Observations, params: Params | None = None, free: Sequence[str] | None = None
) -> tuple[FloatArray, Identifiability]:
    """The covariance a calibration on ``obs`` would give, without solving.

    Evaluated at ``params`` (default Table 1) as if the data were consistent
    with it (the rank judged with the rounding floor only): for planning
    poses and for tolerance allocation. Returns the (25, 25) covariance (held
    parameters zero) and the identifiability it rests on.
    """
    problem = Problem(obs)
    ev = problem.evaluate(params or Params())
    ev_ideal = dataclasses.replace(ev, r=np.zeros_like(ev.r))
    ident = analyse(ev_ideal, _candidates(free, ()))
    basis, _ = _stage_basis(ident, _candidates(free, ()), "fix")
    return _covariance(ev, basis), ident


def length_observations(obs: Observations) -> list[tuple[int, LengthSet]]:
    """The length sets of ``obs`` with their constraint indices."""
    return [(i, c) for i, c in enumerate(obs.constraints) if isinstance(c, LengthSet)]
