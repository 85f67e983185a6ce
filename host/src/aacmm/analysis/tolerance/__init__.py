"""Tolerance allocation: from a target accuracy to a tolerance for every part.

The inverse of :mod:`aacmm.uncertainty`: given what the arm must
reach (the expanded uncertainty of the probe point over a workspace, at its
worst pose or as an RMS, or a length-measurement MPE), a cost model per
parameter (c / t^k within process limits) and an encoder catalogue, find the
cheapest tolerance of each of the 25 structural parameters and the encoder
for each joint, the budget they make, and check by Monte Carlo that arms
built to those tolerances meet the target. With a calibration model the
allocation is for a calibrated arm: only what calibration leaves needs a
manufacturing tolerance. Method and example: docs/tolerance.md.

* :func:`load_spec`, :func:`parse_spec` -- the TOML request (spec.py) into
  :class:`ToleranceSpec` and its parts (request.py).
* :func:`allocate` -> :class:`Allocation` (allocation.py; solvers in solve.py,
  the linearised problem in design.py).
* :func:`monte_carlo_check` -> :class:`CheckResult` (check.py), with
  :func:`check_memory_limit` and :func:`estimate_check_seconds` before a long one.
* :class:`CalibrationModel` -- what a calibration identifies (calibrated.py).
* :func:`format_report`, :func:`summary_lines`, :func:`to_json`,
  :func:`to_csv`, :func:`budget_png` (report.py).

Errors: :class:`SpecError` (the spec file; the same class as
:class:`aacmm.analysis.SpecError`), :class:`aacmm.errors.InfeasibleError`
(no allocation meets the target), :class:`RunLimitError` /
:class:`MemoryLimitError` (a check over its limits), ``ValueError`` for bad
arguments.
"""

from aacmm.analysis.tolerance.allocation import (
    STATUSES,
    Allocation,
    EncoderResult,
    ParamResult,
    allocate,
)
from aacmm.analysis.tolerance.calibrated import CalibrationModel
from aacmm.analysis.tolerance.check import (
    CheckResult,
    check_memory_limit,
    estimate_check_seconds,
    monte_carlo_check,
)
from aacmm.analysis.tolerance.design import Design, build_design, radius_factor, z_two_sided
from aacmm.analysis.tolerance.report import (
    budget_png,
    check_lines,
    format_report,
    summary_lines,
    to_csv,
    to_json,
)
from aacmm.analysis.tolerance.request import (
    CalibrationDesign,
    Encoder,
    ParamCost,
    Target,
    ToleranceSpec,
    Workspace,
)
from aacmm.analysis.tolerance.spec import load_spec, parse_spec
from aacmm.uncertainty.spec import SpecError

__all__ = [
    "STATUSES",
    "Allocation",
    "CalibrationDesign",
    "CalibrationModel",
    "CheckResult",
    "Design",
    "Encoder",
    "EncoderResult",
    "ParamCost",
    "ParamResult",
    "SpecError",
    "Target",
    "ToleranceSpec",
    "Workspace",
    "allocate",
    "budget_png",
    "build_design",
    "check_lines",
    "check_memory_limit",
    "estimate_check_seconds",
    "format_report",
    "load_spec",
    "monte_carlo_check",
    "parse_spec",
    "radius_factor",
    "summary_lines",
    "to_csv",
    "to_json",
    "z_two_sided",
]
