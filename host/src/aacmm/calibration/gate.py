"""The quality gate: may a calibration be written to the arm?

A calibration that cannot hurt the arm is one that is refused, loudly, when
its data cannot support it. :func:`assess` runs every check on a finished
calibration and returns the reasons to refuse it (none: it may be written):

``session``
    a calibration session that is not complete (status ``interrupted``,
    ``link_lost``, ...) or that holds fewer points than its plan asks for
    (cut short, whatever its status says);
``rank``
    an unobservable direction that is not a symmetry of the model: the data
    cannot see the arm's scale, or a combination of parameters at all
    (``scale``, ``parallel``, ``other``; :mod:`aacmm.calibration.identifiability`;
    ``geometry``, a combination no pose can observe, is a symmetry). The
    solve holds such directions at their start values, which leaves the
    calibrated set as wrong there as the set in force, while the covariance
    (zero for held parameters) says nothing about it;
``uncertainty``
    a parameter whose reported standard uncertainty exceeds a limit
    (:class:`GateLimits`: lengths in mm, angles in rad);
``correlation``
    two estimated parameters correlated at +-1 (the data cannot tell them
    apart: |r| >= ``max_correlation``);
``prediction``
    the calibrated set's predicted accuracy is not better than the set in
    force's (:func:`predict`, below);
``validation``
    a held-out session measures worse with the calibrated set than with the
    set in force (an RMS figure of the before/after table grew).

**Prediction.** Over ``pairs`` random pairs of workspace poses (every joint
uniform in [-pi, pi), seeded, as the propagated point uncertainty draws its
workspace), each pair's distance is computed with the start and the
calibrated parameters. Distances are what every verification test measures
(lengths, the scatter of one point probed from several articulations, sphere
form): they do not depend on where the arm stands, so the held theta1 and d1
do not enter. With g the gradient of a distance with respect to the
parameters and Sigma the reported covariance (scaled by chi^2/dof when the
model is refuted):

* U, the calibrated set's predicted length error: RMS over the pairs of
  sqrt(g Sigma g^T), the standard uncertainty the calibration leaves;
* D, the change: RMS over the pairs of L(calibrated) - L(start);
* S, the set in force's estimated length error: sqrt(max(0, D^2 - U^2)).
  If the calibration is unbiased, L(start) - L(true) = -(L(cal) - L(start)) +
  (L(cal) - L(true)), whose mean square is D^2 - U^2: the change minus what
  the calibration's own scatter explains;
* when the set in force is itself a calibration whose provenance is known
  (:class:`PreviousCalibration`), its predicted length error U_prev (the
  same computation with its covariance).

Writing helps when the set in force is worse than the calibrated set, S > U
(D^2 > 2 U^2); the gate asks that the change be clearly larger than what the
calibration's own scatter explains: D^2 > U^2 (1 + q), q the ``confidence``
quantile (99 %) of chi-square(nu) / nu, nu the effective degrees of freedom
of D^2 (a weighted sum of chi-square(1) variables, Satterthwaite; a few
parameter directions carry the change, so nu is small and the margin real).
A calibration that predicts less error than the previous one did (U <
U_prev) passes too. Otherwise nothing shows the set in force to be wrong,
and a new set would replace it by one no better: the calibration lab's "as
found within tolerance, not adjusted".

Pure library code: arrays and dataclasses in, a :class:`GateResult` out.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from aacmm.calibration.parameters import (
    ArmParams,
    CalibParams,
    n_joints,
    param_names,
    param_units,
    validate,
    with_vector,
)
from aacmm.calibration.results import CalibrationResult
from aacmm.calibration.validation import Comparison
from aacmm.core import JOINTS, FloatArray, Model, Params

ARCSEC_RAD = math.pi / 648000.0
_HARMONIC = re.compile(r"[cs]\d+_\d+")
#: the null-space kinds that are symmetries of the model (no data see them): the base's
#: rigid motions (alpha1 and a1 too for a modified first joint, issue 26), the tip's split
#: and any other combination that moves no probe point at any pose ("geometry")
SYMMETRIES = frozenset({"theta1", "d1", "alpha1", "a1", "tip", "geometry"})
#: the checks, in the order they are run and reported
CHECKS = ("session", "rank", "uncertainty", "correlation", "prediction", "validation")
DEFAULT_PAIRS = 500
DEFAULT_SEED = 2024
DEFAULT_CONFIDENCE = 0.99
#: limits of coarse encoders: this many times their quantisation (GateLimits.for_arm)
ENCODER_FACTOR = 3.0


@dataclass(frozen=True)
class GateLimits:
    """The limits of the quality gate.

    ``max_u_length_mm``: the largest standard uncertainty of a length
    parameter (d, a, l); ``max_u_angle_rad``: of an angle (theta offset,
    alpha); the defaults are about ten times what the shipped
    kinematic-calibration plan gives on the paper's arm (docs/calibration.md);
    :meth:`for_arm` widens them for a small arm or coarse encoders.
    ``max_correlation``: |r| at or above it is a correlation at +-1 (printed
    as 1.000). ``pairs`` and ``seed``: the workspace pose pairs of the
    prediction.
    """

    max_u_length_mm: float = 0.050
    max_u_angle_rad: float = 20.0 * ARCSEC_RAD
    max_correlation: float = 0.9995
    pairs: int = DEFAULT_PAIRS
    seed: int = DEFAULT_SEED
    confidence: float = DEFAULT_CONFIDENCE

    def __post_init__(self) -> None:
        for name in ("max_u_length_mm", "max_u_angle_rad"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v}")
        if not 0 < self.max_correlation <= 1:
            raise ValueError(f"max_correlation must be in (0, 1], got {self.max_correlation}")
        if self.pairs < 1:
            raise ValueError(f"pairs must be >= 1, got {self.pairs}")
        if not 0.5 <= self.confidence < 1:
            raise ValueError(f"confidence must be in [0.5, 1), got {self.confidence}")

    @classmethod
    def for_arm(
        cls, counts_per_rev: Sequence[int], lever_mm: float, factor: float = ENCODER_FACTOR
    ) -> GateLimits:
        """The default limits, widened for a small arm or coarse encoders.

        An encoder of ``cpr`` counts reads each angle with a quantisation error
        uniform over one count, standard deviation ``u_q = 2 pi / cpr / sqrt(12)``
        (GUM 4.3.7): unmodelled by the kinematics, it scatters the residuals, and
        the calibration's uncertainties (scaled by chi^2/dof) grow with it. The
        length limit is at least ``factor`` times ``u_q`` of the coarsest encoder
        at ``lever_mm`` (the RMS distance of the calibration's points from the
        base); the angle limit at least ``factor`` times ``u_q`` and at least the
        angle whose effect at the lever is the length limit (an angle matters by
        what it does to the tip: 50 um at 300 mm is 34"). With the paper's arm
        (2^32 counts, points some 860 mm out) the defaults hold; a 2^14-count
        digitizer (u_q = 22.8") at a 300 mm lever gets 99 um and 68".
        Raises ValueError for no encoders, a count below 2 or a lever that is not
        a positive number.
        """
        if not counts_per_rev or min(counts_per_rev) < 2:
            raise ValueError("counts_per_rev: one count of 2 or more per joint")
        if not (math.isfinite(lever_mm) and lever_mm > 0):
            raise ValueError(f"lever_mm must be a positive number, got {lever_mm}")
        u_q = 2.0 * math.pi / min(counts_per_rev) / math.sqrt(12.0)
        base = cls()
        length = max(base.max_u_length_mm, factor * u_q * lever_mm)
        return cls(
            max_u_length_mm=length,
            max_u_angle_rad=max(base.max_u_angle_rad, factor * u_q, length / lever_mm),
        )


def arm_limits(res: CalibrationResult[Any], counts_per_rev: Sequence[int]) -> GateLimits:
    """:meth:`GateLimits.for_arm` for a calibration: the lever is the RMS
    distance of its points from the base origin (at least 1 mm). Raises
    ValueError for bad encoder counts."""
    pts = res.after.points
    lever = float(np.sqrt(np.mean(np.einsum("na,na->n", pts, pts)))) if pts.size else 1.0
    return GateLimits.for_arm(counts_per_rev, max(lever, 1.0))


@dataclass(frozen=True)
class SessionState:
    """What the gate needs to know of one calibration session."""

    path: str
    status: str
    points: int
    plan_points: int


@dataclass(frozen=True)
class PreviousCalibration:
    """The calibration that made the set in force (from its provenance file).

    ``params`` and ``covariance`` (P, P; rad, mm; 25 for the paper's arm): its
    calibrated set and reported covariance; ``source``: where it was read, for
    messages.
    """

    params: ArmParams
    covariance: FloatArray
    source: str


@dataclass(frozen=True)
class Prediction:
    """The predicted length errors over the workspace (mm, k = 1; module doc).

    ``calibrated_rms_mm`` (U) and ``calibrated_p95_mm``: the calibrated set's
    predicted length error, RMS and 95th percentile over the pairs;
    ``change_rms_mm`` (D); ``in_force_rms_mm`` (S, estimated from the data);
    ``dof``: the effective degrees of freedom of D^2 (Satterthwaite) and
    ``change_limit_mm``: the change that the calibration's own uncertainty
    explains with probability ``confidence`` (D must exceed it to show the set
    in force worse than the calibration); ``previous_rms_mm`` (U_prev) and
    ``previous_source`` when the set in force's provenance is known.
    """

    pairs: int
    seed: int
    calibrated_rms_mm: float
    calibrated_p95_mm: float
    change_rms_mm: float
    in_force_rms_mm: float
    dof: float
    confidence: float
    change_limit_mm: float
    previous_rms_mm: float | None = None
    previous_source: str | None = None

    @property
    def significant(self) -> bool:
        """The change exceeds what the calibration's own uncertainty explains: the
        data show the set in force to be worse than the calibrated set."""
        return self.change_rms_mm > self.change_limit_mm

    @property
    def beats_previous(self) -> bool:
        """A previous calibration made the set in force, and predicted more error."""
        return self.previous_rms_mm is not None and self.calibrated_rms_mm < self.previous_rms_mm

    @property
    def set_in_force_mm(self) -> float:
        """The set in force's predicted length error: max(S, U_prev)."""
        prev = self.previous_rms_mm if self.previous_rms_mm is not None else 0.0
        return max(self.in_force_rms_mm, prev)

    @property
    def improves(self) -> bool:
        """Writing the calibration is expected to reduce the length errors."""
        return self.significant or self.beats_previous

    def describe(self) -> str:
        """One line: both predictions and where the set in force's comes from."""
        um = 1e3
        prev = (
            f"; its own calibration predicted {self.previous_rms_mm * um:.3g} um "
            f"({self.previous_source})"
            if self.previous_rms_mm is not None
            else ""
        )
        return (
            f"predicted length error over the workspace ({self.pairs} random pose pairs, "
            f"k = 1, RMS): {self.calibrated_rms_mm * um:.3g} um for the calibrated set "
            f"(95 % of pairs below {self.calibrated_p95_mm * um:.3g} um); the set in force "
            f"{self.in_force_rms_mm * um:.3g} um as the data show it (the change "
            f"{self.change_rms_mm * um:.3g} um RMS, its own uncertainty explaining up to "
            f"{self.change_limit_mm * um:.3g} um at {self.confidence:.0%}){prev}"
        )

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        d["set_in_force_mm"] = self.set_in_force_mm
        d["significant"] = self.significant
        d["improves"] = self.improves
        return d


@dataclass(frozen=True)
class Refusal:
    """One reason to refuse a calibration: the check (:data:`CHECKS`) and one line."""

    check: str
    message: str


@dataclass(frozen=True)
class GateResult:
    """The gate's verdict: the refusals (none: it may be written) and the prediction."""

    refusals: tuple[Refusal, ...]
    prediction: Prediction
    limits: GateLimits = field(default_factory=GateLimits)

    @property
    def passed(self) -> bool:
        return not self.refusals

    def to_json(self) -> dict[str, Any]:
        return {
            "passed": self.passed,
            "refusals": [asdict(r) for r in self.refusals],
            "prediction": self.prediction.to_json(),
            "limits": asdict(self.limits),
        }


# ------------------------------------------------------------------ prediction


def workspace_pairs(pairs: int, seed: int, joints: int = JOINTS) -> FloatArray:
    """Joint angles (2 pairs, N) of random workspace poses, consecutive rows a pair
    (N = ``joints``, 6 for the paper's arm)."""
    rng = np.random.default_rng(seed)
    out: FloatArray = rng.uniform(-math.pi, math.pi, (2 * pairs, joints))
    return out


def length_gradients(params: ArmParams, theta_rad: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Distances (n,) between consecutive pose pairs of ``theta_rad`` (2n, N) and their
    gradients (n, P) with respect to the P parameters (rad, mm; 25 for the paper's arm)."""
    p, j = Model(params).points_jacobians(theta_rad)
    d = p[0::2] - p[1::2]
    length = np.linalg.norm(d, axis=1)
    u = d / np.maximum(length, 1e-300)[:, None]
    g: FloatArray = np.einsum("na,nak->nk", u, j[0::2] - j[1::2])
    return length, g


def _full_lengths(params: Any, theta_rad: FloatArray) -> tuple[FloatArray, FloatArray]:
    """:func:`length_gradients` of an arm or of a :class:`CalibParams` with its error
    model (at the reference temperatures): gradients over all P + E columns."""
    if not isinstance(params, CalibParams):
        return length_gradients(params, theta_rad)
    from aacmm.errmodel import points_jacobians

    p, j = points_jacobians(Model(params.arm), params.errors, theta_rad)
    d = p[0::2] - p[1::2]
    length = np.linalg.norm(d, axis=1)
    u = d / np.maximum(length, 1e-300)[:, None]
    g: FloatArray = np.einsum("na,nak->nk", u, j[0::2] - j[1::2])
    return length, g


def length_uncertainty(
    params: ArmParams, covariance: FloatArray, theta_rad: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Distances (n,) between consecutive pose pairs of ``theta_rad`` (2n, 6) and
    their standard uncertainties (n,) from ``covariance`` (25, 25)."""
    length, g = length_gradients(params, theta_rad)
    var = np.einsum("nk,kl,nl->n", g, np.asarray(covariance, dtype=np.float64), g)
    return length, np.sqrt(np.clip(var, 0.0, None))


def _change_dof(g: FloatArray, cov: FloatArray) -> float:
    """Effective degrees of freedom of D^2 = mean((g dp)^2) for dp ~ N(0, cov):
    a weighted sum of chi-square(1) variables whose weights are the eigenvalues of
    C^T M C (M = mean g^T g, cov = C C^T), taken as a scaled chi-square
    (Satterthwaite): (sum w)^2 / sum w^2."""
    lam, vec = np.linalg.eigh(0.5 * (cov + cov.T))
    c = vec * np.sqrt(np.clip(lam, 0.0, None))
    gc = g @ c
    w = np.linalg.eigvalsh(gc.T @ gc / g.shape[0])
    w = np.clip(w, 0.0, None)
    total = float(w.sum())
    return total**2 / float(np.sum(w**2)) if total > 0 else 1.0


def predict(
    res: CalibrationResult[Any],
    previous: PreviousCalibration | None = None,
    pairs: int = DEFAULT_PAIRS,
    seed: int = DEFAULT_SEED,
    confidence: float = DEFAULT_CONFIDENCE,
) -> Prediction:
    """The predicted length errors of the calibrated set and of the set in force.

    The change is significant when D^2 > U^2 (1 + q), q the ``confidence``
    quantile of chi-square(nu) / nu with nu the effective degrees of freedom
    of D^2 (:func:`_change_dof`): then S^2 = D^2 - U^2 > q U^2, the set in force
    shown worse than the calibrated set with a margin for the scatter of D
    itself (few effective degrees of freedom: a few parameter directions
    carry the change).
    """
    from scipy import stats

    theta = workspace_pairs(pairs, seed, n_joints(res.params))
    cov = res.scaled_covariance
    # the whole model on both sides: a change of the encoder harmonics alone is a
    # change of the lengths the arm measures as much as one of its DH parameters
    l_cal, g = _full_lengths(res.params, theta)
    u = np.sqrt(np.clip(np.einsum("nk,kl,nl->n", g, cov, g), 0.0, None))
    l_start, _ = _full_lengths(res.start, theta)
    big_u = float(np.sqrt(np.mean(u**2)))
    big_d = float(np.sqrt(np.mean((l_cal - l_start) ** 2)))
    s = math.sqrt(max(0.0, big_d**2 - big_u**2))
    nu = _change_dof(g, cov) if big_u > 0 else 1.0
    q = float(stats.chi2.ppf(confidence, nu) / nu)
    limit = big_u * math.sqrt(1.0 + q)
    prev = prev_src = None
    if previous is not None:
        _, u_prev = length_uncertainty(previous.params, previous.covariance, theta)
        prev, prev_src = float(np.sqrt(np.mean(u_prev**2))), previous.source
    return Prediction(
        pairs,
        seed,
        big_u,
        float(np.quantile(u, 0.95)),
        big_d,
        s,
        nu,
        confidence,
        limit,
        prev,
        prev_src,
    )


def previous_from_provenance(
    data: Any, source: str, like: ArmParams | None = None
) -> PreviousCalibration:
    """A :class:`PreviousCalibration` from a provenance file's content
    (``format = "aacmm-calibration-1"``: ``result.calibrated``, ``result.covariance``).

    ``like``: the arm the calibration must be of (its parameter names and
    shape; default the paper's arm): the provenance of a calibration of
    another arm (other parameter names) is refused.

    Raises:
        ValueError: not a calibration provenance, values missing or not finite, or
            the calibration of another arm.
    """
    p0: ArmParams = like if like is not None else Params()
    names = param_names(p0)
    if not isinstance(data, Mapping) or data.get("format") != "aacmm-calibration-1":
        raise ValueError(f"{source}: not a calibration provenance (aacmm-calibration-1)")
    result = data.get("result")
    if not isinstance(result, Mapping):
        raise ValueError(f"{source}: no result in the provenance")
    cal = result.get("calibrated")
    cov = result.get("covariance")
    # the arm's parameters (an encoder harmonic's c<j>_<k>, s<j>_<k> are not the arm's)
    dh = (
        {str(k) for k in cal if not _HARMONIC.fullmatch(str(k))}
        if isinstance(cal, Mapping)
        else set()
    )
    if dh and dh != set(names) and dh & set(names):
        theirs = sum(1 for k in dh if k.startswith("theta"))
        raise ValueError(
            f"{source}: the calibration of another arm ({theirs} joints, {len(dh)} "
            f"parameters; this arm has {n_joints(p0)} joints, {len(names)} parameters)"
        )
    if not isinstance(cal, Mapping) or any(n not in cal for n in names):
        raise ValueError(f"{source}: result.calibrated lacks parameters")
    try:
        v = np.array([float(cal[n]) for n in names])
        c = np.array(cov, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{source}: result.calibrated / covariance are not numbers") from None
    k = len(names)
    keys = [str(n) for n in cal]
    if c.ndim == 2 and c.shape == (len(keys), len(keys)) and keys[:k] == list(names):
        c = c[:k, :k]  # a calibration with encoder harmonics: the arm's (marginal) block
    if c.shape != (k, k) or not np.all(np.isfinite(c)) or not np.all(np.isfinite(v)):
        raise ValueError(f"{source}: result.covariance must be a finite {k} x {k} matrix")
    if not np.allclose(c, c.T, rtol=1e-9, atol=1e-30) or np.any(np.diag(c) < 0):
        raise ValueError(f"{source}: result.covariance is not a covariance matrix")
    try:
        params = with_vector(p0, v)
        validate(params)
    except ValueError as exc:
        raise ValueError(f"{source}: result.calibrated: {exc}") from None
    return PreviousCalibration(params, c, source)


# ------------------------------------------------------------------ the checks


def _session_refusals(sessions: Sequence[SessionState]) -> list[Refusal]:
    out = []
    for s in sessions:
        if s.status != "complete":
            out.append(
                Refusal(
                    "session",
                    f"{s.path}: the session is {s.status} ({s.points} of {s.plan_points} "
                    "points): finish it (aacmm capture --resume) before calibrating from it",
                )
            )
        elif s.points < s.plan_points:
            out.append(
                Refusal(
                    "session",
                    f"{s.path}: {s.points} of the plan's {s.plan_points} points although its "
                    "status says complete: the session is short of its plan",
                )
            )
    return out


def _rank_refusals(res: CalibrationResult[Any]) -> list[Refusal]:
    idn = res.identifiability
    bad = [d for d in idn.null if d.kind not in SYMMETRIES]
    if not bad:
        return []
    what = "; ".join(f"{d.kind} ({', '.join(n for n, _ in d.components[:4])})" for d in bad)
    return [
        Refusal(
            "rank",
            f"rank {idn.rank} of {idn.n}: the data cannot observe {what}, beyond the model's "
            f"symmetries; held at the values in force ({', '.join(idn.held)}), they would "
            f"stay as wrong as they are: {bad[0].remedy}",
        )
    ]


def _uncertainty_refusals(res: CalibrationResult[Any], lim: GateLimits) -> list[Refusal]:
    sd = res.scaled_std
    worst: list[tuple[float, str]] = []
    units = param_units(res.params)
    for k, name in enumerate(param_names(res.params)):
        if name not in res.free:
            continue
        if units[k] == "rad":
            if sd[k] > lim.max_u_angle_rad:
                worst.append(
                    (
                        sd[k] / lim.max_u_angle_rad,
                        f'{name} u = {sd[k] / ARCSEC_RAD:.3g}" (limit '
                        f'{lim.max_u_angle_rad / ARCSEC_RAD:.3g}")',
                    )
                )
        elif sd[k] > lim.max_u_length_mm:
            worst.append(
                (
                    sd[k] / lim.max_u_length_mm,
                    f"{name} u = {sd[k] * 1e3:.3g} um (limit {lim.max_u_length_mm * 1e3:.3g} um)",
                )
            )
    if not worst:
        return []
    worst.sort(reverse=True)
    more = f" and {len(worst) - 3} more" if len(worst) > 3 else ""
    return [
        Refusal(
            "uncertainty",
            "parameter uncertainty above the limit: "
            + ", ".join(t for _, t in worst[:3])
            + more
            + ": the data do not determine the arm well enough",
        )
    ]


def _correlation_refusals(res: CalibrationResult[Any], lim: GateLimits) -> list[Refusal]:
    pairs = [
        t
        for t in res.strongest_correlations(len(param_names(res.params)))  # 25: the paper's
        if abs(t[2]) >= lim.max_correlation
    ]
    if not pairs:
        return []
    a, b, c = pairs[0]
    more = f" (and {len(pairs) - 1} more pairs)" if len(pairs) > 1 else ""
    return [
        Refusal(
            "correlation",
            f"{a} and {b} correlated at {c:+.5f}{more}: the data cannot tell them apart",
        )
    ]


def _prediction_refusals(p: Prediction) -> list[Refusal]:
    if p.improves:
        return []
    um = 1e3
    prev = (
        f"; the set in force's own calibration predicted {p.previous_rms_mm * um:.3g} um "
        f"({p.previous_source})"
        if p.previous_rms_mm is not None
        else ""
    )
    return [
        Refusal(
            "prediction",
            f"not shown to be better than the set in force: the change it makes, "
            f"{p.change_rms_mm * um:.3g} um RMS over the workspace, is within what its own "
            f"uncertainty explains ({p.change_limit_mm * um:.3g} um at {p.confidence:.0%}; "
            f"predicted length error {p.calibrated_rms_mm * um:.3g} um RMS){prev}",
        )
    ]


def _validation_refusals(validation: Comparison | None) -> list[Refusal]:
    if validation is None:
        return []
    worse = [
        (n, b, a)
        for n, b, a, _ in validation.rows()
        if n.endswith("_rms_mm") and math.isfinite(b) and math.isfinite(a) and a > b
    ]
    if not worse:
        return []
    text = ", ".join(
        f"{n.removesuffix('_mm')} {b * 1e3:.2f} -> {a * 1e3:.2f} um ({a / b:.3g}x worse)"
        for n, b, a in worse
    )
    return [Refusal("validation", f"the held-out sessions measure worse after calibration: {text}")]


def assess(
    res: CalibrationResult[Any],
    sessions: Sequence[SessionState] = (),
    limits: GateLimits | None = None,
    previous: PreviousCalibration | None = None,
    validation: Comparison | None = None,
) -> GateResult:
    """Every check of the module doc on a finished calibration.

    ``sessions``: the calibration sessions; ``previous``: the calibration
    that made the set in force, if known; ``validation``: the before/after
    comparison on held-out sessions, if any.
    """
    from aacmm.calibration.harmonics import dh_part

    lim = limits or GateLimits()
    pred = predict(res, previous, lim.pairs, lim.seed, lim.confidence)
    res = dh_part(res)  # encoder harmonics: the arm's part (its marginal covariance)
    refusals = [
        *_session_refusals(sessions),
        *_rank_refusals(res),
        *_uncertainty_refusals(res, lim),
        *_correlation_refusals(res, lim),
        *_prediction_refusals(pred),
        *_validation_refusals(validation),
    ]
    return GateResult(tuple(refusals), pred, lim)
