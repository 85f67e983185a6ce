"""Geometric fitting (aacmm.geometry) against published and self-certifying data.

- The Gander-Golub-Strebel (1994) circle: published geometric fit.
- Self-certifying data sets (null-space method, tests/host/selfcert.py: residual
  functions of their own and complex-step Jacobians) for every feature, including
  a 60-degree spherical cap: the nominal feature is the exact least-squares
  solution, to be found to 1e-9 mm.
- No radius bias on noisy 60-degree caps (1,000 seeded caps at 5 um and 50 um),
  where the algebraic fit is biased; the covariance against the scatter.
- Minimum zone against constructed data with a known zone and a brute-force search.
- Bad input: too few points, degenerate geometry, non-finite values.
"""

from __future__ import annotations

import zlib
from typing import Any

import numpy as np
import pytest
import selfcert
from aacmm import geometry as g
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

TOL_MM = 1e-9

# Gander, Golub, Strebel, BIT 34 (1994) 558-578, the circle example.
GGS_X = [1.0, 2.0, 5.0, 7.0, 9.0, 3.0]
GGS_Y = [7.0, 6.0, 8.0, 7.0, 5.0, 7.0]
GGS_CENTER = (4.739782, 2.983533)
GGS_RADIUS = 4.714226


def _ggs_points(rot: np.ndarray, offset: np.ndarray) -> np.ndarray:
    p = np.stack([GGS_X, GGS_Y, np.zeros(6)], axis=1)
    out: np.ndarray = p @ rot.T + offset
    return out


@pytest.mark.parametrize("placed", [False, True])
def test_ggs_circle(placed: bool) -> None:
    rot = Rotation.from_euler("xyz", [0.3, -1.1, 2.0]).as_matrix() if placed else np.eye(3)
    offset = np.array([700.0, -250.0, 410.0]) if placed else np.zeros(3)
    fit = g.fit_circle(_ggs_points(rot, offset))
    centre_plane = (np.asarray(fit.feature.center) - offset) @ rot
    assert abs(centre_plane[0] - GGS_CENTER[0]) < 1e-6
    assert abs(centre_plane[1] - GGS_CENTER[1]) < 1e-6
    assert abs(centre_plane[2]) < 1e-9
    assert abs(fit.feature.radius - GGS_RADIUS) < 1e-6
    assert abs(abs(np.asarray(fit.feature.normal) @ rot[:, 2]) - 1.0) < 1e-12


def test_ggs_algebraic_differs() -> None:
    # The algebraic (Kasa) fit is not the geometric one: recomputed here by
    # plain linear least squares on x^2 + y^2 = 2 a x + 2 b y + c.
    x, y = np.array(GGS_X), np.array(GGS_Y)
    a = np.stack([2 * x, 2 * y, np.ones(6)], axis=1)
    sol = np.linalg.lstsq(a, x * x + y * y, rcond=None)[0]
    r_ref = np.sqrt(sol[2] + sol[0] ** 2 + sol[1] ** 2)
    c, r = g.kasa_sphere(np.stack([x, y], axis=1))
    assert np.allclose(c, sol[:2], atol=1e-12) and abs(r - r_ref) < 1e-12
    assert abs(r - GGS_RADIUS) > 0.5


# ---------------------------------------------------------------- self-certifying data


def _dist_to_line(p: np.ndarray, x0: np.ndarray, d: np.ndarray) -> float:
    q = p - x0
    return float(np.linalg.norm(q - (q @ d) * d))


def _check_residuals(fit: g.Fit[Any], e: np.ndarray) -> None:
    assert np.max(np.abs(fit.residuals - e)) < TOL_MM
    assert abs(fit.form - float(np.ptp(e))) < 2 * TOL_MM


CASES = [
    ("sphere full", lambda r: selfcert.sphere_case(r, 25, 12.7, 180.0)),
    ("sphere hemisphere", lambda r: selfcert.sphere_case(r, 25, 12.7, 90.0)),
    ("sphere 60-degree cap", lambda r: selfcert.sphere_case(r, 25, 12.7, 30.0)),
    ("sphere 60-degree cap, 200 points", lambda r: selfcert.sphere_case(r, 200, 25.0, 30.0)),
    ("fixed-radius sphere, 60-degree cap", lambda r: selfcert.fixed_sphere_case(r, 25, 12.7, 30.0)),
    ("fixed-radius sphere, 5 points", lambda r: selfcert.fixed_sphere_case(r, 5, 12.7, 60.0)),
    ("plane", lambda r: selfcert.plane_case(r, 30, 150.0)),
    ("line", lambda r: selfcert.line_case(r, 20, 300.0)),
    ("point", lambda r: selfcert.point_case(r, 10)),
    ("circle full", lambda r: selfcert.circle_case(r, 16, 20.0, 360.0)),
    ("circle 90-degree arc", lambda r: selfcert.circle_case(r, 16, 20.0, 90.0)),
    ("cylinder full", lambda r: selfcert.cylinder_case(r, 40, 10.0, 60.0, 360.0)),
    ("cylinder short", lambda r: selfcert.cylinder_case(r, 40, 30.0, 8.0, 360.0)),
    ("cylinder 120-degree arc", lambda r: selfcert.cylinder_case(r, 60, 15.0, 50.0, 120.0)),
]


@pytest.mark.parametrize("size_mm", [0.005, 0.1])
@pytest.mark.parametrize(("name", "make"), CASES, ids=[c[0] for c in CASES])
def test_self_certifying(name: str, make, size_mm: float) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng([zlib.crc32(name.encode()), int(size_mm * 1e4)])
    case = make(rng)
    pts, e = selfcert.certify(case, rng, size_mm)
    nom = case.nominal
    kind = case.name.split()[0]
    if kind == "sphere":
        fit = g.fit_sphere(pts)
        assert np.max(np.abs(np.asarray(fit.feature.center) - nom["center"])) < TOL_MM
        assert abs(fit.feature.radius - nom["radius"]) < TOL_MM
        _check_residuals(fit, e[:, 0])
    elif kind == "fixed":
        ff = g.fit_sphere(pts, radius=float(nom["radius"]))
        assert np.max(np.abs(np.asarray(ff.feature.center) - nom["center"])) < TOL_MM
        assert ff.feature.radius == nom["radius"] and ff.dof == len(pts) - 3
        _check_residuals(ff, e[:, 0])
    elif kind == "plane":
        fp = g.fit_plane(pts)
        n = np.asarray(fp.feature.normal)
        assert np.linalg.norm(np.cross(n, nom["normal"])) * 106.0 < TOL_MM  # at the corners
        assert abs((np.asarray(fp.feature.point) - nom["point"]) @ nom["normal"]) < TOL_MM
        _check_residuals(fp, e[:, 0] * np.sign(n @ nom["normal"]))
    elif kind == "line":
        fl = g.fit_line(pts)
        d = np.asarray(fl.feature.direction)
        assert np.linalg.norm(np.cross(d, nom["direction"])) * 150.0 < TOL_MM
        assert _dist_to_line(np.asarray(fl.feature.point), nom["point"], nom["direction"]) < TOL_MM
        assert np.max(np.abs(fl.residuals - np.hypot(e[:, 0], e[:, 1]))) < TOL_MM
    elif kind == "point":
        fq = g.fit_point(pts)
        assert np.max(np.abs(np.asarray(fq.feature.center) - nom["center"])) < TOL_MM
        assert np.max(np.abs(fq.residuals - np.linalg.norm(e, axis=1))) < TOL_MM
    elif kind == "circle":
        fc = g.fit_circle(pts)
        assert np.max(np.abs(np.asarray(fc.feature.center) - nom["center"])) < TOL_MM
        assert abs(fc.feature.radius - nom["radius"]) < TOL_MM
        assert np.linalg.norm(np.cross(fc.feature.normal, nom["normal"])) * 20.0 < TOL_MM
        _check_residuals(fc, e[:, 0])
        assert abs(fc.extra["out_of_plane_form"] - float(np.ptp(e[:, 1]))) < 2 * TOL_MM
    else:
        fy = g.fit_cylinder(pts)
        ax = np.asarray(fy.feature.axis)
        assert np.linalg.norm(np.cross(ax, nom["axis"])) * 30.0 < TOL_MM  # at the ends
        assert _dist_to_line(np.asarray(fy.feature.point), nom["point"], nom["axis"]) < TOL_MM
        assert abs(fy.feature.radius - nom["radius"]) < TOL_MM
        _check_residuals(fy, e[:, 0])


# ---------------------------------------------------------------- bias on partial spheres

CAPS = 1000
CAP_POINTS = 25
CAP_RADIUS = 12.7  # a 25.4 mm test sphere
CAP_HALF_ANGLE = 30.0  # a 60-degree cap (included angle)


def _noisy_caps(seed: int, sigma: float) -> np.ndarray:
    """1,000 seeded 60-degree caps, 25 points, isotropic Gaussian noise sigma per axis."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(np.cos(np.radians(CAP_HALF_ANGLE)), 1.0, (CAPS, CAP_POINTS))
    phi = rng.uniform(0.0, 2 * np.pi, (CAPS, CAP_POINTS))
    s = np.sqrt(1 - z * z)
    u = np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=-1)
    centres = rng.uniform(-500, 500, (CAPS, 1, 3))
    out: np.ndarray = centres + CAP_RADIUS * u + rng.normal(scale=sigma, size=u.shape)
    return out


@pytest.mark.parametrize(("sigma", "seed"), [(0.005, 11), (0.050, 12)])
def test_no_radius_bias_on_caps(sigma: float, seed: int) -> None:
    pts = _noisy_caps(seed, sigma)
    fits = g.fit_spheres(pts)
    err = fits.radii - CAP_RADIUS
    se = err.std(ddof=1) / np.sqrt(CAPS)
    z = err.mean() / se
    print(
        f"sigma {sigma * 1e3:g} um: geometric mean radius error {err.mean() * 1e3:+.3f} um "
        f"= {z:+.2f} standard errors (SE {se * 1e3:.3f} um)"
    )
    assert abs(z) < 3.0
    # The covariance predicts the scatter of the radius: mean squared error
    # against the mean predicted variance (a few caps with bunched points
    # dominate both, so the ratio scatters by ~4 % between seeds).
    ratio = np.sqrt(np.mean(err**2) / np.mean(fits.covariance[:, 3, 3]))
    assert abs(ratio - 1.0) < 0.1
    # the algebraic fit on the same caps: biased low, visibly so at 50 um
    _, kr = g.kasa_spheres(pts)
    kerr = kr - CAP_RADIUS
    kz = kerr.mean() / (kerr.std(ddof=1) / np.sqrt(CAPS))
    print(
        f"sigma {sigma * 1e3:g} um: algebraic mean radius error {kerr.mean() * 1e3:+.3f} um "
        f"= {kz:+.2f} standard errors"
    )
    if sigma >= 0.05:
        assert kz < -10.0


def test_batch_matches_single() -> None:
    pts = _noisy_caps(3, 0.02)[:20]
    b = g.fit_spheres(pts)
    for i in range(20):
        f = g.fit_sphere(pts[i])
        assert np.allclose(f.feature.center, b.centers[i], atol=1e-10)
        assert abs(f.feature.radius - b.radii[i]) < 1e-10


# ---------------------------------------------------------------- probe compensation


def test_probe_compensation() -> None:
    rng = np.random.default_rng(5)
    u = rng.normal(size=(30, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    u[:, 2] = np.abs(u[:, 2])
    c = np.array([100.0, 50.0, -20.0])
    ball = 1.5
    outer = g.fit_sphere(c + (12.7 + ball) * u, probe_radius=ball)
    assert abs(outer.feature.radius - 12.7) < 1e-12
    inner = g.fit_sphere(c + (20.0 - ball) * u, probe_radius=ball, inner=True)
    assert abs(inner.feature.radius - 20.0) < 1e-12
    # a plane probed from +z: ball centres 1.5 mm above the surface z = 3
    xy = rng.uniform(-50, 50, (20, 2))
    pl = g.fit_plane(np.c_[xy, np.full(20, 3.0 + ball)], probe_radius=ball, outward=(0, 0.1, 1))
    assert abs(pl.feature.point[2] - 3.0) < 1e-12 and pl.feature.normal[2] > 0.999
    with pytest.raises(ValueError, match="outward"):
        g.fit_plane(np.c_[xy, np.zeros(20)], probe_radius=ball)
    with pytest.raises(g.GeometryError, match="not larger than the probe radius"):
        g.fit_sphere(c + 1.0 * u, probe_radius=ball)
    # a bore: ball centres on radius 9 - 1.5 about the z axis
    phi = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    ring = np.c_[7.5 * np.cos(phi), 7.5 * np.sin(phi), np.tile([0.0, 10.0, 20.0], 8)]
    cyl = g.fit_cylinder(ring, probe_radius=ball, inner=True)
    assert abs(cyl.feature.radius - 9.0) < 1e-12
    circ = g.fit_circle(ring[ring[:, 2] == 0.0], probe_radius=ball, inner=True)
    assert abs(circ.feature.radius - 9.0) < 1e-12


# ---------------------------------------------------------------- minimum zone


def test_minimum_zone_sphere_known() -> None:
    # Contacts on two concentric spheres R +- t: outer ones along the vertices of a
    # regular tetrahedron, inner ones along the opposite directions. Any centre
    # shift raises the zone to first order, so the minimum zone is exactly 2 t;
    # further points lie strictly inside. The least-squares centre is elsewhere.
    tet = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]) / np.sqrt(3)
    rng = np.random.default_rng(8)
    extra = rng.normal(size=(20, 3))
    extra /= np.linalg.norm(extra, axis=1)[:, None]
    r, t = 12.5, 0.004
    c = np.array([40.0, -10.0, 300.0])
    pts = np.concatenate(
        [
            c + (r + t) * tet,
            c - (r - t) * tet,
            c + (r + rng.uniform(-0.5, 0.9, (20, 1)) * t) * extra,
        ]
    )
    mz = g.minimum_zone_sphere(pts)
    assert abs(mz.form - 2 * t) < 1e-10
    assert np.max(np.abs(np.asarray(mz.feature.center) - c)) < 1e-8
    assert mz.form <= g.fit_sphere(pts).form + 1e-15


def test_minimum_zone_plane_known() -> None:
    # Three contacts on z = +t forming a triangle, one on z = -t inside it (the
    # 3-1 rule): the zone is exactly 2 t; further points between. Then placed.
    t = 0.003
    top = np.array([[-50.0, -40.0, t], [60.0, -30.0, t], [0.0, 55.0, t]])
    bottom = np.array([[5.0, 2.0, -t]])
    rng = np.random.default_rng(9)
    mid = np.c_[rng.uniform(-40, 40, (25, 2)), rng.uniform(-0.99 * t, 0.99 * t, 25)]
    mid = mid[np.abs(mid[:, 0]) + np.abs(mid[:, 1]) < 45]  # within the triangle's span
    pts = np.concatenate([top, bottom, mid])
    rot = Rotation.from_euler("zyx", [0.4, 1.0, -0.3]).as_matrix()
    placed = pts @ rot.T + np.array([300.0, 200.0, -100.0])
    mz = g.minimum_zone_plane(placed)
    assert abs(mz.form - 2 * t) < 1e-10
    assert np.linalg.norm(np.cross(mz.feature.normal, rot[:, 2])) < 1e-10


def _width(q: np.ndarray, ang: np.ndarray) -> float:
    d = np.array([np.sin(ang[0]) * np.cos(ang[1]), np.sin(ang[0]) * np.sin(ang[1]), np.cos(ang[0])])
    pr = q @ d
    return float(pr.max() - pr.min())


def test_minimum_zone_random_vs_search() -> None:
    rng = np.random.default_rng(10)
    for _ in range(5):
        pl = np.c_[rng.uniform(-60, 60, (40, 2)), rng.normal(scale=0.01, size=40)]
        pl[:, 2] += 0.0005 * pl[:, 0] ** 2 / 60  # a little curvature
        mz = g.minimum_zone_plane(pl)
        ls = g.fit_plane(pl)
        assert mz.form <= ls.form + 1e-15
        # a local search of the exact width from the least-squares normal cannot beat it
        n0 = np.asarray(ls.feature.normal)
        a0 = np.array([np.arccos(n0[2]), np.arctan2(n0[1], n0[0])])
        best = minimize(
            lambda a, pl=pl: _width(pl, a),
            a0,
            method="Nelder-Mead",
            options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 4000},
        )
        assert mz.form <= best.fun + 1e-12
        sp = rng.normal(size=(30, 3))
        sp /= np.linalg.norm(sp, axis=1)[:, None]
        sp = 20.0 * sp + rng.normal(scale=0.01, size=sp.shape)
        mzs = g.minimum_zone_sphere(sp)
        assert mzs.form <= g.fit_sphere(sp).form + 1e-15
        nm = minimize(
            lambda c, sp=sp: float(np.ptp(np.linalg.norm(sp - c, axis=1))),
            np.asarray(g.fit_sphere(sp).feature.center),
            method="Nelder-Mead",
            options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 4000},
        )
        assert mzs.form <= nm.fun + 1e-10


# ---------------------------------------------------------------- bad input


def test_bad_input() -> None:
    line_pts = np.outer(np.linspace(0, 1, 10), [1.0, 2.0, 3.0])
    with pytest.raises(g.DegenerateGeometryError, match="collinear"):
        g.fit_plane(line_pts)
    with pytest.raises(g.DegenerateGeometryError, match="collinear"):
        g.fit_circle(line_pts)
    with pytest.raises(g.DegenerateGeometryError, match="collinear"):
        g.minimum_zone_plane(line_pts)
    phi = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    ring = np.c_[10 * np.cos(phi), 10 * np.sin(phi), np.zeros(12)]
    with pytest.raises(g.DegenerateGeometryError, match="coplanar"):
        g.fit_sphere(ring)
    with pytest.raises(g.DegenerateGeometryError):
        g.fit_cylinder(ring)
    with pytest.raises(g.DegenerateGeometryError, match="coincide"):
        g.fit_line(np.tile([1.0, 2.0, 3.0], (5, 1)))
    with pytest.raises(g.TooFewPointsError, match="at least 4"):
        g.fit_sphere(ring[:3])
    with pytest.raises(g.TooFewPointsError):
        g.fit_cylinder(ring[:4])
    with pytest.raises(g.TooFewPointsError):
        g.fit_plane(ring[:2])
    bad = ring.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        g.fit_circle(bad)
    with pytest.raises(ValueError, match="shape"):
        g.fit_sphere(np.zeros((5, 2)))
    # every error is a ValueError (exit status 2 in the CLI)
    assert issubclass(g.GeometryError, ValueError)


def test_fit_dict_is_json() -> None:
    import json

    f = g.fit_sphere(_noisy_caps(1, 0.01)[0])
    d = g.to_dict(f)
    assert json.loads(json.dumps(d))["feature"]["radius"] == f.feature.radius
