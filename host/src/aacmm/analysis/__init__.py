"""Error analysis on the kinematics core: a pure library (arrays and
dataclasses in, results out; no argument parsing, no printing). The ``aacmm mc``,
``aacmm uncertainty`` and ``aacmm tolerance`` commands live in :mod:`aacmm.commands`.

* :mod:`aacmm.analysis.mc` -- Monte Carlo error-transfer coefficients (the
  paper's Table 2), fixed-N and adaptive (JCGM 101 7.9), over random or
  logged poses; its poses in :mod:`aacmm.analysis.mc_poses`, its results and
  reports in :mod:`aacmm.analysis.mc_report` (both re-exported).
* :mod:`aacmm.analysis.poselog` -- reads poses from ``aacmm log`` CSV files.
* :mod:`aacmm.analysis.uncertainty` -- probe-point uncertainty from parameter
  uncertainties, by Monte Carlo (JCGM 101) and linear propagation (GUM).
* :mod:`aacmm.analysis.tolerance` -- the inverse: cost-optimal tolerances and
  encoders for a target accuracy, calibrated or not, checked by Monte Carlo.

Errors (all :class:`aacmm.errors.AacmmError` and ``ValueError``):
:class:`~aacmm.analysis.uncertainty_spec.SpecError` (a parameter-uncertainty
or tolerance spec file), :class:`~aacmm.analysis.poselog.PoseLogError` (a pose
log), :class:`~aacmm.analysis.runlimits.RunLimitError` and its subclass
:class:`~aacmm.analysis.uncertainty.MemoryLimitError` (a run over its limits);
:class:`aacmm.errors.InfeasibleError` (no tolerance allocation meets the
target); :class:`aacmm.core.KinematicsError` from the core; plain
``ValueError`` for bad arguments.
"""
