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
  Sigma_p = J Sigma_q J^T with the 3 x P Jacobian at the nominal parameters
  (P = 25 for the paper's arm; any arm of 4 to 7 joints, its own P: the
  spec's :attr:`UncertaintySpec.param_names`), and the 95 % interval
  +-1.96 u (normal output assumed).

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

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aacmm.uncertainty.propagation import BYTES_PER_POSE as BYTES_PER_POSE
    from aacmm.uncertainty.propagation import DEFAULT_TRIALS as DEFAULT_TRIALS
    from aacmm.uncertainty.propagation import DEFAULT_WORKSPACE as DEFAULT_WORKSPACE
    from aacmm.uncertainty.propagation import HIST_BINS as HIST_BINS
    from aacmm.uncertainty.propagation import K95 as K95
    from aacmm.uncertainty.propagation import MEMORY_BUDGET as MEMORY_BUDGET
    from aacmm.uncertainty.propagation import TRIAL_CHUNK as TRIAL_CHUNK
    from aacmm.uncertainty.propagation import MemoryLimitError as MemoryLimitError
    from aacmm.uncertainty.propagation import Progress as Progress
    from aacmm.uncertainty.propagation import draw_deltas as draw_deltas
    from aacmm.uncertainty.propagation import propagate as propagate
    from aacmm.uncertainty.report import BudgetEntry as BudgetEntry
    from aacmm.uncertainty.report import PoseResult as PoseResult
    from aacmm.uncertainty.report import UncertaintyResult as UncertaintyResult
    from aacmm.uncertainty.report import csv_text as csv_text
    from aacmm.uncertainty.report import figure as figure
    from aacmm.uncertainty.report import format_report as format_report
    from aacmm.uncertainty.report import to_json as to_json
    from aacmm.uncertainty.spec import ANGLE_UNITS as ANGLE_UNITS
    from aacmm.uncertainty.spec import DISTRIBUTIONS as DISTRIBUTIONS
    from aacmm.uncertainty.spec import EXAMPLE_SPEC as EXAMPLE_SPEC
    from aacmm.uncertainty.spec import GROUPS as GROUPS
    from aacmm.uncertainty.spec import LENGTH_UNITS as LENGTH_UNITS
    from aacmm.uncertainty.spec import TOLERANCE_FACTOR as TOLERANCE_FACTOR
    from aacmm.uncertainty.spec import ArmParameterError as ArmParameterError
    from aacmm.uncertainty.spec import ParamUncertainty as ParamUncertainty
    from aacmm.uncertainty.spec import SpecError as SpecError
    from aacmm.uncertainty.spec import UncertaintySpec as UncertaintySpec
    from aacmm.uncertainty.spec import expand_name as expand_name
    from aacmm.uncertainty.spec import load_spec as load_spec
    from aacmm.uncertainty.spec import parse_spec as parse_spec
    from aacmm.uncertainty.spec import pose_list as pose_list

# Loaded on first use, so that importing a light submodule (aacmm.uncertainty.runlimits,
# which every command's parser reads) does not pull numpy and the C core in.
_WHERE = {
    "BYTES_PER_POSE": "propagation",
    "DEFAULT_TRIALS": "propagation",
    "DEFAULT_WORKSPACE": "propagation",
    "HIST_BINS": "propagation",
    "K95": "propagation",
    "MEMORY_BUDGET": "propagation",
    "MemoryLimitError": "propagation",
    "Progress": "propagation",
    "TRIAL_CHUNK": "propagation",
    "draw_deltas": "propagation",
    "propagate": "propagation",
    "BudgetEntry": "report",
    "PoseResult": "report",
    "UncertaintyResult": "report",
    "csv_text": "report",
    "figure": "report",
    "format_report": "report",
    "to_json": "report",
    "ANGLE_UNITS": "spec",
    "ArmParameterError": "spec",
    "GROUPS": "spec",
    "DISTRIBUTIONS": "spec",
    "EXAMPLE_SPEC": "spec",
    "LENGTH_UNITS": "spec",
    "ParamUncertainty": "spec",
    "SpecError": "spec",
    "TOLERANCE_FACTOR": "spec",
    "UncertaintySpec": "spec",
    "expand_name": "spec",
    "load_spec": "spec",
    "parse_spec": "spec",
    "pose_list": "spec",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(importlib.import_module(f"aacmm.uncertainty.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'aacmm.uncertainty' has no attribute {name!r}")


__all__ = [
    "ANGLE_UNITS",
    "BYTES_PER_POSE",
    "DEFAULT_TRIALS",
    "DEFAULT_WORKSPACE",
    "DISTRIBUTIONS",
    "EXAMPLE_SPEC",
    "GROUPS",
    "HIST_BINS",
    "K95",
    "LENGTH_UNITS",
    "MEMORY_BUDGET",
    "TOLERANCE_FACTOR",
    "TRIAL_CHUNK",
    "ArmParameterError",
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
