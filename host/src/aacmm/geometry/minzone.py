"""Minimum-zone (Chebyshev) form of a plane and of a sphere.

The minimum-zone form is the smallest separation of two parallel planes (two
concentric spheres) that enclose every point: the definition of flatness and
sphericity in ISO 12781 / ISO 1101. It is never larger than the
least-squares form (the range of the least-squares residuals), which ISO
10360-12 prescribes for P_Form.

- Plane: exact. The minimum width of a point set is attained by a direction
  normal to a face of its convex hull, or normal to two hull edges, one on
  each side (Houle and Toussaint 1988); every such candidate is evaluated.
- Sphere: sequential linear programming from the least-squares centre (the
  zone linearised in the centre shift, solved with scipy's HiGHS, inside a
  trust region that shrinks when a step does not pay). The sphericity
  problem is not convex, so this is a local minimum near the least-squares
  centre: the one metrology means for data from a sphere.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aacmm.geometry._base import FloatArray, GeometryError, as_points, extent, unit
from aacmm.geometry.curved import Sphere, fit_spheres
from aacmm.geometry.linear import Plane, fit_plane

#: Hull-candidate directions evaluated per chunk (bounds memory: chunk x hull vertices).
_CHUNK = 4096
#: Refuse the exact plane search beyond this many edge pairs (a huge hull).
MAX_EDGE_PAIRS = 4_000_000


@dataclass(frozen=True)
class MinZone:
    """A minimum-zone result.

    ``form`` is the zone width (mm). For a plane, ``feature`` is the mid
    plane and ``low``/``high`` the offsets of the two enclosing planes along
    its normal from ``feature.point``; for a sphere, ``feature`` has the mid
    radius and ``low``/``high`` are the inner and outer radii.
    """

    kind: str
    feature: Any
    form: float
    low: float
    high: float
    iterations: int
    method: str


def _hull_candidates(q: FloatArray, n0: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Hull vertices and candidate directions of centred points q, LS normal n0."""
    from scipy.spatial import ConvexHull, QhullError

    # The hull's combinatorics are affine invariant: stretch the thin direction
    # so Qhull sees a fat set, then measure in the original coordinates.
    h = q @ n0
    thick = float(np.ptp(h))
    stretch = extent(q) / thick if thick > 0 else 1.0
    try:
        hull = ConvexHull(q + np.outer(h * (stretch - 1.0), n0))
    except QhullError as exc:
        raise GeometryError(f"minimum zone: the convex hull failed ({exc})") from None
    tri = hull.simplices
    a, b, c = q[tri[:, 0]], q[tri[:, 1]], q[tri[:, 2]]
    faces = np.cross(b - a, c - a)
    # outward face normals in the original coordinates (the centroid, the
    # origin of q, is inside the hull)
    faces[np.einsum("ij,ij->i", faces, a) < 0] *= -1.0
    upper = faces @ n0 > 0
    edges: dict[bool, set[tuple[int, int]]] = {True: set(), False: set()}
    for t, is_up in zip(tri, upper, strict=True):
        for i, j in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            edges[bool(is_up)].add((min(i, j), max(i, j)))
    eu = np.array(sorted(edges[True]), dtype=np.intp).reshape(-1, 2)
    el = np.array(sorted(edges[False]), dtype=np.intp).reshape(-1, 2)
    if len(eu) * len(el) > MAX_EDGE_PAIRS:
        raise GeometryError(
            f"minimum zone: the convex hull has {len(eu)} x {len(el)} edge pairs "
            f"(more than {MAX_EDGE_PAIRS}); use fewer points"
        )
    vu = q[eu[:, 1]] - q[eu[:, 0]]
    vl = q[el[:, 1]] - q[el[:, 0]]
    pairs = np.cross(vu[:, None, :], vl[None, :, :]).reshape(-1, 3)
    dirs = np.concatenate([faces, pairs])
    norms = np.linalg.norm(dirs, axis=1)
    dirs = dirs[norms > 1e-12 * max(float(norms.max()), 1e-300)]
    verts = q[hull.vertices]
    return verts, unit(dirs)


def minimum_zone_plane(points: npt.ArrayLike) -> MinZone:
    """The minimum-zone (Chebyshev) flatness of (n >= 3, 3) points.

    Raises:
        ValueError, TooFewPointsError, DegenerateGeometryError (collinear points),
        GeometryError (the exact search would be too large).
    """
    p = as_points(points, 3, "plane")
    ls = fit_plane(p)
    c = p.mean(axis=0)
    q = p - c
    n0 = np.asarray(ls.feature.normal)
    if ls.form <= 1e-13 * extent(p):
        return MinZone(
            "plane",
            ls.feature,
            ls.form,
            float(min(ls.residuals)),
            float(max(ls.residuals)),
            0,
            "exact",
        )
    verts, dirs = _hull_candidates(q, n0)
    best_w, best_d = np.inf, n0
    for k in range(0, len(dirs), _CHUNK):
        d = dirs[k : k + _CHUNK]
        proj = verts @ d.T
        w = proj.max(axis=0) - proj.min(axis=0)
        i = int(np.argmin(w))
        if w[i] < best_w:
            best_w, best_d = float(w[i]), d[i]
    if best_d @ n0 < 0:
        best_d = -best_d
    proj = q @ best_d
    lo, hi = float(proj.min()), float(proj.max())
    mid = 0.5 * (lo + hi)
    plane = Plane(tuple(map(float, c + mid * best_d)), tuple(map(float, best_d)))  # type: ignore[arg-type]
    return MinZone("plane", plane, hi - lo, lo - mid, hi - mid, 1, "exact")


def minimum_zone_sphere(points: npt.ArrayLike, max_iter: int = 200) -> MinZone:
    """The minimum-zone (Chebyshev) sphericity of (n >= 4, 3) points.

    Starts at the least-squares centre (see the module notes: a local minimum).

    Raises:
        ValueError, TooFewPointsError, DegenerateGeometryError (coplanar),
        ConvergenceError (of the least-squares start).
    """
    from scipy.optimize import linprog

    p = as_points(points, 4, "sphere")
    c0 = p.mean(axis=0)
    q = p - c0
    ext = extent(p)
    c = fit_spheres(p[None]).centers[0] - c0
    dist = np.linalg.norm(q - c, axis=1)
    zone = float(np.ptp(dist))
    delta = 0.05 * ext
    it = 0
    while it < max_iter:
        it += 1
        g = -(q - c) / dist[:, None]
        n = len(dist)
        a_ub = np.block(
            [[g, -np.ones((n, 1)), np.zeros((n, 1))], [-g, np.zeros((n, 1)), np.ones((n, 1))]]
        )
        b_ub = np.concatenate([-dist, dist])
        bounds = [(-delta, delta)] * 3 + [(None, None)] * 2
        lp = linprog(
            np.array([0, 0, 0, 1.0, -1.0]), A_ub=a_ub, b_ub=b_ub, bounds=bounds, method="highs"
        )
        if lp.status != 0:
            break
        step = lp.x[:3]
        trial = c + step
        d_t = np.linalg.norm(q - trial, axis=1)
        z_t = float(np.ptp(d_t))
        if z_t < zone:
            c, dist, zone = trial, d_t, z_t
            if float(np.max(np.abs(step))) <= 1e-13 * ext:
                break
        else:
            delta = 0.25 * float(np.max(np.abs(step)))
            if delta <= 1e-13 * ext:
                break
    lo, hi = float(dist.min()), float(dist.max())
    sph = Sphere(tuple(map(float, c + c0)), 0.5 * (lo + hi))  # type: ignore[arg-type]
    return MinZone("sphere", sph, hi - lo, lo, hi, it, "sequential LP")
