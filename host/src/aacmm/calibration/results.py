"""What a calibration found: the result, its chi-square check, outliers, suspects, progress,
the encoder harmonics it estimated (:class:`ErrorTerm`).

Plain records, filled by :mod:`aacmm.calibration.solve`; public as names of
:mod:`aacmm.calibration`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Generic

import numpy as np

from aacmm.arm import Arm
from aacmm.calibration.identifiability import Identifiability
from aacmm.calibration.observations import Observations
from aacmm.calibration.parameters import CalibParams, param_names
from aacmm.calibration.problem import Evaluation, Problem
from aacmm.core import FloatArray, Params

if TYPE_CHECKING:  # the default (PEP 696) is for the type checker only
    from typing_extensions import TypeVar

    #: The kind of parameters a calibration works on: the paper's Params
    #: (the default), an Arm, or either with its encoder harmonics (CalibParams).
    P = TypeVar("P", Params, Arm, CalibParams, default=Params)
else:
    from typing import TypeVar

    P = TypeVar("P", Params, Arm, CalibParams)


#: The status of an encoder harmonic term (:class:`ErrorTerm`).
TERM_ESTIMATED = "estimated"
TERM_WEAK = "weakly observed"
TERM_UNOBSERVED = "unobserved"


@dataclass(frozen=True)
class ErrorTerm:
    """One encoder angle harmonic of a calibration: ``c<j>_<k>`` or ``s<j>_<k>``.

    ``joint`` and ``k`` from 1; ``value`` and ``std`` (rad; the reported,
    scaled uncertainty; 0 when not estimated); ``observability``: the share of
    the term's effect on the probe points that no other free parameter (and no
    nuisance unknown) can take up, 0 .. 1 (the column-scaled Jacobian's
    ``1 / sqrt((A^T A)^-1_ii)``; 0 for a term held or outside the model);
    ``status``: :data:`TERM_ESTIMATED`, :data:`TERM_WEAK` (estimated, but
    mostly confounded with other parameters: a joint that moves over a limited
    range sees ``cos kq`` and ``sin kq`` nearly as a constant, its theta
    offset, and a slope) or :data:`TERM_UNOBSERVED` (held at 0: in the data's
    null space, or no effect on the probe point at all); ``in_model``: the
    term is one of the calibration's parameters.
    """

    name: str
    joint: int
    k: int
    value: float
    std: float
    observability: float
    status: str
    in_model: bool = True


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
class CalibrationResult(Generic[P]):
    """Everything a calibration found.

    ``params``: calibrated parameters; ``start``: where it began (both the
    paper's :class:`~aacmm.core.Params` or both an :class:`~aacmm.arm.Arm`:
    ``CalibrationResult[Params]``, the default, or ``CalibrationResult[Arm]``).
    ``free``: parameters that were estimated; ``held``: parameters held at
    their start values because the data cannot observe them (auto, 'fix'
    strategy) and ``fixed``: those the caller fixed. ``identifiability`` (at
    the solution) and ``identifiability_start``; ``covariance`` (P, P; 25 for the paper's arm),
    rad and mm, from the stated uncertainties (a priori), zero for held and
    fixed parameters (:attr:`scaled_covariance` is the one to report: scaled
    by chi^2/dof when the check refutes the model); ``chi_square``;
    ``outliers`` found at the solution and ``rejected`` (excluded when
    ``reject=True``); ``before`` and ``after``: evaluations at start and
    solution; ``observations``: the data finally used. ``error_terms``: the
    encoder harmonics considered (empty without ``harmonics``; with it ``params``
    is a :class:`~aacmm.calibration.parameters.CalibParams`, P + E wide) and
    ``harmonics_requested``: what was asked for (``"0"``, ``"2"``, ``"auto"``, a
    per-joint list). ``thermal``: whether the link CTEs (``cte<i>`` of a
    :class:`~aacmm.calibration.parameters.CalibParams`) were estimated, which
    were identified, and if not, why (issue 27).
    """

    params: P
    start: P
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
    error_terms: tuple[ErrorTerm, ...] = ()
    harmonics_requested: str = "0"
    thermal: str = ""

    @property
    def std(self) -> FloatArray:
        """Standard uncertainties (P,) of the parameters (0 for held/fixed)."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    @property
    def correlation(self) -> FloatArray:
        """Correlation matrix (P, P); NaN rows/columns for held or fixed parameters."""
        sd = self.std
        with np.errstate(invalid="ignore", divide="ignore"):
            c = self.covariance / np.outer(sd, sd)
        c[sd == 0, :] = np.nan
        c[:, sd == 0] = np.nan
        return c

    @property
    def variance_factor(self) -> float:
        """chi^2/dof when the chi-square check refutes the model (verdict
        ``incomplete``), else 1: the factor the reported covariance carries.

        A refuted model means the residuals, not the stated probing
        uncertainty, tell how well the parameters are known: the a-posteriori
        variance factor scales the covariance (the standard uncertainties by
        its square root), as a least-squares adjustment with an unknown
        variance of unit weight does.
        """
        chi = self.chi_square
        if chi.verdict == "incomplete" and chi.dof > 0 and math.isfinite(chi.ratio):
            return max(1.0, chi.ratio)
        return 1.0

    @property
    def uncertainty_scale(self) -> float:
        """sqrt(:attr:`variance_factor`): what the reported uncertainties are multiplied by."""
        return math.sqrt(self.variance_factor)

    @property
    def scaled_covariance(self) -> FloatArray:
        """The reported covariance: :attr:`covariance` times :attr:`variance_factor`."""
        return self.covariance * self.variance_factor

    @property
    def scaled_std(self) -> FloatArray:
        """The reported standard uncertainties (P,): :attr:`std` times
        :attr:`uncertainty_scale` (0 for held/fixed)."""
        return self.std * self.uncertainty_scale

    def delta(self) -> FloatArray:
        """Calibrated minus start parameters (P,)."""
        return self.params.to_vector() - self.start.to_vector()

    def strongest_correlations(self, k: int = 5) -> list[tuple[str, str, float]]:
        """The ``k`` largest |correlations| between free parameters."""
        c = self.correlation
        names = param_names(self.params)
        pairs = []
        for i in range(len(names)):
            for j in range(i + 1, len(names)):
                if np.isfinite(c[i, j]):
                    pairs.append((names[i], names[j], float(c[i, j])))
        pairs.sort(key=lambda t: -abs(t[2]))
        return pairs[:k]
