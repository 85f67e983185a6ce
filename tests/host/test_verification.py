"""The verification quantities (aacmm.verification) on synthetic point sets.

Every expected value is built into the data (a sphere of known size with
residuals that leave its least-squares fit unchanged, centres at known
places, seats with known scatter) or recomputed here another way (the
smallest enclosing sphere by constrained optimisation, 2 sigma by hand).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import selfcert
import verify_sessions as vs
from aacmm import verification as v
from aacmm.geometry import GeometryError, TooFewPointsError
from aacmm.verification import rules
from hypothesis import given
from hypothesis import strategies as st

# ---------------------------------------------------------------- decision rules


@pytest.mark.parametrize(
    ("value", "mpe", "u", "rule", "verdict", "zone"),
    [
        (0.010, 0.020, 0.004, "simple", "PASS", rules.CONFORMANCE),
        (0.018, 0.020, 0.004, "simple", "PASS", rules.UNDECIDED),
        (0.020, 0.020, 0.004, "simple", "PASS", rules.UNDECIDED),  # on the limit: conforms
        (0.022, 0.020, 0.004, "simple", "FAIL", rules.UNDECIDED),
        (0.025, 0.020, 0.004, "simple", "FAIL", rules.NONCONFORMANCE),
        (0.016, 0.020, 0.004, "iso14253-1", "PASS", rules.CONFORMANCE),  # MPE - U exactly
        (0.0161, 0.020, 0.004, "iso14253-1", "FAIL", rules.UNDECIDED),
        (0.030, 0.020, 0.004, "iso14253-1", "FAIL", rules.NONCONFORMANCE),
        (0.010, None, 0.004, "iso14253-1", "NO MPE", ""),
        (math.nan, 0.020, 0.0, "simple", "FAIL", rules.NONCONFORMANCE),
    ],
)
def test_decide(
    value: float, mpe: float | None, u: float, rule: str, verdict: str, zone: str
) -> None:
    d = v.decide(value, mpe, u, rule)
    assert d.verdict == verdict and d.zone == zone
    if mpe is not None and math.isfinite(value):
        assert d.limit == pytest.approx(mpe if rule == "simple" else mpe - u)


def test_decide_bad() -> None:
    with pytest.raises(ValueError, match="unknown decision rule"):
        v.decide(0.01, 0.02, 0.0, "lenient")
    with pytest.raises(ValueError, match="conformance zone is empty"):
        v.decide(0.01, 0.02, 0.02, "iso14253-1")
    with pytest.raises(ValueError, match="uncertainty"):
        v.decide(0.01, 0.02, -1.0, "simple")
    d = [v.decide(0.01, 0.02, 0, "simple"), v.decide(0.01, None, 0, "simple")]
    assert v.overall(d) == "PASS"
    assert v.overall([*d, v.decide(0.03, 0.02, 0, "simple")]) == "FAIL"
    assert v.overall([v.decide(0.01, None, 0, "simple")]) == "NO MPE"


# ---------------------------------------------------------------- sphere size and form


def test_sphere_size_form_certified() -> None:
    # ball centres on a sphere of radius R + r, displaced radially by residuals the
    # least-squares fit cannot absorb: D = 2 R exactly, form = their range
    rng = np.random.default_rng(21)
    ball_r, cal_d, true_d = 1.0, 25.4, 25.4 + 0.006
    case = selfcert.sphere_case(rng, 25, true_d / 2 + ball_r, 90.0)
    pts, e = selfcert.certify(case, rng, 0.004)
    t = v.sphere_size_form(pts, cal_d, probe_radius=ball_r)
    assert t.size_error == pytest.approx(0.006, abs=1e-9)
    assert t.form == pytest.approx(float(np.ptp(e)), abs=1e-9)
    with pytest.raises(ValueError, match="calibrated diameter"):
        v.sphere_size_form(pts, 0.0)


# ---------------------------------------------------------------- articulated location


def test_smallest_enclosing_sphere() -> None:
    rng = np.random.default_rng(22)
    for n in (1, 2, 3, 4, 5, 8, 20, 60):
        p = rng.normal(size=(n, 3)) * rng.uniform(0.01, 100.0) + rng.uniform(-900, 900, 3)
        c, r = v.smallest_enclosing_sphere(p)
        assert np.max(np.linalg.norm(p - c, axis=1)) <= r * (1 + 1e-12) + 1e-12
        if n > 1:
            assert r == pytest.approx(vs.enclosing_radius(p), rel=1e-6)
    # degenerate sets: duplicates, collinear, four on one circle
    assert v.smallest_enclosing_sphere(np.tile([1.0, 2.0, 3.0], (5, 1)))[1] == 0.0
    line = np.outer(np.arange(6.0), [1.0, 2.0, 2.0])
    assert v.smallest_enclosing_sphere(line)[1] == pytest.approx(7.5)
    sq = np.array([[1.0, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], [0, -1.0, 0]])
    c, r = v.smallest_enclosing_sphere(sq)
    assert r == pytest.approx(1.0) and np.allclose(c, 0.0, atol=1e-12)


def test_articulated_location_known_centres() -> None:
    # five articulations see the sphere's centre at five known places: the origin
    # and the vertices of a regular tetrahedron of circumradius s around it, so
    # the smallest enclosing sphere has diameter 2 s
    s = 0.004
    tet = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]) / np.sqrt(3)
    centres = np.vstack([np.zeros(3), s * tet]) + np.array([500.0, -200.0, 100.0])
    pattern = np.array([[0, 0, 1.0], [1, 0, 1], [0, 1, 1], [-1, 0, 1], [0, -1, 1]])
    pattern /= np.linalg.norm(pattern, axis=1)[:, None]
    groups = [c + 13.7 * pattern for c in centres]  # ball radius 1 on a 25.4 mm sphere
    t = v.articulated_location(groups, probe_radius=1.0)
    assert t.l_dia == pytest.approx(2 * s, abs=1e-9)
    assert np.allclose(t.centers, centres, atol=1e-9)
    assert all(abs(2 * f.feature.radius - 25.4) < 1e-9 for f in t.fits)
    fixed = v.articulated_location(groups, probe_radius=1.0, cal_diameter=25.4)
    assert fixed.l_dia == pytest.approx(2 * s, abs=1e-9)
    assert all(f.dof == 2 for f in fixed.fits)
    with pytest.raises(TooFewPointsError):
        v.articulated_location(groups[:1])
    with pytest.raises(TooFewPointsError):
        v.articulated_location([g[:3] for g in groups])


# ---------------------------------------------------------------- lengths


def test_length_error_spheres_and_seats() -> None:
    rng = np.random.default_rng(23)
    a, b = (
        np.array([100.0, 20.0, 30.0]),
        np.array([100.0, 20.0, 30.0]) + 500.01 * np.array([0.6, 0.0, 0.8]),
    )
    d = rng.normal(size=(6, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    t = v.length_error(a + 13.7 * d, b + 13.7 * d, 500.0)
    assert t.error == pytest.approx(0.01, abs=1e-9) and t.end_a.method == "sphere"
    seat = v.length_error([a], [b], 500.0)
    assert seat.error == pytest.approx(0.01, abs=1e-9) and seat.end_b.method == "seat"
    with pytest.raises(ValueError, match="calibrated length"):
        v.length_error([a], [b], -1.0)
    with pytest.raises(GeometryError, match="coplanar"):
        v.length_error(a + 13.7 * np.c_[d[:, :2], np.zeros(6)], [b], 500.0, as_sphere=True)


def test_length_statistics() -> None:
    e = np.array([0.010, -0.004, 0.002, -0.012])
    s = v.length_statistics(e)
    assert s.max_abs == pytest.approx(0.012) and s.range == pytest.approx(0.022)
    # 2 sqrt((100 + 16 + 4 + 144) um^2 / 3)
    assert s.two_sigma == pytest.approx(2 * math.sqrt(264e-6 / 3))
    with pytest.raises(TooFewPointsError):
        v.length_statistics([0.01])


# ---------------------------------------------------------------- single point


def test_single_point_articulation_by_hand() -> None:
    base = np.array([300.0, -100.0, 50.0])
    offs = np.array(
        [
            [0.010, 0, 0],
            [-0.010, 0, 0],
            [0, 0.006, 0],
            [0, -0.006, 0],
            [0, 0, 0.002],
            [0, 0, -0.002],
        ]
    )
    t = v.single_point_articulation(base + offs)
    assert np.allclose(t.mean, base, atol=1e-12)
    # deviations 10, 10, 6, 6, 2, 2 um: 2 sqrt(280 um^2 / 5)
    assert t.two_sigma == pytest.approx(2 * math.sqrt(280e-6 / 5), rel=1e-9)
    assert t.max_deviation == pytest.approx(0.010, rel=1e-9)
    assert np.allclose(t.half_range, [0.010, 0.006, 0.002], atol=1e-12)
    assert t.max_half_range == pytest.approx(0.010, rel=1e-9)
    with pytest.raises(TooFewPointsError):
        v.single_point_articulation(base[None])


def test_definitions_are_marked() -> None:
    assert {d.status for d in v.DEFINITIONS.values()} <= {
        "public summary",
        "assumed (not verified against the standard's text)",
    }
    assert v.DEFINITIONS["L_Dia.5x5:Art:AArm"].status.startswith("assumed")


# ---------------------------------------------------------------- aacmm fit --points parser


@given(st.text(alphabet="0123456789,- x", max_size=20), st.integers(1, 60))
def test_point_selection_never_crashes(spec: str, n: int) -> None:
    from aacmm.commands.exitcodes import UsageError
    from aacmm.commands.fit import parse_selection

    try:
        idx = parse_selection(spec, n)
    except UsageError:
        return
    assert idx and len(set(idx)) == len(idx) and all(0 <= i < n for i in idx)


@given(st.lists(st.tuples(st.integers(1, 40), st.integers(0, 5)), min_size=1, max_size=6))
def test_point_selection_ranges(parts: list[tuple[int, int]]) -> None:
    from aacmm.commands.exitcodes import UsageError
    from aacmm.commands.fit import parse_selection

    n = 50
    spec = ",".join(f"{a}-{a + w}" if w else str(a) for a, w in parts)
    want = [i - 1 for a, w in parts for i in range(a, a + w + 1)]
    if len(set(want)) != len(want):
        with pytest.raises(UsageError, match="twice"):
            parse_selection(spec, n)
    else:
        assert parse_selection(spec, n) == want
