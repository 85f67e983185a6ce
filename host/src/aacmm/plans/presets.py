"""Probing arrangements: where on an artefact the points of a step go.

Directions are unit vectors in the arm's base frame, from the centre of the
feature towards the probe ball centre (the outward surface normal at the
contact point). All arrangements are pure functions of their arguments, so
the simulated operator, capture's prompts and the analysis see the same
targets.

* :func:`iso10360_sphere_25` -- the 25-point arrangement used for the
  ISO 10360-12 probing test (P_Size.Sph.1x25 / P_Form.Sph.1x25). The text of
  ISO 10360-12 is not public; we use the 25-point pattern of ISO 10360-5 as
  it is publicly described: 1 point at the pole, 4 points at 22.5 deg from
  the pole, 8 at 45 deg, 4 at 67.5 deg and 8 on the equator (90 deg), each
  ring turned 22.5 deg against the one before. Exact angles in
  docs/plans.md.
* :func:`ring_pattern` -- one point at the pole and the others on one ring
  (the 5-point groups of the articulated location test, the ends of a ball
  bar with spheres).
* :func:`spiral_cap` -- N points spread evenly over a spherical cap (a
  golden-angle spiral), for a sphere step of any N.
* :func:`plane_grid` -- N points on a near-square grid in a rectangle.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: (polar angle from the pole in deg, number of points, azimuth of the first point in deg)
ISO_25_RINGS: tuple[tuple[float, int, float], ...] = (
    (0.0, 1, 0.0),
    (22.5, 4, 0.0),
    (45.0, 8, 22.5),
    (67.5, 4, 45.0),
    (90.0, 8, 67.5),
)
#: Polar angle of the ring of :func:`ring_pattern` (deg): the 4 side points of
#: a 5-point group sit 60 deg from the pole.
RING_POLAR_DEG = 60.0
GOLDEN_ANGLE_RAD = math.pi * (3.0 - math.sqrt(5.0))


def unit(v: npt.ArrayLike) -> FloatArray:
    """``v`` scaled to length 1. Raises ValueError for a zero or non-finite vector."""
    a = np.asarray(v, dtype=np.float64).reshape(3)
    n = float(np.linalg.norm(a))
    if not (math.isfinite(n) and n > 0.0):
        raise ValueError("a direction must be a finite, non-zero vector")
    return a / n


def frame(pole: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
    """A right-handed orthonormal frame (u, v, w) with w along ``pole``.

    u is the base axis least aligned with the pole, made orthogonal to it,
    so the frame is a deterministic function of the pole.
    """
    w = unit(pole)
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(w)))] = 1.0
    u = helper - float(helper @ w) * w
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    return u, v, w


def _spherical(polar_deg: float, azimuth_deg: float, pole: npt.ArrayLike) -> FloatArray:
    u, v, w = frame(pole)
    p, a = math.radians(polar_deg), math.radians(azimuth_deg)
    d: FloatArray = math.sin(p) * (math.cos(a) * u + math.sin(a) * v) + math.cos(p) * w
    return d


def iso10360_sphere_25(pole: npt.ArrayLike = (0.0, 0.0, 1.0)) -> FloatArray:
    """The 25 probing directions of the ISO 10360 sphere test, shape (25, 3)."""
    out = [
        _spherical(polar, first + k * 360.0 / n, pole)
        for polar, n, first in ISO_25_RINGS
        for k in range(n)
    ]
    return np.array(out)


def ring_pattern(
    n: int, pole: npt.ArrayLike = (0.0, 0.0, 1.0), polar_deg: float = RING_POLAR_DEG
) -> FloatArray:
    """One direction at the pole and ``n - 1`` equally spaced on a ring, shape (n, 3)."""
    if n < 1:
        raise ValueError("a ring pattern needs at least 1 point")
    out = [_spherical(0.0, 0.0, pole)]
    out += [_spherical(polar_deg, k * 360.0 / (n - 1), pole) for k in range(n - 1)]
    return np.array(out)


def spiral_cap(
    n: int, pole: npt.ArrayLike = (0.0, 0.0, 1.0), max_polar_deg: float = 90.0
) -> FloatArray:
    """``n`` directions spread evenly (equal area) over the cap within ``max_polar_deg``
    of the pole, on a golden-angle spiral; shape (n, 3)."""
    if n < 1:
        raise ValueError("a spiral needs at least 1 point")
    u, v, w = frame(pole)
    c_min = math.cos(math.radians(max_polar_deg))
    out = []
    for k in range(n):
        c = 1.0 - (k + 0.5) / n * (1.0 - c_min)
        s = math.sqrt(max(0.0, 1.0 - c * c))
        a = k * GOLDEN_ANGLE_RAD
        out.append(s * (math.cos(a) * u + math.sin(a) * v) + c * w)
    return np.array(out)


def plane_grid(
    n: int, normal: npt.ArrayLike, size_mm: tuple[float, float]
) -> tuple[FloatArray, FloatArray]:
    """``n`` offsets (mm) in a plane through the origin, on a near-square grid filling
    ``size_mm`` (width along u, height along v of :func:`frame` of the normal).

    Returns (offsets (n, 3), unit normal (3,)).
    """
    if n < 1:
        raise ValueError("a grid needs at least 1 point")
    u, v, w = frame(normal)
    cols = math.ceil(math.sqrt(n))
    rows = math.ceil(n / cols)
    out = []
    for k in range(n):
        r, c = divmod(k, cols)
        fx = (c + 0.5) / cols - 0.5
        fy = (r + 0.5) / rows - 0.5
        out.append(fx * size_mm[0] * u + fy * size_mm[1] * v)
    return np.array(out), w
