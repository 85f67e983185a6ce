"""Encoder angle harmonics in a calibration (issue 27): what DH cannot describe.

Per joint ``j`` the reading ``q`` becomes ``q + sum_k (c_k cos kq + s_k sin kq)``,
``k = 1 .. K_j``, ``K_j <= 4`` (:mod:`aacmm.errmodel`, the C core's error model).
:func:`aacmm.calibration.calibrate` with ``harmonics=K`` estimates the
coefficients with the arm's parameters: they follow the arm's P parameters as
``c<j>_<k>``, ``s<j>_<k>`` (rad), the columns of
:func:`aacmm.errmodel.points_jacobians`, and go through the same
identifiability analysis, covariance and chi-square check.

There is no ``k = 0`` term: a constant angle error is the joint's theta
offset. A joint that moves over a limited range sees ``cos kq`` and ``sin kq``
there nearly as a constant and a slope, which its theta offset and the other
parameters take up: such terms are named *weakly observed* (a small
:attr:`~aacmm.calibration.results.ErrorTerm.observability`) or, in the data's
null space, *unobserved* and held at 0. A joint whose angle does not move the
probe point (the last joint with the tip on its axis) cannot show any harmonic:
its terms are left out of the model.

Main names: :data:`AUTO`, :func:`parse_harmonics`, :func:`start_params`,
:func:`observability`, :func:`screen`, :func:`choose_auto`, :func:`error_terms`,
:func:`dh_part`. Used by :mod:`aacmm.calibration.solve`; nothing printed.

Errors: :func:`parse_harmonics` raises ValueError for K outside 0 .. 4 or a list
of the wrong length.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from aacmm.calibration.identifiability import Identifiability, analyse
from aacmm.calibration.parameters import (
    ArmParams,
    CalibParams,
    arm_part,
    n_joints,
    param_names,
)
from aacmm.calibration.problem import Evaluation, Problem
from aacmm.calibration.results import (
    TERM_ESTIMATED,
    TERM_UNOBSERVED,
    TERM_WEAK,
    CalibrationResult,
    ErrorTerm,
)
from aacmm.core import FloatArray
from aacmm.errmodel import HARMONICS_MAX, ErrorModel

__all__ = [
    "AUTO",
    "SIGNIFICANCE_CHI2",
    "WEAK_OBSERVABILITY",
    "AutoChoice",
    "check_harmonics_option",
    "choose_auto",
    "dh_part",
    "error_terms",
    "harmonic_names",
    "observability",
    "parse_harmonics",
    "screen",
    "start_params",
    "wald_chi2",
]

#: ``harmonics="auto"``: per joint the largest K (up to 4) the data identify and the
#: fit finds significant (:func:`choose_auto`).
AUTO = "auto"
#: A term whose observability is below this is *weakly observed* (and ``auto``
#: does not take it): less than 3 % of its effect on the probe points is its own.
WEAK_OBSERVABILITY = 0.03
#: A term whose whole effect on the probe points (its scaled column) is below
#: this share of the largest column's is outside the model (no effect at all).
_DEAD = 1e-9


def parse_harmonics(spec: int | str | Sequence[int], joints: int) -> tuple[int, ...] | None:
    """K per joint (N,) from an int 0 .. 4 (every joint), a sequence of N ints, or a
    string (``"auto"``: None; ``"2"``, ``"2,2,1,1,0,0"``).

    Raises ValueError for K outside 0 .. 4 or a list without N values.
    """
    if isinstance(spec, str):
        text = spec.strip().lower()
        if text == AUTO:
            return None
        try:
            items = [int(x) for x in text.split(",")]
        except ValueError:
            raise ValueError(
                f"harmonics must be {AUTO!r}, 0 .. {HARMONICS_MAX} or one per joint "
                f"(comma list), got {spec!r}"
            ) from None
        return parse_harmonics(items[0] if len(items) == 1 else items, joints)
    if isinstance(spec, (int, np.integer)) and not isinstance(spec, bool):
        ks = (int(spec),) * joints
    else:
        ks = tuple(int(k) for k in spec)  # type: ignore[union-attr]
        if len(ks) != joints:
            raise ValueError(f"harmonics: {len(ks)} values for an arm of {joints} joints")
    bad = [k for k in ks if not 0 <= k <= HARMONICS_MAX]
    if bad:
        raise ValueError(f"harmonics must be 0 .. {HARMONICS_MAX} per joint, got {bad[0]}")
    return ks


def check_harmonics_option(text: str) -> str:
    """A command line's K for every joint: ``"0"`` .. ``"4"`` or ``"auto"``, normalised.

    Raises ValueError (one line) for anything else (a negative K, K > 4, text).
    """
    t = str(text).strip().lower()
    if t == AUTO:
        return t
    try:
        k = int(t)
    except ValueError:
        k = -1
    if not 0 <= k <= HARMONICS_MAX or not t.lstrip("+").isdigit():
        raise ValueError(f"K must be 0 .. {HARMONICS_MAX} or {AUTO!r}, got {text!r}")
    return str(k)


def harmonic_names(ks: Sequence[int]) -> tuple[str, ...]:
    """The coefficient names of K per joint: ``c<j>_<k>``, ``s<j>_<k>``, joint after joint."""
    return tuple(
        f"{w}{j}_{h}" for j, k in enumerate(ks, start=1) for h in range(1, k + 1) for w in "cs"
    )


def start_params(start: ArmParams | CalibParams, ks: Sequence[int]) -> CalibParams:
    """The arm of ``start`` with K per joint ``ks``: the start's own coefficients
    where it has them (a :class:`CalibParams`, its link CTEs too), 0 elsewhere."""
    arm = arm_part(start)
    old = start.errors.harmonics if isinstance(start, CalibParams) else ((),) * len(ks)
    hs = tuple(
        tuple(h[i] if i < len(h) else (0.0, 0.0) for i in range(k))
        for h, k in zip(old, ks, strict=True)
    )
    if isinstance(start, CalibParams):  # its link CTEs (and their columns) as they are
        e = start.errors
        return CalibParams(arm, ErrorModel(hs, e.cte_per_k, e.tref_c, e.cte_columns))
    return CalibParams(arm, ErrorModel(hs))


def observability(ev: Evaluation, ident: Identifiability) -> dict[str, float]:
    """Per free parameter (those of ``ident`` not held): the share of its effect on
    the probe points that no other free parameter or nuisance unknown takes up,
    ``1 / sqrt((A^T A)^-1_ii)`` of the column-scaled Jacobian A (0 .. 1)."""
    held = set(ident.held)
    cols = [c for c, n in zip(ident.columns, ident.names, strict=True) if n not in held]
    if not cols:
        return {}
    names = param_names(ev.params)
    raw = np.sqrt(ev.raw_norm2[cols])
    a = ev.jac[:, cols] / raw
    r = np.linalg.qr(a, mode="r")
    try:
        rinv = np.linalg.inv(r)
    except np.linalg.LinAlgError:
        rinv = np.linalg.pinv(r)
    diag = np.einsum("ij,ij->i", rinv, rinv)  # diag of (A^T A)^-1
    return {
        names[c]: float(1.0 / np.sqrt(d)) if d > 0 else 0.0 for c, d in zip(cols, diag, strict=True)
    }


def screen(ev: Evaluation, ks: Sequence[int]) -> tuple[tuple[int, ...], tuple[str, ...]]:
    """K per joint cut to the terms that move the probe point at all, and the names
    of those left out (a joint whose angle does not move the tip: every term).

    ``ev``: an evaluation at a :class:`CalibParams` with K per joint ``ks``.
    """
    names = param_names(ev.params)
    raw = np.sqrt(ev.raw_norm2)
    top = float(raw.max()) if raw.size else 0.0
    out = list(ks)
    dead: list[str] = []
    for j, k in enumerate(ks, start=1):
        for h in range(1, k + 1):
            if any(raw[names.index(f"{w}{j}_{h}")] <= _DEAD * top for w in ("c", "s")):
                out[j - 1] = min(out[j - 1], h - 1)
        dead += [f"{w}{j}_{h}" for h in range(out[j - 1] + 1, k + 1) for w in ("c", "s")]
    return tuple(out), tuple(dead)


#: ``auto`` takes harmonic order k of a joint only if the pair (c_k, s_k) differs
#: from 0 by more than this chi-square quantile (2 degrees of freedom, 99.9 %:
#: a false order in about 1 of 1000 tests) in the trial fit's covariance.
SIGNIFICANCE_CHI2 = 13.8155


@dataclasses.dataclass(frozen=True)
class AutoChoice:
    """``harmonics="auto"``'s answer: K per joint and, per joint, why it stopped there."""

    ks: tuple[int, ...]
    reasons: tuple[str, ...]

    def text(self) -> str:
        """``joint 1: K 2 (k = 3 not significant, chi^2 1.2 < 13.8); ...``."""
        return "; ".join(
            f"joint {j}: K {k} ({why})"
            for j, (k, why) in enumerate(zip(self.ks, self.reasons, strict=True), start=1)
        )


def wald_chi2(res: CalibrationResult[Any], joint: int, order: int) -> float:
    """How far the pair (c, s) of ``joint`` (from 1) and harmonic ``order`` is from 0
    in the covariance of the stated uncertainties (unscaled): ``v^T C^-1 v``
    (chi-square with 2 degrees of freedom when it is 0); 0 for a pair not
    estimated."""
    names = param_names(res.params)
    pair = [f"{w}{joint}_{order}" for w in ("c", "s")]
    if not all(n in names and n in res.free for n in pair):
        return 0.0
    idx = [names.index(n) for n in pair]
    v = res.params.to_vector()[idx]
    # the stated uncertainties, not scaled up by what the trial model still misses
    cov = res.covariance[np.ix_(idx, idx)]
    try:
        return float(v @ np.linalg.solve(cov, v))
    except np.linalg.LinAlgError:
        return 0.0


def choose_auto(
    problem: Problem,
    start: ArmParams | CalibParams,
    cand: Sequence[str],
    kappa: float,
    fit: Callable[[CalibParams], CalibrationResult[Any]] | None = None,
) -> AutoChoice:
    """``harmonics="auto"``: per joint the largest K <= 4 whose terms are all
    identified (estimated, not weakly observed) with those of the other joints
    and, with ``fit`` (a calibration from a start with given K), significant: the
    pair of order k differs from 0 (:func:`wald_chi2` above
    :data:`SIGNIFICANCE_CHI2`, in the covariance of the stated uncertainties:
    scaled by the trial's chi-square, the orders it still lacks would hide
    themselves) in the fit with order k on every joint still growing. The
    harmonics are added one order at a time for every joint still growing; a
    joint stops at its first order not identified, or after two orders in a row
    not significant (one order may be small where the next is not), K being its
    last significant order. Then each joint's highest order is tested again in the
    fit with every chosen order, against the scatter that fit leaves
    (:func:`_against_the_scatter`: the Wald chi-square over chi^2/dof when the
    model is still refuted, as with coarse encoders), and dropped if it fails.

    ``cand``: the arm's parameter names to estimate (the harmonics are added).
    """
    joints = n_joints(start)
    ks = [0] * joints
    growing = [True] * joints
    why = [f"the most the model takes (K <= {HARMONICS_MAX})"] * joints
    misses: list[list[tuple[int, float]]] = [[] for _ in range(joints)]
    for h in range(1, HARMONICS_MAX + 1):
        trial = [h if g else k for k, g in zip(ks, growing, strict=True)]
        if trial == ks:
            break
        p0 = start_params(start, trial)
        ev = problem.evaluate(p0)
        cut, _ = screen(ev, trial)
        kept = set(cand) | set(harmonic_names(cut))
        cols = [i for i, n in enumerate(param_names(p0)) if n in kept]
        ident = analyse(ev, cols, kappa)
        obs = observability(ev, ident)
        identified = list(ks)
        for j in range(joints):
            if not growing[j]:
                continue
            terms = [f"{w}{j + 1}_{i}" for i in range(1, h + 1) for w in ("c", "s")]
            if cut[j] >= h and all(obs.get(t, 0.0) >= WEAK_OBSERVABILITY for t in terms):
                identified[j] = h
                continue
            growing[j] = False
            if cut[j] < h:
                why[j] = (
                    "its angle does not move the probe point"
                    if h == 1
                    else f"k = {h} does not move the probe point"
                )
            else:
                low = min(obs.get(t, 0.0) for t in terms)
                why[j] = (
                    f"k = {h} weakly observed, observability {low:.3g} < {WEAK_OBSERVABILITY:g}"
                )
            if misses[j]:
                why[j] = f"{_not_significant(misses[j])}; {why[j]}"
        if fit is None:
            ks = identified
            continue
        if not any(k == h for k in identified):
            break
        res = fit(start_params(start, identified))
        for j in range(joints):
            if identified[j] != h:
                continue
            chi2 = wald_chi2(res, j + 1, h)
            if chi2 >= SIGNIFICANCE_CHI2:
                ks[j] = h
                misses[j] = []
                continue
            # one order may be small where the next is not (an encoder's k = 2
            # without much k = 1): a joint stops after two insignificant orders
            misses[j].append((h, chi2))
            if len(misses[j]) == 2 or h == HARMONICS_MAX:
                growing[j] = False
                why[j] = _not_significant(misses[j])
    if fit is not None:
        ks = _against_the_scatter(start, ks, why, fit)
    return AutoChoice(tuple(ks), tuple(why))


def _against_the_scatter(
    start: ArmParams | CalibParams,
    ks: list[int],
    why: list[str],
    fit: Callable[[CalibParams], CalibrationResult[Any]],
) -> list[int]:
    """The orders chosen, each tested again in the fit with all of them, against the
    scatter that fit leaves: the Wald chi-square divided by its chi^2/dof when above 1.
    Where the residuals stay far above the stated uncertainties with every chosen order
    (coarse encoders' quantisation, no harmonic), terms that are only significant
    against the stated uncertainties are noise fitted; the highest order of each joint
    that fails is dropped and the rest tested again. ``why`` is updated in place."""
    ks = list(ks)
    for _ in range(HARMONICS_MAX * len(ks)):
        if not any(ks):
            break
        res = fit(start_params(start, ks))
        ratio = res.chi_square.ratio
        if not (math.isfinite(ratio) and ratio > 1.0):
            break
        dropped = False
        for j, k in enumerate(ks):
            if k == 0:
                continue
            chi2 = wald_chi2(res, j + 1, k) / ratio
            if chi2 < SIGNIFICANCE_CHI2:
                ks[j] = k - 1
                why[j] = (
                    f"k = {k} not significant against the residual scatter (chi^2 {chi2:.3g} "
                    f"< {SIGNIFICANCE_CHI2:.1f} with chi^2/dof {ratio:.3g})"
                )
                dropped = True
        if not dropped:
            break
    return ks


def _not_significant(misses: Sequence[tuple[int, float]]) -> str:
    """``k = 3, 4 not significant, chi^2 0.4, 1.2 < 13.8``."""
    orders = ", ".join(str(k) for k, _ in misses)
    values = ", ".join(f"{x:.1f}" for _, x in misses)
    return f"k = {orders} not significant, chi^2 {values} < {SIGNIFICANCE_CHI2:.1f}"


def error_terms(
    res: CalibrationResult[Any], requested: Sequence[int], dead: Sequence[str]
) -> tuple[ErrorTerm, ...]:
    """Every harmonic term asked for (``requested``: K per joint), with its value,
    reported uncertainty, observability and status; ``dead``: the terms left out
    of the model (no effect on the probe point)."""
    names = param_names(res.params)
    v = res.params.to_vector()
    sd = res.scaled_std
    obs = observability(res.after, res.identifiability)
    out = []
    for j, k in enumerate(requested, start=1):
        for h in range(1, k + 1):
            for w in ("c", "s"):
                n = f"{w}{j}_{h}"
                if n in dead or n not in names:
                    out.append(ErrorTerm(n, j, h, 0.0, 0.0, 0.0, TERM_UNOBSERVED, False))
                    continue
                i = names.index(n)
                o = obs.get(n, 0.0)
                if n not in res.free:
                    status = TERM_UNOBSERVED
                else:
                    status = TERM_ESTIMATED if o >= WEAK_OBSERVABILITY else TERM_WEAK
                out.append(ErrorTerm(n, j, h, float(v[i]), float(sd[i]), o, status))
    return tuple(out)


def dh_part(res: CalibrationResult[Any]) -> CalibrationResult[Any]:
    """The arm's part of a calibration with harmonics: the arm's parameters, their
    (marginal) covariance, the arm's free, held and fixed names; the rest as it is
    (the residuals are those of the whole model). ``res`` itself without harmonics.

    For the consumers that take an arm only (the quality gate's predicted
    accuracy, the propagated point uncertainty, the figures): the covariance
    block is the arm's uncertainty with the harmonics estimated alongside.
    """
    if not isinstance(res.params, CalibParams):
        return res
    arm_names = set(param_names(res.params.arm))
    p = len(arm_names)

    def keep(names: tuple[str, ...]) -> tuple[str, ...]:
        return tuple(n for n in names if n in arm_names)

    cov: FloatArray = res.covariance[:p, :p].copy()
    return dataclasses.replace(
        res,
        params=res.params.arm,
        start=arm_part(res.start),
        free=keep(res.free),
        held=keep(res.held),
        fixed=keep(res.fixed),
        covariance=cov,
    )
