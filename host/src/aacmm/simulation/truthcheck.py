"""Lengths across the reach against the truth: the evaluation of ``aacmm demo --check``.

:func:`reach_lengths` draws ``lengths`` pairs of random postures within the
simulated arm's joint limits (:func:`truth_limits`), the true distance between
each pair's two tip points (the truth's geometry) and the true encoders'
noise-free readings there (with their eccentricity and harmonics,
:meth:`~aacmm.simulation.truth.Truth.counts` without a generator).
:func:`length_errors` compares the distances an arm model measures from those
readings (the caller converts the counts into points with the model under
test: a parameter set, a calibration's arm and error model) with the true
ones: RMS, 95th percentile and largest absolute error.

The demo's truth check (:func:`aacmm.commands.demo_report.truth_check`) and
the tests' studies of calibrations against a truth (issue 27) both use it;
only such checks read a truth: calibration code never does.

Pure: no printing, no files.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from aacmm.core import Params

#: the demo's defaults: 2,000 lengths, postures of seed 2024
CHECK_LENGTHS: Final = 2000
CHECK_SEED: Final = 2024

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class ReachLengths:
    """``lengths`` pairs of postures: joint angles ``theta_rad`` (2n, N; the pair
    of length i in rows 2i and 2i + 1), the true encoders' noise-free ``counts``
    there (2n, N) and the true distances ``true_mm`` (n,)."""

    theta_rad: FloatArray
    counts: npt.NDArray[np.int64]
    true_mm: FloatArray

    @property
    def lengths(self) -> int:
        return int(self.true_mm.shape[0])


@dataclass(frozen=True)
class LengthErrors:
    """Measured minus true length (mm, per length) and its RMS, 95th percentile of
    the absolute value and largest absolute value."""

    error_mm: FloatArray
    rms_mm: float
    p95_mm: float
    max_mm: float

    def to_json(self) -> dict[str, float]:
        return {"rms_mm": self.rms_mm, "p95_mm": self.p95_mm, "max_mm": self.max_mm}


def truth_limits(truth: Any) -> Any:
    """The joint limits the truth check's postures keep within: the simulator's
    (:data:`~aacmm.simulation.ik.ARM_LIMITS`) for the paper's arm; for an arm model's
    truth (``[origin] model``, ``aacmm sim --model``) the shipped model's limits, and
    none (every joint a full turn) for an arm the shipped models do not name."""
    from aacmm.errors import ModelError
    from aacmm.models import load_model
    from aacmm.simulation.ik import ARM_LIMITS, JointLimits

    if isinstance(truth.params, Params):
        return ARM_LIMITS
    n = truth.params.n_joints
    name = truth.origin.get("model")
    if isinstance(name, str):
        try:
            model = load_model(name)
        except ModelError:
            model = None
        if model is not None and model.file is None and model.n_joints == n:
            return JointLimits.from_ranges(model.joint_limits_rad)
    return JointLimits((0.0,) * n, (math.inf,) * n)


def reach_lengths(truth: Any, lengths: int = CHECK_LENGTHS, seed: int = CHECK_SEED) -> ReachLengths:
    """The check's postures, the true encoders' readings there and the true lengths
    (a :class:`~aacmm.simulation.truth.Truth`; same seed, same postures)."""
    rng = np.random.default_rng(seed)
    limits = truth_limits(truth)
    theta = np.array([limits.sample(rng) for _ in range(2 * lengths)])
    true_pts = truth.model().points(theta)
    counts = truth.counts(theta)  # no rng: the readings without noise
    true_len = np.linalg.norm(true_pts[0::2] - true_pts[1::2], axis=1)
    return ReachLengths(theta, np.asarray(counts, dtype=np.int64), true_len)


def length_errors(check: ReachLengths, points_mm: npt.ArrayLike) -> LengthErrors:
    """The errors of the lengths a model measures: ``points_mm`` (2n, 3) its tip
    points from ``check.counts``, row for row."""
    pts = np.asarray(points_mm, dtype=np.float64)
    if pts.shape != (2 * check.lengths, 3):
        raise ValueError(f"points must have shape ({2 * check.lengths}, 3), got {pts.shape}")
    err = np.linalg.norm(pts[0::2] - pts[1::2], axis=1) - check.true_mm
    return LengthErrors(
        err,
        float(np.sqrt(np.mean(err**2))),
        float(np.quantile(np.abs(err), 0.95)),
        float(np.max(np.abs(err))),
    )
