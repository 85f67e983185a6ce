"""The link CTEs of a calibration (issue 27 item 3): whether to estimate them, the
start with their columns, and what the estimate gave.

:func:`~aacmm.calibration.solve.calibrate` (``thermal=``) uses these: the
observations' link temperatures (:attr:`Observations.temp_c`) decide
(:func:`thermal_choice`: ``"auto"`` from a span of :data:`THERMAL_SPAN_C`),
:func:`with_ctes` adds the N ``cte<i>`` columns to the start (a
:class:`~aacmm.calibration.parameters.CalibParams`), :func:`thermal_outcome`
words the result (identified with value and sigma, weakly observed, held as
confounded with the links' lengths, left out). Nothing here prints.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aacmm.calibration.harmonics import WEAK_OBSERVABILITY, observability
from aacmm.calibration.identifiability import analyse
from aacmm.calibration.observations import Observations
from aacmm.calibration.parameters import AnyParams, CalibParams, n_joints, param_names
from aacmm.calibration.problem import Problem
from aacmm.calibration.results import CalibrationResult
from aacmm.errmodel import ErrorModel

__all__ = ["THERMAL_SPAN_C", "thermal_choice", "thermal_outcome", "unobserved_ctes", "with_ctes"]

#: ``thermal="auto"`` estimates the link CTEs from link temperatures spanning at least this.
THERMAL_SPAN_C = 5.0


def thermal_choice(obs: Observations, thermal: bool | str) -> tuple[bool, str]:
    """Whether to estimate the link CTEs, and if not, why (the text of the notes)."""
    if thermal not in (True, False, "auto"):
        raise ValueError(f"thermal must be True, False or 'auto', got {thermal!r}")
    span = obs.temperature_span()
    if thermal is False:
        return False, "link CTEs: not estimated (not asked for)"
    if span is None:
        if thermal is True:
            raise ValueError("thermal=True needs the observations' link temperatures (temp_c)")
        return False, "link CTEs: not estimated (the observations state no link temperature)"
    if thermal == "auto" and span < THERMAL_SPAN_C:
        return False, (
            f"link CTEs: not estimated (the stated link temperatures span {span:.1f} degC, "
            f"at least {THERMAL_SPAN_C:g} degC needed)"
        )
    return True, ""


def with_ctes(obs: Observations, p0: AnyParams) -> tuple[CalibParams, tuple[str, ...]]:
    """``p0`` with the link CTE columns (start values: the start's CTEs, 0 for an arm;
    reference temperatures the start's, 20 degC for an arm), and the CTEs of links
    without a length (no effect on any probe point: fixed at the start value)."""
    if isinstance(p0, CalibParams):
        e = p0.errors
        cp = CalibParams(p0.arm, ErrorModel(e.harmonics, e.cte_per_k, e.tref_c, True))
    else:
        cp = CalibParams(p0, ErrorModel(((),) * n_joints(p0), cte_columns=True))
    ev = Problem(obs).evaluate(cp)
    names = param_names(cp)
    raw = np.sqrt(ev.raw_norm2)
    top = float(raw.max())
    dead = tuple(n for i, n in enumerate(names) if n.startswith("cte") and raw[i] <= 1e-9 * top)
    return cp, dead


def unobserved_ctes(
    obs: Observations, p0: CalibParams, cand: list[int], kappa: float
) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The CTEs among the columns ``cand`` the data do not measure at the start
    ``p0``: those not identified (confounded with their links' lengths) and those
    observed only weakly (under :data:`~aacmm.calibration.harmonics.WEAK_OBSERVABILITY`
    of their effect on the probe points their own). The calibration holds both at
    their start values (the data sheet's, when the start states one) for the whole
    fit: freed at a later stage, such a CTE takes up noise (hundreds of 1e-6/K, out
    of the core's and the wire's range)."""
    ev = Problem(obs).evaluate(p0)
    ident = analyse(ev, cand, kappa)
    share = observability(ev, ident)
    ctes = [n for n in param_names(p0) if n.startswith("cte")]
    held = tuple(n for n in ctes if n in ident.held)
    weak = tuple(n for n in ctes if share.get(n, 1.0) < WEAK_OBSERVABILITY)
    return held, weak


def thermal_outcome(
    res: CalibrationResult[Any],
    unobserved: tuple[tuple[str, ...], tuple[str, ...]] = ((), ()),
) -> str:
    """What the CTE estimate gave: the CTEs identified (with their values), weakly
    observed (:data:`~aacmm.calibration.harmonics.WEAK_OBSERVABILITY`, as for a
    harmonic term), held (not identified) or fixed (a link without a length);
    ``unobserved``: :func:`unobserved_ctes`, the CTEs the fit held at their start
    values from the start."""
    names = param_names(res.params)
    ctes = [n for n in names if n.startswith("cte")]
    share = observability(res.after, res.identifiability)
    free = [n for n in ctes if n in res.free]
    est = [n for n in free if share.get(n, 0.0) >= WEAK_OBSERVABILITY]
    not_identified, weak_start = unobserved
    weak_all = [n for n in ctes if n in weak_start or (n in free and n not in est)]
    held = [n for n in ctes if (n in res.held or n in not_identified) and n not in weak_all]
    fixed = [n for n in ctes if n in res.fixed and n not in weak_all and n not in held]
    span = res.observations.temperature_span() or 0.0
    parts = [f"link CTEs estimated from link temperatures spanning {span:.1f} degC"]
    if est:
        v, sd = res.params.to_vector(), res.scaled_std
        parts.append(
            "identified (1e-6/K, +- 1 sigma): "
            + ", ".join(
                f"{n} {v[names.index(n)] * 1e6:.2f} +- {sd[names.index(n)] * 1e6:.2f}" for n in est
            )
        )
    if weak_all:
        start = res.params.errors.cte_per_k
        parts.append(
            f"weakly observed (under {WEAK_OBSERVABILITY:.0%} of the effect on the probe "
            "points their own: the link barely has a length the data see), held at the "
            "start value (1e-6/K): "
            + ", ".join(f"{n} {start[int(n[3:]) - 1] * 1e6:.2f}" for n in weak_all)
        )
    if held:
        start = res.params.errors.cte_per_k
        parts.append(
            "not identified (confounded with their links' lengths at these temperatures; "
            "held at the start value, 1e-6/K): "
            + ", ".join(f"{n} {start[int(n[3:]) - 1] * 1e6:.2f}" for n in held)
        )
    if fixed:
        parts.append("left out (the link has no length): " + ", ".join(fixed))
    return "; ".join(parts)
