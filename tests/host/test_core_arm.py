"""The Python binding of the general arm model (issue 26): aacmm.arm.Arm and
aacmm.core.Model of any arm, against an independent numpy oracle.

The oracle multiplies the elementary 4x4 matrices of each joint in the
documented order (standard: [Ry(beta)] Rz(theta) Tz(d) Tx(a) Rx(alpha);
modified: Rx(alpha) Tx(a) [Ry(beta)] Rz(theta) Tz(d)) and takes each
Jacobian column as the same product with that one factor replaced by its
derivative (the product rule; no differences, no shared code with the C
core's frame recursion). The C suites (tests/core/test_arm.c) hold the core
to 1e-12 against a long-double reference; here the bound is numpy's own
rounding.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
import numpy.typing as npt
import pytest
from aacmm import core
from aacmm.arm import Arm, Joint
from aacmm.core import EncoderConfig, KinematicsError, Model, Params, perturbed_points

pytestmark = pytest.mark.timeout(120)
F = npt.NDArray[np.float64]


def _rot(axis: str, t: float, deriv: bool = False) -> F:
    c, s = math.cos(t), math.sin(t)
    if deriv:
        c, s = -s, c  # d/dt of (cos, sin)
    m = np.zeros((4, 4)) if deriv else np.eye(4)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def _trans(axis: int, v: float, deriv: bool = False) -> F:
    m = np.zeros((4, 4)) if deriv else np.eye(4)
    m[axis, 3] = 1.0 if deriv else v
    return m


def oracle(a: Arm, theta: F) -> tuple[F, F]:
    """Point (3,) and Jacobian (3, P) of arm ``a`` at joint readings ``theta``."""
    n = a.n_joints
    factors: list[tuple[str, int]] = []  # (kind, parameter column or -1)
    values: list[float] = []
    kb = 4 * n
    for i, j in enumerate(a.joints):
        beta = []
        if j.beta_rad is not None:
            beta = [("ry", kb)]
            kb += 1
        std = [("rz", i), ("tz", 2 * n + i), ("tx", 3 * n + i), ("rx", n + i)]
        mod = [("rx", n + i), ("tx", 3 * n + i), *beta, ("rz", i), ("tz", 2 * n + i)]
        factors += beta + std if j.convention == "standard" else mod
    v = a.to_vector()
    v[:n] += theta
    values = [float(v[c]) for _, c in factors]

    def matrix(kind: str, x: float, deriv: bool) -> F:
        if kind[0] == "r":
            return _rot(kind[1], x, deriv)
        return _trans(0 if kind == "tx" else 2, x, deriv)

    tip_col = kb
    tip = np.array([*a.tip_mm, 1.0])
    mats = [matrix(k, x, False) for (k, _), x in zip(factors, values, strict=True)]
    t = np.eye(4)
    for m in mats:
        t = t @ m
    p = (t @ tip)[:3]
    jac = np.zeros((3, a.n_params))
    for f, ((kind, col), x) in enumerate(zip(factors, values, strict=True)):
        d = np.eye(4)
        for g, m in enumerate(mats):
            d = d @ (matrix(kind, x, True) if g == f else m)
        jac[:, col] = (d @ tip)[:3]
    if a.tip == "xyz":
        jac[:, tip_col : tip_col + 3] = t[:3, :3]
    else:
        jac[:, tip_col] = t[:3, 2]
    return p, jac


def random_arm(rng: np.random.Generator, n: int, mode: str, beta: bool, tip: str) -> Arm:
    joints = []
    for i in range(n):
        conv = mode if mode != "mixed" else ("standard", "modified")[int(rng.integers(2))]
        joints.append(
            Joint(
                convention=conv,
                theta_offset_rad=float(rng.uniform(-0.2, 0.2)),
                alpha_rad=float(rng.choice([0.0, math.pi / 2, -math.pi / 2, 3.0])),
                d_mm=float(rng.uniform(-300, 300)),
                a_mm=float(rng.uniform(-150, 150)),
                beta_rad=float(rng.uniform(-0.02, 0.02)) if beta and i in (1, n - 1) else None,
            )
        )
    t = (float(rng.uniform(-80, 80)), float(rng.uniform(-80, 80))) if tip == "xyz" else (0.0, 0.0)
    return Arm(joints=tuple(joints), tip=tip, tip_mm=(*t, float(rng.uniform(50, 200))))


ARMS = [
    (n, mode, beta, tip)
    for n in (4, 5, 6, 7)
    for mode in ("standard", "modified", "mixed")
    for beta in (False, True)
    for tip in ("z", "xyz")
]


@pytest.mark.parametrize(("n", "mode", "beta", "tip"), ARMS)
def test_model_equals_the_numpy_oracle(n: int, mode: str, beta: bool, tip: str) -> None:
    rng = np.random.default_rng(zlib.crc32(repr((n, mode, beta, tip)).encode()))
    a = random_arm(rng, n, mode, beta, tip)
    m = Model(a)
    assert (m.joints, m.n_params, m.param_names) == (n, a.n_params, a.param_names)
    th = rng.uniform(-math.pi, math.pi, (20, n))
    p, j = m.points_jacobians(th)
    assert p.shape == (20, 3) and j.shape == (20, 3, a.n_params)
    for k in range(20):
        po, jo = oracle(a, th[k])
        assert np.max(np.abs(p[k] - po)) < 1e-9
        assert np.max(np.abs(j[k] - jo)) < 1e-9
    # single precision within today's f32 class (1e-3 mm), tiled == row-major
    p32 = m.points(th, dtype=np.float32)
    assert p32.dtype == np.float32 and np.max(np.abs(p32 - p)) < 1e-3
    pt, jt = m.points_jacobians_tiled(th)
    assert np.array_equal(pt, p) and np.array_equal(core.untile_jacobians(jt, 20), j)
    assert jt.shape[1:3] == (3, a.n_params)


def test_paper_arm_is_the_same_model_either_way() -> None:
    a = Arm.paper()
    assert a == Params().to_arm() and a.is_paper_shape
    assert a.param_names == core.PARAM_NAMES and a.n_params == core.JAC_COLS
    assert np.array_equal(a.to_vector(), Params().to_vector())
    assert Params.from_arm(a) == Params()
    rng = np.random.default_rng(5)
    th = rng.uniform(-3, 3, (200, 6))
    p1, j1 = Model(Params()).points_jacobians(th)
    p2, j2 = Model(a).points_jacobians(th)
    assert np.array_equal(p1, p2) and np.array_equal(j1, j2)
    s1 = Model(Params()).abs_jacobian_sums(th)
    s2 = Model(a).abs_jacobian_sums(th)
    assert np.array_equal(s1[0], s2[0]) and np.array_equal(s1[1], s2[1])


def test_vectors_names_units() -> None:
    a = Arm(
        joints=(
            Joint(),
            Joint(d_mm=100.0, beta_rad=0.01),
            Joint("modified", a_mm=50.0),
            Joint("modified", alpha_rad=1.0, beta_rad=-0.02),
            Joint(theta_offset_rad=0.1),
        ),
        tip="xyz",
        tip_mm=(1.0, 2.0, 3.0),
    )
    assert a.n_params == 20 + 2 + 3
    assert a.param_names[20:] == ("beta2", "beta4", "tx", "ty", "tz")
    assert a.param_units == ("rad",) * 10 + ("mm",) * 10 + ("rad",) * 2 + ("mm",) * 3
    v = a.to_vector()
    assert v[20] == 0.01 and v[21] == -0.02 and list(v[22:]) == [1.0, 2.0, 3.0]
    assert a.with_vector(v) == a
    b = a.with_vector(v + 1e-3)
    assert np.allclose(b.to_vector(), v + 1e-3) and b.beta_joints == (1, 3)
    with pytest.raises(ValueError, match="25 parameters, got 3"):
        a.with_vector([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="paper's shape"):
        Params.from_arm(a)


def test_bad_arms_get_clear_errors() -> None:
    j = Joint()
    with pytest.raises(ValueError, match="4 to 7 joints, got 3"):
        Arm(joints=(j, j, j))
    with pytest.raises(ValueError, match="4 to 7 joints, got 8"):
        Arm(joints=(j,) * 8)
    with pytest.raises(ValueError, match="joint 1 cannot have a beta"):
        Arm(joints=(Joint(beta_rad=0.01), j, j, j))
    with pytest.raises(ValueError, match="convention must be one of standard, modified"):
        Joint("craig")
    with pytest.raises(ValueError, match="d_mm must be finite"):
        Joint(d_mm=math.nan)
    with pytest.raises(ValueError, match="alpha_rad must be within"):
        Joint(alpha_rad=7.0)
    with pytest.raises(ValueError, match="tip must be one of z, xyz"):
        Arm(joints=(j,) * 4, tip="vector")
    with pytest.raises(ValueError, match="kind 'z' has tip_mm"):
        Arm(joints=(j,) * 4, tip_mm=(1.0, 0.0, 100.0))
    with pytest.raises(ValueError, match="tip_mm needs 3 values"):
        Arm.from_sequences(["standard"] * 4, [0] * 4, [0] * 4, [0] * 4, [0] * 4, tip_mm=(1, 2))
    with pytest.raises(ValueError, match="alpha_rad needs 4 values"):
        Arm.from_sequences(["standard"] * 4, [0] * 4, [0] * 3, [0] * 4, [0] * 4)
    with pytest.raises(ValueError, match="Params or an Arm"):
        Model("gao2013")  # type: ignore[arg-type]
    m = Model(Arm(joints=(j,) * 5))
    with pytest.raises(ValueError, match=r"shape \(n, 5\)"):
        m.points(np.zeros((3, 6)))
    th = np.zeros((4, 5))
    th[2, 4] = math.inf
    with pytest.raises(KinematicsError) as ei:
        m.points_jacobians(th)
    assert ei.value.index == 2 and ei.value.status == -3


def test_counts_and_encoders_of_any_joint_count() -> None:
    rng = np.random.default_rng(11)
    a = random_arm(rng, 7, "mixed", True, "xyz")
    m = Model(a)
    enc = EncoderConfig((3600,) * 7, (5,) * 7, (1, -1, 1, -1, 1, -1, 1))
    counts = rng.integers(0, 3600, (30, 7))
    p, j = m.points_from_counts(counts, enc)
    p2, j2 = m.points_jacobians(core.counts_to_angles(counts, enc))
    assert np.array_equal(p, p2) and np.array_equal(j, j2)
    p3, _ = m.points_from_counts(rng.integers(0, 2**32, (3, 7)))  # default: 2^32 counts
    assert p3.shape == (3, 3)
    assert EncoderConfig.default(7).joints == 7 and EncoderConfig().joints == 6
    with pytest.raises(ValueError, match="7 joints, the model 6"):
        Model().points_from_counts(counts, enc)
    with pytest.raises(ValueError, match="direction needs 7 values"):
        EncoderConfig((3600,) * 7, (0,) * 7, (1,) * 6)
    counts[4, 2] = 3600
    with pytest.raises(KinematicsError) as ei:
        m.points_from_counts(counts, enc)
    assert ei.value.index == 4


def test_perturbed_points_and_sums_of_a_general_arm() -> None:
    rng = np.random.default_rng(13)
    a = random_arm(rng, 5, "modified", True, "z")
    th = rng.uniform(-3, 3, (9, 5))
    delta = rng.normal(0, 1e-3, (4, a.n_params))
    out = perturbed_points(a, delta, th)
    assert out.shape == (4, 9, 3)
    for t in range(4):
        assert np.array_equal(out[t], Model(a.with_vector(a.to_vector() + delta[t])).points(th))
    with pytest.raises(ValueError, match=rf"shape \(T, {a.n_params}\)"):
        perturbed_points(a, np.zeros((2, 25)), th)
    s, q = Model(a).abs_jacobian_sums(th)
    _, j = Model(a).points_jacobians(th)
    assert np.allclose(s, np.abs(j).sum(axis=0), rtol=1e-13)
    assert np.allclose(q, (j**2).sum(axis=0), rtol=1e-13)
    sc = np.linspace(1.0, 1.5, 5)
    off = np.linspace(-0.1, 0.1, 5)
    s2, _ = Model(a).abs_jacobian_sums(th, sc, off)
    s3, _ = Model(a).abs_jacobian_sums(th * sc + off)
    assert np.array_equal(s2, s3)
