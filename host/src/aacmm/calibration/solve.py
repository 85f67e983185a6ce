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
   joint, as encoder eccentricity gives) (:mod:`aacmm.calibration.diagnostics`);
5. with ``harmonics`` (issue 27), the encoder angle harmonics ``c<j>_<k>``,
   ``s<j>_<k>`` are parameters too, after the arm's (a
   :class:`~aacmm.calibration.parameters.CalibParams`; steps 1 to 4 unchanged
   over P + E columns; :mod:`aacmm.calibration.harmonics`);
6. outliers: each probed point (or length position) is tested with its
   normalised residual against a family-wise false-alarm rate
   (:func:`~aacmm.calibration.diagnostics.find_outliers`); flagged points
   are only excluded (and the solve repeated) when ``reject=True``.

The result types (:class:`CalibrationResult` and its parts) are in
:mod:`aacmm.calibration.results`, the checks in
:mod:`aacmm.calibration.diagnostics`; the public names of all three are in
:mod:`aacmm.calibration`.
Nothing here prints: progress goes to an optional callback.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from typing import Any, overload

import numpy as np
from scipy import optimize

from aacmm.arm import Arm
from aacmm.calibration.diagnostics import (
    DEFAULT_ALPHA_CHI2,
    DEFAULT_ALPHA_OUTLIER,
    chi_square_check,
    find_outliers,
    parameter_covariance,
)
from aacmm.calibration.features import CalibrationError
from aacmm.calibration.harmonics import (
    choose_auto,
    error_terms,
    parse_harmonics,
    screen,
    start_params,
)
from aacmm.calibration.identifiability import DEFAULT_KAPPA, Identifiability, analyse
from aacmm.calibration.observations import LengthSet, Observations
from aacmm.calibration.parameters import (
    AnyParams,
    ArmParams,
    CalibParams,
    arm_part,
    hayati_held,
    n_joints,
    param_names,
    tip_columns,
    validate,
    with_vector,
)
from aacmm.calibration.problem import Evaluation, Problem, Residuals
from aacmm.calibration.results import (
    CalibrationResult,
    Outlier,
    Progress,
)
from aacmm.calibration.thermal import thermal_choice, thermal_outcome, unobserved_ctes, with_ctes
from aacmm.core import PARAM_GROUPS, FloatArray, Params

__all__ = [
    "STRATEGIES",
    "calibrate",
    "length_observations",
    "parse_names",
    "predicted_covariance",
]

STRATEGIES = ("fix", "min-norm")
_MAX_STAGES = 5
_MAX_REJECT_ROUNDS = 4


def parse_names(names: Sequence[str], params: AnyParams | None = None) -> tuple[str, ...]:
    """Parameter names from names and groups (``theta``, ``alpha``, ``d``, ``a``,
    ``beta``, ``tip`` = theta6 alpha6 d6 a6 l, ``all``; with encoder harmonics
    also ``harmonics``, with link CTE columns ``cte``), comma lists allowed; in
    column order. The names are those of ``params`` (default: the paper's arm;
    for any arm ``tip`` is :func:`~aacmm.calibration.parameters.tip_columns`).

    Raises ValueError for an unknown name.
    """
    p = params if params is not None else Params()
    all_names = param_names(p)
    tip = set(tip_columns(p))
    groups = {g: {n for n in all_names if n.rstrip("0123456789") == g} for g in PARAM_GROUPS[:4]}
    groups["beta"] = {n for n in all_names if n.startswith("beta")}
    if isinstance(p, CalibParams):
        groups["harmonics"] = {n for n in p.errors.param_names if not n.startswith("cte")}
        if p.errors.cte_columns:
            groups["cte"] = {n for n in p.errors.param_names if n.startswith("cte")}
    out: set[str] = set()
    for item in names:
        for n in (x.strip() for x in str(item).split(",")):
            if not n:
                continue
            if n in all_names:
                out.add(n)
            elif n in groups and (groups[n] or n != "beta"):
                out |= groups[n]
            elif n == "tip":
                out |= tip
            elif n == "all":
                out |= set(all_names)
            else:
                raise ValueError(f"unknown parameter {n!r} ({_name_help(arm_part(p))})")
    return tuple(n for n in all_names if n in out)


def _name_help(p: ArmParams) -> str:
    if isinstance(p, Params):
        return "theta1..6, alpha1..6, d1..6, a1..6, l, or a group: theta, alpha, d, a, tip, all"
    n = len(p.joints)
    tip = "tx, ty, tz" if p.tip == "xyz" else "l"
    betas = "".join(f", beta{j + 1}" for j in p.beta_joints)
    beta = ", beta" if betas else ""
    return (
        f"theta1..{n}, alpha1..{n}, d1..{n}, a1..{n}{betas}, {tip}, or a group: theta, "
        f"alpha, d, a{beta}, tip, all"
    )


class _Solver:
    """One least-squares run over a parametrisation x -> P parameters (of ``template``'s kind)."""

    def __init__(
        self,
        problem: Problem,
        template: AnyParams,
        base: FloatArray,
        basis: FloatArray,
        stage: int,
        progress: Callable[[Progress], None] | None,
        history: list[Progress],
    ) -> None:
        self.problem = problem
        self.template = template
        self.base = base  # (P,)
        self.basis = basis  # (P, k): dp = basis @ x
        self.stage = stage
        self.progress = progress
        self.history = history
        self._key: bytes | None = None
        self._ev: Evaluation | None = None
        self._rkey: bytes | None = None
        self._res: Residuals | None = None
        self.nfev = 0

    def params(self, x: FloatArray) -> AnyParams:
        try:
            return with_vector(self.template, self.base + self.basis @ x)
        except ValueError as e:  # harmonics the error model refuses (beyond 0.1 rad)
            raise CalibrationError(f"error model out of range during the fit: {e}") from None

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
    ident: Identifiability, candidates: Sequence[int], strategy: str, names: Sequence[str]
) -> tuple[FloatArray, tuple[str, ...]]:
    """The parametrisation (P, k) of a stage and the parameters it holds (``names``: all P)."""
    p = len(names)
    scale = np.zeros(p)
    scale[list(ident.columns)] = ident.scale
    if strategy == "fix":
        held = set(ident.held)
        cols = [c for c in candidates if names[c] not in held]
        b = np.zeros((p, len(cols)))
        for j, c in enumerate(cols):
            b[c, j] = 1.0 / scale[c]  # x in mm at the tip
        return b, ident.held
    b = np.zeros((p, ident.rank))
    b[list(ident.columns), :] = ident.basis / ident.scale[:, None]
    return b, ()


def _candidates(free: Sequence[str] | None, fix: Sequence[str], params: AnyParams) -> list[int]:
    """The columns to estimate: ``free`` (default all but the d a Hayati beta replaces,
    :func:`~aacmm.calibration.parameters.hayati_held`; the encoder harmonics of a
    :class:`CalibParams` always) less ``fix``."""
    all_names = param_names(params)
    names = (
        parse_names(free, params)
        if free is not None
        else tuple(n for n in all_names if n not in hayati_held(params))
    )
    if isinstance(params, CalibParams) and free is not None:
        names = (*names, *params.errors.param_names)
    fixed = set(parse_names(fix, params))
    cols = [all_names.index(n) for n in names if n not in fixed]
    if not cols:
        raise ValueError("no parameter left free to calibrate")
    return cols


@overload
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
    harmonics: int | str | Sequence[int] | None = None,
    thermal: bool | str = "auto",
) -> CalibrationResult[Params]: ...
@overload
def calibrate(
    obs: Observations,
    start: Arm,
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
    harmonics: int | str | Sequence[int] | None = None,
    thermal: bool | str = "auto",
) -> CalibrationResult[Arm]: ...
@overload
def calibrate(
    obs: Observations,
    start: CalibParams,
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
    harmonics: int | str | Sequence[int] | None = None,
    thermal: bool | str = "auto",
) -> CalibrationResult[CalibParams]: ...
@overload
def calibrate(
    obs: Observations,
    start: AnyParams | None = None,
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
    harmonics: int | str | Sequence[int] | None = None,
    thermal: bool | str = "auto",
) -> CalibrationResult[Any]: ...
def calibrate(
    obs: Observations,
    start: AnyParams | None = None,
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
    harmonics: int | str | Sequence[int] | None = None,
    thermal: bool | str = "auto",
) -> CalibrationResult[Any]:
    """Identify the arm's parameters from ``obs``, starting at ``start`` (default Table 1).

    ``start`` is a :class:`~aacmm.core.Params` (the paper's arm; the result's
    parameters are Params) or any :class:`~aacmm.arm.Arm` (the result is an
    arm of the same shape; its joint count must be the observations').
    ``free``/``fix``: parameter names or groups to estimate / hold (default:
    all P free but the d of each joint that declares a Hayati beta, which the
    beta replaces); ``strategy``: ``fix`` or ``min-norm`` for the unobservable
    directions (see the module doc); ``reject``: exclude outliers and solve
    again (otherwise they are only reported).

    ``harmonics``: the encoder angle harmonics to estimate with the arm
    (:mod:`aacmm.calibration.harmonics`): K = 0 .. 4 for every joint, one K per
    joint, or ``"auto"`` (per joint the largest K the data identify); default
    (None): 0 for an arm, the start's own K for a
    :class:`~aacmm.calibration.parameters.CalibParams` (whose coefficients are
    the start values). With harmonics (or a :class:`CalibParams` start) the
    result's parameters are a :class:`CalibParams` and its ``error_terms`` say
    which terms were estimated, weakly observed or unobserved; K = 0 for an arm
    is the arm alone, exactly as without it.

    ``thermal`` (issue 27): estimate each link's coefficient of thermal
    expansion ``cte<i>`` (1/K, reference temperature 20 degC, or the start
    error model's) with the arm, from the observations' link temperatures
    (:attr:`Observations.temp_c`): ``"auto"`` (default) when they span at
    least :data:`~aacmm.calibration.thermal.THERMAL_SPAN_C` (5 degC),
    ``True`` whenever they are stated, ``False`` never. A CTE is confounded
    with its link's lengths unless the temperatures differ: the
    identifiability analysis holds (and names) the ones the data do not
    identify. The result's ``thermal`` says what was done and why (its notes
    too, when temperatures were stated); without temperatures nothing changes.

    Raises ObservationError (bad data), CalibrationError (no solution: the
    parameters left the valid range, degenerate constraints), ValueError (bad
    arguments).
    """
    if strategy not in STRATEGIES:
        raise ValueError(f"strategy must be one of {', '.join(STRATEGIES)}, got {strategy!r}")
    p0: AnyParams = start or Params()
    validate(p0)
    t0 = time.perf_counter()

    def fit(p: AnyParams) -> CalibrationResult[Any]:  # auto's trial fits
        c = _candidates(free, fix, p)
        return _solve(obs, p, c, strategy, kappa, alpha_chi2, max_nfev, None, [])

    requested, modelled, dead, text, why = _harmonics(obs, p0, harmonics, free, fix, kappa, fit)
    if requested is not None:
        p0 = start_params(p0, modelled)
    estimate, thermal_text = thermal_choice(obs, thermal)
    fix_all = tuple(fix)
    unobserved: tuple[tuple[str, ...], tuple[str, ...]] = ((), ())
    if estimate:
        p0, no_length = with_ctes(obs, p0)
        fix_all += no_length
        unobserved = unobserved_ctes(obs, p0, _candidates(free, fix_all, p0), kappa)
        fix_all += unobserved[0] + unobserved[1]
    cand = _candidates(free, fix_all, p0)
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
    if why:
        notes.append(f"encoder harmonics, auto: {why}")
    if requested is None and text != "0":
        notes.append(f"encoder harmonics ({text}): none estimated")
    if requested is not None:
        ks = ", ".join(str(k) for k in requested)
        notes.append(f"encoder harmonics ({text}): K per joint {ks} asked for")
        if dead:
            notes.append(
                "left out of the model (the joint's angle does not move the probe point): "
                + ", ".join(dead)
            )
    out = dataclasses.replace(
        res,
        outliers=outliers,
        rejected=tuple(rejected),
        history=tuple(history),
        elapsed_s=time.perf_counter() - t0,
        notes=tuple(notes),
        harmonics_requested=text,
    )
    if requested is not None:
        out = dataclasses.replace(out, error_terms=error_terms(out, requested, dead))
    if estimate:
        thermal_text = thermal_outcome(out, unobserved)
    if thermal_text:
        out = dataclasses.replace(out, thermal=thermal_text)
        if obs.temp_c is not None:
            out = dataclasses.replace(out, notes=(*out.notes, thermal_text))
    return out


def _harmonics(
    obs: Observations,
    p0: AnyParams,
    harmonics: int | str | Sequence[int] | None,
    free: Sequence[str] | None,
    fix: Sequence[str],
    kappa: float,
    fit: Callable[[Any], CalibrationResult[Any]],
) -> tuple[tuple[int, ...] | None, tuple[int, ...], tuple[str, ...], str, str]:
    """K per joint asked for (None: the arm alone, as without harmonics), K per
    joint in the model, the terms left out (no effect on the probe point), how
    it was asked (for the notes) and, for ``auto``, why each joint's K (``fit``:
    its trial fits, :func:`~aacmm.calibration.harmonics.choose_auto`)."""
    joints = n_joints(p0)
    if harmonics is None:
        harmonics = list(p0.harmonics) if isinstance(p0, CalibParams) else 0
    ks = parse_harmonics(harmonics, joints)
    text = (
        harmonics.strip().lower()
        if isinstance(harmonics, str)
        else (str(harmonics) if isinstance(harmonics, int) else ",".join(str(k) for k in harmonics))
    )
    if ks is not None and not any(ks) and not isinstance(p0, CalibParams):
        return None, (), (), "0", ""
    problem = Problem(obs)
    why = ""
    if ks is None:
        arm = arm_part(p0)
        cand = [param_names(arm)[c] for c in _candidates(free, fix, arm)]
        choice = choose_auto(problem, p0, cand, kappa, fit)
        ks, why = choice.ks, choice.text()
        text = f"auto: the largest K the data identify, {','.join(str(k) for k in ks)}"
        if not any(ks) and not isinstance(p0, CalibParams):
            return None, (), (), text, why
    modelled, dead = screen(problem.evaluate(start_params(p0, ks)), ks)
    return ks, modelled, dead, text, why


def _solve(
    obs: Observations,
    p0: AnyParams,
    cand: list[int],
    strategy: str,
    kappa: float,
    alpha_chi2: float,
    max_nfev: int,
    progress: Callable[[Progress], None] | None,
    history: list[Progress],
) -> CalibrationResult[Any]:
    problem = Problem(obs)
    before = problem.evaluate(p0)
    ident0 = analyse(before, cand, kappa)
    if ident0.rank == 0:
        raise CalibrationError("the data identify no parameter (rank 0)")
    ident = ident0
    names = param_names(p0)
    v0 = p0.to_vector()
    p = v0.copy()
    status = ""
    stages = 0
    basis = np.zeros((len(names), 0))
    for stage in range(1, _MAX_STAGES + 1):
        stages = stage
        basis, held = _stage_basis(ident, cand, strategy, names)
        if strategy == "fix":
            for n in held:
                k = names.index(n)
                p[k] = v0[k]  # never move an unobservable parameter
        solver = _Solver(problem, p0, p, basis, stage, progress, history)
        x, status = solver.run(max_nfev)
        p = solver.base + basis @ x
        ev = problem.evaluate(with_vector(p0, p))
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
            basis, _ = _stage_basis(ident, cand, strategy, names)
            stages += 1
            solver = _Solver(problem, p0, p, basis, stages, progress, history)
            x, status = solver.run(max_nfev)
            p = solver.base + basis @ x
            ident = analyse(problem.evaluate(with_vector(p0, p)), cand, kappa)
    params = with_vector(p0, p)
    after = problem.evaluate(params)
    basis, held = _stage_basis(ident, cand, strategy, names)
    cov = parameter_covariance(after, basis)
    chi = chi_square_check(problem, after, basis, ident.rank, alpha_chi2)
    free = [names[c] for c in cand if strategy != "fix" or names[c] not in held]
    return CalibrationResult[Any](
        params=params,
        start=p0,
        strategy=strategy,
        free=tuple(free),
        held=held,
        fixed=tuple(n for k, n in enumerate(names) if k not in cand),
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
    obs: Observations, params: ArmParams | None = None, free: Sequence[str] | None = None
) -> tuple[FloatArray, Identifiability]:
    """The covariance a calibration on ``obs`` would give, without solving.

    Evaluated at ``params`` (default Table 1) as if the data were consistent
    with it (the rank judged with the rounding floor only): for planning
    poses and for tolerance allocation. Returns the (P, P) covariance (held
    parameters zero; 25 for the paper's arm) and the identifiability it rests on.
    """
    p0: ArmParams = params or Params()
    problem = Problem(obs)
    ev = problem.evaluate(p0)
    ev_ideal = dataclasses.replace(ev, r=np.zeros_like(ev.r))
    cand = _candidates(free, (), p0)
    ident = analyse(ev_ideal, cand)
    basis, _ = _stage_basis(ident, cand, "fix", param_names(p0))
    return parameter_covariance(ev, basis), ident


def length_observations(obs: Observations) -> list[tuple[int, LengthSet]]:
    """The length sets of ``obs`` with their constraint indices."""
    return [(i, c) for i, c in enumerate(obs.constraints) if isinstance(c, LengthSet)]
