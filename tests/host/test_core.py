"""aacmm.core: the cffi-bound C core against the independent numpy oracle."""

from __future__ import annotations

import math

import numpy as np
import pytest
from aacmm.core import (
    PARAM_NAMES,
    EncoderConfig,
    KinematicsError,
    Model,
    Params,
    counts_to_angles,
    perturbed_points,
)
from test_core_oracle import numpy_point_jacobian, random_params

pytestmark = pytest.mark.timeout(60)


def _rel_err(a: np.ndarray, b: np.ndarray) -> float:
    """Largest error relative to each pose's largest |entry| (entries near 0 included)."""
    scale = np.max(np.abs(b).reshape(b.shape[0], -1), axis=1)
    err = np.max(np.abs(a - b).reshape(a.shape[0], -1), axis=1)
    return float(np.max(err / scale))


def test_param_names_follow_jacobian_columns() -> None:
    assert len(PARAM_NAMES) == 25
    assert PARAM_NAMES[0] == "theta1" and PARAM_NAMES[6] == "alpha1"
    assert PARAM_NAMES[12] == "d1" and PARAM_NAMES[18] == "a1" and PARAM_NAMES[24] == "l"


def test_paper_params_match_c_default() -> None:
    from aacmm._core import ffi, lib

    c = ffi.new("aacmm_params_f64_t *")
    assert lib.aacmm_params_default_f64(c) == 0
    p = Params.paper()
    assert list(c.d_mm) == list(p.d_mm) and c.l_mm == p.l_mm
    assert list(c.alpha_rad) == list(p.alpha_rad) and list(c.a_mm) == list(p.a_mm)
    assert Params.from_vector(p.to_vector()) == p


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_batch_matches_numpy_to_1e9(seed: int) -> None:
    rng = np.random.default_rng(seed)
    prm = Params() if seed == 1 else random_params(rng)
    th = rng.uniform(-math.pi, math.pi, (2000, 6))
    p, j = Model(prm).points_jacobians(th)
    p_ref, j_ref = numpy_point_jacobian(prm, th)
    assert _rel_err(j, j_ref) < 1e-9
    assert np.max(np.abs(p - p_ref)) / np.max(np.abs(p_ref)) < 1e-9
    # entrywise too, for every entry not tiny against its pose's scale
    big = np.abs(j_ref) > 1e-3
    assert np.all(np.abs(j - j_ref)[big] <= 1e-9 * np.abs(j_ref)[big])


def test_single_pose_equals_batch_and_points_only() -> None:
    rng = np.random.default_rng(5)
    th = rng.uniform(-3, 3, (10, 6))
    m = Model()
    p, j = m.points_jacobians(th)
    p1, j1 = m.point_jacobian(th[3])
    assert np.array_equal(p1, p[3]) and np.array_equal(j1, j[3])
    assert np.array_equal(m.points(th), p)
    assert np.array_equal(m.point(list(th[4])), p[4])


def test_abs_sums_match_stored_jacobians() -> None:
    rng = np.random.default_rng(11)
    th = rng.uniform(-math.pi, math.pi, (3000, 6))
    m = Model(random_params(rng))
    s, q = m.abs_jacobian_sums(th)
    _, j = m.points_jacobians(th)
    assert np.allclose(s, np.abs(j).sum(axis=0), rtol=1e-12)
    assert np.allclose(q, (j**2).sum(axis=0), rtol=1e-12)


def test_counts_to_angles() -> None:
    quarter = 1 << 30
    th = counts_to_angles([[quarter, 0, (1 << 32) - quarter, 1 << 31, 1, 0]])
    assert th[0, 0] == pytest.approx(math.pi / 2, abs=0)
    assert th[0, 1] == 0.0
    assert th[0, 2] == pytest.approx(-math.pi / 2, abs=0)
    assert abs(th[0, 3]) == pytest.approx(math.pi, abs=0)
    enc = EncoderConfig(
        counts_per_rev=(3600,) * 6, zero_offset_counts=(100,) * 6, direction=(1, -1, 1, 1, 1, 1)
    )
    th = counts_to_angles(np.array([[1000, 1000, 50, 100, 100, 100]]), enc)
    assert th[0, 0] == pytest.approx(math.radians(90.0), rel=1e-15)
    assert th[0, 1] == pytest.approx(-math.radians(90.0), rel=1e-15)
    assert th[0, 2] == pytest.approx(-math.radians(5.0), rel=1e-15)
    with pytest.raises(KinematicsError) as ei:
        counts_to_angles(np.array([[0] * 6, [3600, 0, 0, 0, 0, 0]]), enc)
    assert ei.value.index == 1
    with pytest.raises(ValueError, match=r"0 \.\. 2"):
        counts_to_angles(np.array([[-1, 0, 0, 0, 0, 0]]))
    with pytest.raises(ValueError, match="direction"):
        counts_to_angles([[0] * 6], EncoderConfig(direction=(2, 1, 1, 1, 1, 1)))


def test_points_from_counts_equal_angles_path() -> None:
    rng = np.random.default_rng(21)
    enc = EncoderConfig(
        counts_per_rev=(1 << 20,) * 6, zero_offset_counts=(77,) * 6, direction=(1, -1, 1, -1, 1, -1)
    )
    counts = rng.integers(0, 1 << 20, (200, 6))
    m = Model(random_params(rng))
    p, j = m.points_from_counts(counts, enc)
    p2, j2 = m.points_jacobians(counts_to_angles(counts, enc))
    assert np.array_equal(p, p2) and np.array_equal(j, j2)
    counts[150, 4] = 1 << 20
    with pytest.raises(KinematicsError) as ei:
        m.points_from_counts(counts, enc)
    assert ei.value.index == 150


def test_bad_inputs_raise_value_errors() -> None:
    with pytest.raises(KinematicsError, match="out of range") as ei:
        Model(Params(l_mm=20000.0))
    assert ei.value.status == -2
    with pytest.raises(ValueError, match="6 values"):
        Params(d_mm=(1.0, 2.0))
    with pytest.raises(KinematicsError, match="not finite"):
        Params(alpha_rad=(math.nan,) * 6).validate()
    m = Model()
    th = np.zeros((5, 6))
    th[3, 2] = 2000.0
    with pytest.raises(KinematicsError) as ei:
        m.points_jacobians(th)
    assert ei.value.index == 3 and isinstance(ei.value, ValueError)
    with pytest.raises(ValueError, match="shape"):
        m.points(np.zeros((4, 5)))


def test_perturbed_points_equal_perturbed_models() -> None:
    rng = np.random.default_rng(3)
    th = rng.uniform(-3, 3, (7, 6))
    delta = rng.normal(0, 1e-3, (4, 25))
    nominal = Params()
    out = perturbed_points(nominal, delta, th)
    assert out.shape == (4, 7, 3)
    for t in range(4):
        m = Model(Params.from_vector(nominal.to_vector() + delta[t]))
        assert np.array_equal(out[t], m.points(th))
    bad = np.zeros((3, 25))
    bad[2, 24] = 1e6  # l beyond 10 m
    with pytest.raises(KinematicsError) as ei:
        perturbed_points(nominal, bad, th)
    assert ei.value.index == 2
