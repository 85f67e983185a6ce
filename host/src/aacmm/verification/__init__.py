"""Performance verification of arms: ISO 10360-12 and ASME B89.4.22.

A pure library (arrays, plans and sessions in; dataclasses out).

- :mod:`aacmm.verification.rules`: the decision rules (``simple``,
  ``iso14253-1``), :func:`decide`.
- :mod:`aacmm.verification.evaluations`: the test quantities from points
  (sphere size/form, articulated location, length errors, single-point
  articulation, volumetric statistics) and :data:`DEFINITIONS`, the
  definition implemented for each with its source and status.

Errors: :class:`VerificationError` (a session that cannot be verified: no
MPE, points outside the plan, nothing to evaluate) and the
:class:`aacmm.geometry.GeometryError` family from the fits (too few or
degenerate points), both :class:`aacmm.errors.AacmmError` and ``ValueError``.

See docs/verification.md.
"""

from aacmm.verification.evaluations import (
    DEFINITIONS,
    Definition,
    EndPoint,
    LengthStatistics,
    LengthTest,
    LocationTest,
    SinglePointTest,
    SphereTest,
    articulated_location,
    end_center,
    length_error,
    length_statistics,
    single_point_articulation,
    smallest_enclosing_sphere,
    sphere_size_form,
)
from aacmm.verification.rules import RULES, Decision, decide, overall

__all__ = [
    "DEFINITIONS",
    "RULES",
    "Decision",
    "Definition",
    "EndPoint",
    "LengthStatistics",
    "LengthTest",
    "LocationTest",
    "SinglePointTest",
    "SphereTest",
    "articulated_location",
    "decide",
    "end_center",
    "length_error",
    "length_statistics",
    "overall",
    "single_point_articulation",
    "smallest_enclosing_sphere",
    "sphere_size_form",
]
