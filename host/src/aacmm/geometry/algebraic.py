"""Algebraic (Kasa) sphere and circle fits: start values for the geometric fits.

The algebraic fit minimises the sum of ``(|p - c|^2 - r^2)^2``, which is linear
in ``(c, r^2 - |c|^2)`` and needs no start value, but it is not the
orthogonal-distance fit: it is biased towards small radii, worst on partial
arcs and caps. It is exported so that the bias can be shown (docs/verification.md);
measurement results come from the geometric fits.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aacmm.geometry._base import FloatArray


def kasa_spheres(points: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Algebraic sphere fits of a batch: centres (B, d) and radii (B,) from points (B, n, d).

    Works in any dimension ``d`` (2: circles in the plane, 3: spheres).
    Degenerate input gives the minimum-norm solution (check with the geometric fit).
    """
    p = np.asarray(points, dtype=np.float64)
    c0 = p.mean(axis=-2, keepdims=True)
    q = p - c0  # centred: keeps the linear system well conditioned far from the origin
    a = np.concatenate([2.0 * q, np.ones((*q.shape[:-1], 1))], axis=-1)
    b = np.sum(q**2, axis=-1)
    sol = np.einsum("...ij,...j->...i", np.linalg.pinv(a), b)
    centre = sol[..., :-1]
    r2 = sol[..., -1] + np.sum(centre**2, axis=-1)
    radius = np.sqrt(np.maximum(r2, 0.0))
    out: FloatArray = centre + c0[..., 0, :]
    return out, radius


def kasa_sphere(points: npt.ArrayLike) -> tuple[FloatArray, float]:
    """Algebraic sphere (or, for (n, 2) points, circle) fit: centre and radius."""
    c, r = kasa_spheres(np.asarray(points, dtype=np.float64)[None])
    return c[0], float(r[0])
