"""Probe-point uncertainty from structural-parameter uncertainties.

Two methods, side by side:

* **Monte Carlo** (JCGM 101, GUM Supplement 1): draw every parameter from its
  distribution (normal, uniform, triangular, arcsine, or correlated normal
  from a covariance), build one model per trial with the firmware's C core
  and compute the probe point at each pose (on the batch kernel across SIMD
  lanes, :func:`aacmm.core.perturbed_points`); the spread of the points is the
  uncertainty, the 2.5 % and 97.5 % quantiles give the probabilistically
  symmetric 95 % coverage interval.
* **Linear propagation** (GUM, law of propagation of uncertainty):
  Sigma_p = J Sigma_q J^T with the 3x25 Jacobian at the nominal parameters,
  and the 95 % interval +-1.96 u (normal output assumed).

Their agreement is judged as in JCGM 101 section 8 (the endpoints of the two
95 % intervals differ by at most the numerical tolerance delta for ``ndig``
significant digits of u) and by the ratio of the standard uncertainties. The
budget ranks each parameter's share of the variance.

**Memory does not grow with the number of trials.** Trials are drawn in
chunks of :data:`TRIAL_CHUNK`, each from its own random stream
(``SeedSequence(seed, spawn_key=(chunk,))``), so a result depends on the seed
only, never on the number of threads. While the deviations of a pose fit the
memory budget (``trials x 32 bytes <= memory_budget``, 8 million trials at
the default 256 MiB) the statistics are exact (``numpy.std``,
``numpy.quantile``); beyond, two passes over the same chunks give the
moments and the extremes, then histograms of :data:`HIST_BINS` bins between
them, and the quantiles are read from the histograms (within one bin,
range / 16384, of the exact order statistic). Poses are processed in blocks
that fit the same budget; per pose the result itself takes about
:data:`BYTES_PER_POSE` bytes, and :func:`propagate` refuses
(:class:`MemoryLimitError`) a request whose poses would not fit in the
memory available.

The package sits below :mod:`aacmm.calibration` and :mod:`aacmm.analysis`,
which both use it. Modules: :mod:`~aacmm.uncertainty.spec` (the input:
:func:`load_spec`, :func:`parse_spec`, :class:`UncertaintySpec`),
:mod:`~aacmm.uncertainty.propagation` (the entry point :func:`propagate`),
:mod:`~aacmm.uncertainty.report` (:func:`format_report`, :func:`to_json`,
:func:`csv_text`, :func:`figure`), :mod:`~aacmm.uncertainty.runlimits` (time
and memory limits of long Monte Carlo runs, shared with :mod:`aacmm.analysis`)
and :mod:`~aacmm.uncertainty.parallel` (the thread pool of those runs). This
``__init__`` is the public face: every name below is importable from
``aacmm.uncertainty``.

Errors: ValueError (:class:`SpecError` for the file) for bad specs and
arguments; :class:`MemoryLimitError` (a :class:`RunLimitError`, a
ValueError) for poses that cannot fit; :class:`aacmm.core.KinematicsError`
(a ValueError) if a perturbed arm is invalid. All are
:class:`aacmm.errors.AacmmError`.
"""

from aacmm.uncertainty.propagation import (
    BYTES_PER_POSE,
    DEFAULT_TRIALS,
    DEFAULT_WORKSPACE,
    HIST_BINS,
    K95,
    MEMORY_BUDGET,
    TRIAL_CHUNK,
    MemoryLimitError,
    Progress,
    draw_deltas,
    propagate,
)
from aacmm.uncertainty.report import (
    BudgetEntry,
    PoseResult,
    UncertaintyResult,
    csv_text,
    figure,
    format_report,
    to_json,
)
from aacmm.uncertainty.spec import (
    ANGLE_UNITS,
    DISTRIBUTIONS,
    EXAMPLE_SPEC,
    LENGTH_UNITS,
    TOLERANCE_FACTOR,
    ParamUncertainty,
    SpecError,
    UncertaintySpec,
    expand_name,
    load_spec,
    parse_spec,
    pose_list,
)

__all__ = [
    "ANGLE_UNITS",
    "BYTES_PER_POSE",
    "DEFAULT_TRIALS",
    "DEFAULT_WORKSPACE",
    "DISTRIBUTIONS",
    "EXAMPLE_SPEC",
    "HIST_BINS",
    "K95",
    "LENGTH_UNITS",
    "MEMORY_BUDGET",
    "TOLERANCE_FACTOR",
    "TRIAL_CHUNK",
    "BudgetEntry",
    "MemoryLimitError",
    "ParamUncertainty",
    "PoseResult",
    "Progress",
    "SpecError",
    "UncertaintyResult",
    "UncertaintySpec",
    "csv_text",
    "draw_deltas",
    "expand_name",
    "figure",
    "format_report",
    "load_spec",
    "parse_spec",
    "pose_list",
    "propagate",
    "to_json",
]
