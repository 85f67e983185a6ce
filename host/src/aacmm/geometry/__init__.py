"""Geometric (orthogonal-distance) fitting of measured features.

A pure library: arrays in, dataclasses out (no printing, no files).

Least-squares fits, each returning a :class:`Fit` (feature, residuals, form,
covariance, standard uncertainties):

- :func:`fit_point`, :func:`fit_line`, :func:`fit_plane` (closed form),
- :func:`fit_sphere` (and :func:`fit_spheres` for a batch), :func:`fit_circle`
  (a circle in 3D), :func:`fit_cylinder` (Gauss-Newton on the orthogonal distances).

Form: the range of the signed residuals for plane, sphere and cylinder (the
in-plane radial residuals for a circle); twice the largest distance for a
line (straightness zone diameter) and a point (the spread of a point cloud).

Minimum-zone (Chebyshev) form: :func:`minimum_zone_plane` (exact),
:func:`minimum_zone_sphere` (sequential LP from the least-squares centre).

Probe compensation: ``probe_radius`` on the plane, sphere, circle and
cylinder fits (points are ball centres; see each function). Algebraic fits
(:func:`kasa_sphere`) are exported only to show their bias.

Errors: :class:`GeometryError` (a ``ValueError``) and its subclasses
:class:`TooFewPointsError`, :class:`DegenerateGeometryError`,
:class:`ConvergenceError`; plain ``ValueError`` for bad arrays.
See docs/verification.md.
"""

from aacmm.geometry._base import (
    ConvergenceError,
    DegenerateGeometryError,
    Fit,
    GeometryError,
    TooFewPointsError,
    frame,
    to_dict,
)
from aacmm.geometry.algebraic import kasa_sphere, kasa_spheres
from aacmm.geometry.curved import (
    Circle,
    Cylinder,
    Sphere,
    SphereBatch,
    fit_circle,
    fit_cylinder,
    fit_sphere,
    fit_spheres,
)
from aacmm.geometry.linear import Line, Plane, Point, fit_line, fit_plane, fit_point
from aacmm.geometry.minzone import MinZone, minimum_zone_plane, minimum_zone_sphere

__all__ = [
    "Circle",
    "ConvergenceError",
    "Cylinder",
    "DegenerateGeometryError",
    "Fit",
    "GeometryError",
    "Line",
    "MinZone",
    "Plane",
    "Point",
    "Sphere",
    "SphereBatch",
    "TooFewPointsError",
    "fit_circle",
    "fit_cylinder",
    "fit_line",
    "fit_plane",
    "fit_point",
    "fit_sphere",
    "fit_spheres",
    "frame",
    "kasa_sphere",
    "kasa_spheres",
    "minimum_zone_plane",
    "minimum_zone_sphere",
    "to_dict",
]
