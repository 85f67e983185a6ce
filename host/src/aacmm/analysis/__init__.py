"""Error analysis on the kinematics core: a pure library (arrays and
dataclasses in, results out; no argument parsing, no printing). The ``aacmm mc``,
``aacmm uncertainty`` and ``aacmm tolerance`` commands live in :mod:`aacmm.commands`.

* :mod:`aacmm.analysis.mc` -- Monte Carlo error-transfer coefficients (the
  paper's Table 2), fixed-N and adaptive (JCGM 101 7.9), over random or
  logged poses; its poses in :mod:`aacmm.analysis.mc_poses`, its results and
  reports in :mod:`aacmm.analysis.mc_report`.
* :mod:`aacmm.analysis.poselog` -- reads poses from ``aacmm log`` CSV files.
* probe-point uncertainty from parameter uncertainties (Monte Carlo and GUM)
  is the package :mod:`aacmm.uncertainty`, below both this package and
  :mod:`aacmm.calibration` (which uses it for its reports), with the run
  limits and thread pool the Monte Carlo runs here share.
* :mod:`aacmm.analysis.tolerance` -- the inverse: cost-optimal tolerances and
  encoders for a target accuracy, calibrated or not, checked by Monte Carlo.

Errors (all :class:`aacmm.errors.AacmmError` and ``ValueError``):
:class:`~aacmm.uncertainty.spec.SpecError` (a parameter-uncertainty
or tolerance spec file), :class:`~aacmm.analysis.poselog.PoseLogError` (a pose
log), :class:`~aacmm.uncertainty.runlimits.RunLimitError` and its subclass
:class:`~aacmm.uncertainty.MemoryLimitError` (a run over its limits);
:class:`aacmm.errors.InfeasibleError` (no tolerance allocation meets the
target); :class:`aacmm.core.KinematicsError` from the core; plain
``ValueError`` for bad arguments.
"""
