"""Encoder grades of the simulated arm: what its encoders' reading errors are (issue 27).

An encoder reads joint angle ``theta`` as ``theta + e(theta)`` with a
periodic reading error ``e`` the DH model cannot describe, a sum of
harmonics of the joint's revolution::

    e(theta) = sum_k A_k sin(k theta + phi_k),  k = 1 .. K

(k = 1: a disc mounted off-centre; k = 2: an elliptic disc or a tilted head;
higher orders: the scale's own pattern errors). A grade says which orders an
encoder of that kind shows and how large they are; :func:`draw_harmonics`
draws one encoder's amplitudes (uniform in the grade's range per order) and
phases (uniform in 0 .. 2 pi) for every joint. docs/simulator.md, "Encoder
grades", is the table:

=========  =====================================================  ============================
grade      what                                                   amplitude, per order
=========  =====================================================  ============================
two-head   an optical disc read by two opposite heads: the        k = 1: 0.5-2 arcsec
           eccentricity mostly cancels (the default; the random
           truths of before grades existed)
one-head   an optical disc read by one head                       k = 1, 2: 10-30 arcsec each
magnetic   a magnetic ring encoder (a diametral magnet and a      k = 1..4: 0.02-0.1 deg each
           Hall sensor array)                                     (72-360 arcsec)
=========  =====================================================  ============================

Main names: :class:`EncoderGrade`, :data:`GRADES`, :data:`DEFAULT_GRADE`,
:func:`encoder_grade` (a grade by name; :class:`EncoderGradeError` for an
unknown one), :func:`draw_harmonics`; for the truth file's ``[harmonics]``
table :func:`harmonics_from_table`; :func:`harmonic_error_model` (harmonics
in the C core's error-model form, :class:`aacmm.errmodel.ErrorModel`).

Pure: no printing, no files; the simulated truth (:mod:`aacmm.simulation.truth`)
uses it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Final

import numpy as np

from aacmm.errmodel import ErrorModel
from aacmm.errors import AacmmError


class EncoderGradeError(AacmmError, ValueError):
    """An unknown encoder grade (exit status 2 in the CLI)."""


@dataclass(frozen=True)
class EncoderGrade:
    """A kind of encoder: the amplitude range (arcsec, uniform) of each harmonic
    order ``k = 1 .. K`` of its reading error (``amplitude_arcsec[k - 1]``)."""

    name: str
    description: str
    amplitude_arcsec: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        if not 1 <= len(self.amplitude_arcsec) <= 4:
            raise ValueError(f"grade {self.name}: 1 to 4 harmonic orders")
        for lo, hi in self.amplitude_arcsec:
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
                raise ValueError(f"grade {self.name}: amplitude range {lo}..{hi}")

    @property
    def orders(self) -> int:
        """K, the highest harmonic order (every order 1 .. K is drawn)."""
        return len(self.amplitude_arcsec)


DEG_ARCSEC: Final = 3600.0
_ARCSEC_RAD: Final = math.pi / (180.0 * 3600.0)

#: The grades of ``aacmm sim --encoder-grade`` (docs/simulator.md, "Encoder grades").
GRADES: Final[dict[str, EncoderGrade]] = {
    g.name: g
    for g in (
        EncoderGrade(
            "two-head",
            "optical disc, two opposite heads: residual eccentricity",
            ((0.5, 2.0),),
        ),
        EncoderGrade(
            "one-head",
            "optical disc, one head: eccentricity and its second harmonic",
            ((10.0, 30.0), (10.0, 30.0)),
        ),
        EncoderGrade(
            "magnetic",
            "magnetic ring encoder: harmonics 1 to 4",
            ((0.02 * DEG_ARCSEC, 0.1 * DEG_ARCSEC),) * 4,
        ),
    )
}
#: The grade of ``--truth random:SEED`` without ``--encoder-grade``.
DEFAULT_GRADE: Final = "two-head"


def encoder_grade(name: str) -> EncoderGrade:
    """The grade called ``name``.

    Raises:
        EncoderGradeError: no such grade (one line naming the known ones).
    """
    try:
        return GRADES[name]
    except KeyError:
        known = ", ".join(GRADES)
        raise EncoderGradeError(f"unknown encoder grade {name!r} (known: {known})") from None


@dataclass(frozen=True)
class Harmonics:
    """One arm's drawn reading errors: ``amplitude_arcsec[k - 1][i]`` and
    ``phase_rad[k - 1][i]`` are order k of joint i (k = 1 .. K)."""

    amplitude_arcsec: tuple[tuple[float, ...], ...]
    phase_rad: tuple[tuple[float, ...], ...]


def draw_harmonics(grade: EncoderGrade, rng: np.random.Generator, joints: int) -> Harmonics:
    """Every joint's harmonics of ``grade``, drawn order after order: for each
    k the N amplitudes (uniform in the grade's range), then the N phases
    (uniform in 0 .. 2 pi). Order 1 draws what the random truths drew before
    grades existed (so a two-head truth is the same arm as then)."""
    amps: list[tuple[float, ...]] = []
    phases: list[tuple[float, ...]] = []
    for lo, hi in grade.amplitude_arcsec:
        amps.append(tuple(float(v) for v in rng.uniform(lo, hi, joints)))
        phases.append(tuple(float(v) for v in rng.uniform(0.0, 2.0 * math.pi, joints)))
    return Harmonics(tuple(amps), tuple(phases))


def _numbers(name: str, row: Any, n: int, lo: float) -> tuple[float, ...]:
    if not isinstance(row, list) or len(row) != n:
        raise ValueError(f"{name} must be a list of {n} numbers")
    out = []
    for i, v in enumerate(row):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"{name}[{i}] must be a finite number, got {v!r}")
        if v < lo:
            raise ValueError(f"{name}[{i}]={v} must be >= {lo:g}")
        out.append(float(v))
    return tuple(out)


def harmonics_from_table(table: dict[str, Any], n: int) -> dict[str, Any]:
    """A truth file's ``[harmonics]`` table (``order``: increasing orders 2..4;
    ``amplitude_arcsec``, ``phase_rad``: one list of ``n`` numbers per order) as
    the ``harmonic_*`` fields of :class:`aacmm.simulation.truth.ErrorSources`.

    Raises:
        ValueError: a malformed table (the message names the key).
    """
    orders = table.get("order")
    if (
        not isinstance(orders, list)
        or not 1 <= len(orders) <= 3
        or any(isinstance(k, bool) or not isinstance(k, int) or not 2 <= k <= 4 for k in orders)
        or orders != sorted(set(orders))
    ):
        raise ValueError(f"harmonics.order must be increasing orders of 2..4, got {orders!r}")
    rows: dict[str, tuple[tuple[float, ...], ...]] = {}
    for key, lo in (("amplitude_arcsec", 0.0), ("phase_rad", -math.inf)):
        value = table.get(key)
        if not isinstance(value, list) or len(value) != len(orders):
            raise ValueError(
                f"harmonics.{key} must be {len(orders)} lists (one per order) of {n} numbers"
            )
        rows[key] = tuple(
            _numbers(f"harmonics.{key}[{j}]", row, n, lo) for j, row in enumerate(value)
        )
    return {
        "harmonic_orders": tuple(orders),
        "harmonic_arcsec": rows["amplitude_arcsec"],
        "harmonic_phase_rad": rows["phase_rad"],
    }


def harmonic_error_model(
    harmonics: dict[int, tuple[tuple[float, ...], tuple[float, ...]]],
) -> ErrorModel:
    """Reading-error harmonics ``{k: (amplitudes arcsec, phases rad)}`` (N values
    each) as the C core's error model: joint i's ``(c_k, s_k)`` in rad, k = 1 .. K
    (K the highest order given; a missing order is 0), from ``A sin(k q + phi) =
    A sin(phi) cos(kq) + A cos(phi) sin(kq)``; no thermal part."""
    top = max(harmonics)
    joints = len(next(iter(harmonics.values()))[0])
    zero = ((0.0,) * joints, (0.0,) * joints)
    out = []
    for i in range(joints):
        pairs = []
        for k in range(1, top + 1):
            amp, phase = harmonics.get(k, zero)
            a = amp[i] * _ARCSEC_RAD
            pairs.append((a * math.sin(phase[i]), a * math.cos(phase[i])))
        out.append(tuple(pairs))
    return ErrorModel(harmonics=tuple(out))
