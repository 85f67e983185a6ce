"""Arm calibration: identify the structural parameters from probed artefacts.

A pure library (arrays and dataclasses in, results out; nothing printed):

* :mod:`~aacmm.calibration.observations` -- poses and constraints (seats,
  calibrated lengths, reference points, spheres, planes);
* :mod:`~aacmm.calibration.problem` -- residuals and the analytic Jacobian
  (C core) with the nuisance unknowns eliminated;
* :mod:`~aacmm.calibration.identifiability` -- rank, singular values,
  observability indices, named null-space directions;
* :mod:`~aacmm.calibration.solve` -- :func:`calibrate`: Levenberg-Marquardt in
  the identifiable subspace;
* :mod:`~aacmm.calibration.diagnostics` -- covariance, chi-square check,
  outliers at the solution;
* :mod:`~aacmm.calibration.results` -- :class:`CalibrationResult` and its parts;
* :mod:`~aacmm.calibration.parameters` -- the paper's ``Params`` or any
  :class:`aacmm.arm.Arm` (issue 26): names, vectors, the tip's parameters;
* :mod:`~aacmm.calibration.thermal` -- the link CTEs a calibration estimates
  from stated link temperatures (issue 27).

The method and the figures are in docs/calibration.md.

Errors (all :class:`aacmm.errors.AacmmError` and ``ValueError``):
:class:`CalibrationError` (a problem that cannot be solved: too few
observations, unknown parameters, ...) and its subclass
:class:`~aacmm.calibration.probe.SpreadError` (probe points not spread
enough); :class:`ObservationError` (bad observations) and its subclass
:class:`~aacmm.calibration.sessions.SessionDataError` (a session that cannot
be turned into observations); :class:`aacmm.records.RecordError` from
the session reader; :class:`aacmm.core.KinematicsError` from the core.
"""

from aacmm.calibration.diagnostics import find_outliers
from aacmm.calibration.features import CalibrationError
from aacmm.calibration.identifiability import (
    Identifiability,
    NullDirection,
    analyse,
)
from aacmm.calibration.observations import (
    Cone,
    LengthSet,
    ObservationError,
    Observations,
    Plane,
    ReferencePoints,
    Sphere,
    combine,
)
from aacmm.calibration.problem import Evaluation, Problem
from aacmm.calibration.results import CalibrationResult, ChiSquare, Outlier, Progress, Suspect
from aacmm.calibration.solve import calibrate, parse_names, predicted_covariance

__all__ = [
    "CalibrationError",
    "CalibrationResult",
    "ChiSquare",
    "Cone",
    "Evaluation",
    "Identifiability",
    "LengthSet",
    "NullDirection",
    "ObservationError",
    "Observations",
    "Outlier",
    "Plane",
    "Problem",
    "Progress",
    "ReferencePoints",
    "Sphere",
    "Suspect",
    "analyse",
    "calibrate",
    "combine",
    "find_outliers",
    "parse_names",
    "predicted_covariance",
]
