"""The error model (:class:`aacmm.errmodel.ErrorModel`) in a parameter set's wire fields.

The parameter set carries the error model in integer units (docs/protocol.md
2.3): harmonic coefficients in 1e-7 rad (|x| <= 3.2767 mrad), CTEs in 1e-8/K
(|x| <= 3.2767e-4 /K) and one reference temperature for every link in
0.01 degC (-40 .. 85). :func:`with_error_model` rounds an error model to
those units (to nearest) and refuses what they cannot carry;
:func:`error_model` gives the error model the device computes with, exactly
(the host's reference for a device's points: ``aacmm.errmodel.points``).

Errors: ValueError, one line naming the joint or link, for a value the wire
cannot carry (too large, NaN, per-link reference temperatures that differ)
or an error model of another joint count.
"""

from __future__ import annotations

import math
from dataclasses import replace

from aacmm.errmodel import ErrorModel
from aacmm.protocol.layout import REF_TEMP_MAX, REF_TEMP_MIN
from aacmm.protocol.payloads import ParamSet

__all__ = ["CTE_UNIT_PER_K", "HARMONIC_UNIT_RAD", "TEMP_UNIT_C", "error_model", "with_error_model"]

HARMONIC_UNIT_RAD = 1e-7
CTE_UNIT_PER_K = 1e-8
TEMP_UNIT_C = 0.01
_I16 = 32767


def _units(what: str, value: float, unit: float, lo: int = -_I16 - 1, hi: int = _I16) -> int:
    if not math.isfinite(value):
        raise ValueError(f"{what} must be finite, got {value}")
    v = round(value / unit)
    if not lo <= v <= hi:
        raise ValueError(
            f"{what} = {value:g} is beyond what the parameter set carries "
            f"({lo * unit:g} .. {hi * unit:g})"
        )
    return v


def with_error_model(ps: ParamSet, em: ErrorModel) -> ParamSet:
    """``ps`` with its error-model fields replaced by ``em`` rounded to the wire units.

    ``em`` must have ``ps``'s joint count. Without thermal expansion (every
    CTE 0 and every reference temperature 20 degC) the set has no thermal
    block; with it, every link must share one reference temperature. An error
    model that changes nothing gives ``ps`` without an error model (the same
    bytes as today's sets). ``em.cte_columns`` (a host calibration choice) is
    not carried.

    Raises:
        ValueError: another joint count, a value beyond the wire's range,
            reference temperatures that differ between links.
    """
    n = ps.joints
    if em.joints != n:
        raise ValueError(f"an error model of {em.joints} joints for a {n}-joint parameter set")
    rows_c = tuple(
        tuple(
            _units(f"joint {i + 1} c_{k + 1}", c, HARMONIC_UNIT_RAD) for k, (c, _) in enumerate(h)
        )
        for i, h in enumerate(em.harmonics)
    )
    rows_s = tuple(
        tuple(
            _units(f"joint {i + 1} s_{k + 1}", s, HARMONIC_UNIT_RAD) for k, (_, s) in enumerate(h)
        )
        for i, h in enumerate(em.harmonics)
    )
    thermal = any(x != 0.0 for x in em.cte_per_k) or any(t != 20.0 for t in em.tref_c)
    cte: tuple[int, ...] = ()
    ref = 0
    if thermal:
        if len(set(em.tref_c)) != 1:
            raise ValueError(
                "the parameter set carries one reference temperature for every link; the "
                f"error model has {', '.join(f'{t:g}' for t in em.tref_c)} degC"
            )
        cte = tuple(
            _units(f"link {i + 1} cte", x, CTE_UNIT_PER_K) for i, x in enumerate(em.cte_per_k)
        )
        ref = _units("reference temperature", em.tref_c[0], TEMP_UNIT_C, REF_TEMP_MIN, REF_TEMP_MAX)
    any_h = any(rows_c)
    return replace(
        ps,
        harm_cos=rows_c if any_h else (),
        harm_sin=rows_s if any_h else (),
        cte=cte,
        ref_temp=ref,
    )


def error_model(ps: ParamSet) -> ErrorModel:
    """The error model a device computes with for ``ps`` (the wire values in SI units:
    rad, 1/K, degC; every link at ``ref_temp``; ``ErrorModel.none`` for a set without
    one)."""
    n = ps.joints
    harm = tuple(
        tuple(
            (c * HARMONIC_UNIT_RAD, s * HARMONIC_UNIT_RAD)
            for c, s in zip(ps.harm_cos[i], ps.harm_sin[i], strict=True)
        )
        if ps.harm_cos
        else ()
        for i in range(n)
    )
    if not ps.cte:
        return ErrorModel(harmonics=harm)
    return ErrorModel(
        harmonics=harm,
        cte_per_k=tuple(x * CTE_UNIT_PER_K for x in ps.cte),
        tref_c=(ps.ref_temp * TEMP_UNIT_C,) * n,
    )
