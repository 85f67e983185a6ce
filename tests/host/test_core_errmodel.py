"""The error model through the C core (issue 27 items 1-2): encoder harmonics
and thermal expansion, against an independent reference written here.

The reference multiplies the elementary 4x4 matrices of each joint in the
documented order (kinematics.h) in long double (numpy's ``longdouble``,
80-bit on x86-64), with the corrected angle q + sum_k (c_k cos kq + s_k sin
kq) from numpy's own cos(k q) (not the recurrence) and every length of link i
times 1 + cte_i (T_i - tref_i); its Jacobian is a complex step of the same
function in every parameter (structural, harmonic, CTE): no code shared with
the core's frame recursion or its analytic columns.
"""

from __future__ import annotations

import math
import zlib
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from aacmm import core, errmodel
from aacmm._core import ffi, lib
from aacmm.arm import Arm, Joint
from aacmm.core import KinematicsError, Model
from aacmm.errmodel import ErrorModel

pytestmark = pytest.mark.timeout(180)
F = npt.NDArray[Any]
LD = np.longdouble
CLD = np.clongdouble


def _rot(axis: str, t: Any) -> F:
    c, s = np.cos(t), np.sin(t)
    m = np.eye(4, dtype=CLD)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def _trans(axis: int, v: Any) -> F:
    m = np.eye(4, dtype=CLD)
    m[axis, 3] = v
    return m


def _layout(a: Arm, em: ErrorModel) -> tuple[int, int, int]:
    """Columns: P structural, then 2 sum(K) harmonic, then N cte."""
    return a.n_params, 2 * sum(len(h) for h in em.harmonics), a.n_joints


def reference_point(a: Arm, em: ErrorModel, theta: F, temp: F | None, x: F) -> F:
    """The point at readings ``theta`` for the parameter vector ``x`` (complex
    long double): the arm's P values, then c_ik, s_ik, then the N CTEs."""
    n = a.n_joints
    p_cols, h_cols, _ = _layout(a, em)
    th = x[:n]
    al = x[n : 2 * n]
    d0 = x[2 * n : 3 * n]
    a0 = x[3 * n : 4 * n]
    beta = {}
    kb = 4 * n
    for i in a.beta_joints:
        beta[i] = x[kb]
        kb += 1
    tip0 = x[kb:p_cols]
    cte = x[p_cols + h_cols : p_cols + h_cols + n]
    tref = np.array(em.tref_c, dtype=LD)
    dt = np.zeros(n, dtype=LD) if temp is None else np.array(temp, dtype=LD) - tref
    f = 1 + cte * dt
    col = p_cols
    t = np.eye(4, dtype=CLD)
    for i, j in enumerate(a.joints):
        q = LD(theta[i])
        qc = q + 0j
        for k in range(1, len(em.harmonics[i]) + 1):
            qc = qc + x[col] * np.cos(k * q) + x[col + 1] * np.sin(k * q)
            col += 2
        ang = qc + th[i]
        d, aa = d0[i] * f[i], a0[i] * f[i]
        ry = [_rot("y", beta[i])] if i in beta else []
        if j.convention == "standard":
            ms = [*ry, _rot("z", ang), _trans(2, d), _trans(0, aa), _rot("x", al[i])]
        else:
            ms = [_rot("x", al[i]), _trans(0, aa), *ry, _rot("z", ang), _trans(2, d)]
        for m in ms:
            t = t @ m
    tipv = np.array([0, 0, tip0[0], 1], dtype=CLD) if a.tip == "z" else np.array([*tip0, 1])
    tipv[:3] = tipv[:3] * f[n - 1]
    p: F = (t @ tipv)[:3]
    return p


def reference(a: Arm, em: ErrorModel, theta: F, temp: F | None) -> tuple[F, F]:
    """Point (3,) and extended Jacobian (3, P + E) by complex step."""
    p_cols, h_cols, n = _layout(a, em)
    x = np.concatenate(
        [
            a.to_vector().astype(LD),
            np.array([v for h in em.harmonics for pair in h for v in pair], dtype=LD),
            np.array(em.cte_per_k, dtype=LD),
        ]
    ).astype(CLD)
    p = reference_point(a, em, theta, temp, x).real
    h = LD(1e-40)
    cols = p_cols + h_cols + (n if em.cte_columns else 0)
    jac = np.zeros((3, cols), dtype=LD)
    for c in range(cols):
        xs = x.copy()
        xs[c] += 1j * h
        jac[:, c] = reference_point(a, em, theta, temp, xs).imag / h
    return p, jac


def random_arm(rng: np.random.Generator, n: int, mode: str, tip: str) -> Arm:
    joints = []
    for i in range(n):
        conv = mode if mode != "mixed" else ("standard", "modified")[int(rng.integers(2))]
        joints.append(
            Joint(
                convention=conv,
                theta_offset_rad=float(rng.uniform(-0.2, 0.2)),
                alpha_rad=float(rng.choice([math.pi / 2, -math.pi / 2, 3.0])),
                d_mm=float(rng.uniform(-300, 300)),
                a_mm=float(rng.uniform(-150, 150)),
                beta_rad=float(rng.uniform(-0.02, 0.02)) if i == n - 1 else None,
            )
        )
    t = (float(rng.uniform(-80, 80)), float(rng.uniform(-80, 80))) if tip == "xyz" else (0.0, 0.0)
    return Arm(joints=tuple(joints), tip=tip, tip_mm=(*t, float(rng.uniform(50, 200))))


def random_em(rng: np.random.Generator, n: int, cte_columns: bool = True) -> ErrorModel:
    hs = []
    for i in range(n):
        k = (4, 2, 0, 1, 3, 2, 4)[i]
        hs.append(
            tuple(
                (float(rng.uniform(-2e-3, 2e-3)), float(rng.uniform(-2e-3, 2e-3))) for _ in range(k)
            )
        )
    return ErrorModel(
        harmonics=tuple(hs),
        cte_per_k=tuple(float(x) for x in rng.uniform(-30e-6, 30e-6, n)),
        tref_c=tuple(float(x) for x in rng.uniform(15, 25, n)),
        cte_columns=cte_columns,
    )


CASES = [
    (n, mode, tip)
    for n in (4, 5, 6, 7)
    for mode in ("standard", "modified", "mixed")
    for tip in ("z", "xyz")
]


@pytest.mark.parametrize(("n", "mode", "tip"), CASES)
def test_points_and_jacobians_equal_the_reference(n: int, mode: str, tip: str) -> None:
    rng = np.random.default_rng(zlib.crc32(repr(("em", n, mode, tip)).encode()))
    a = random_arm(rng, n, mode, tip)
    em = random_em(rng, n)
    m = Model(a)
    th = rng.uniform(-math.pi, math.pi, (8, n))
    temps = rng.uniform(-40, 85, (8, n))
    p, j = errmodel.points_jacobians(m, em, th, temps)
    assert j.shape == (8, 3, a.n_params + em.n_cols)
    assert len(errmodel.param_names(m, em)) == j.shape[2]
    for k in range(8):
        po, jo = reference(a, em, th[k], temps[k])
        assert np.max(np.abs(p[k] - po)) <= 1e-12
        assert np.max(np.abs(j[k] - jo)) <= 1e-11
    # the corrected angles are the reference's
    q = errmodel.corrected_angles(em, th)
    for i, h in enumerate(em.harmonics):
        ref = th[:, i].astype(LD) + sum(
            c * np.cos(k * th[:, i].astype(LD)) + s * np.sin(k * th[:, i].astype(LD))
            for k, (c, s) in enumerate(h, start=1)
        )
        assert np.max(np.abs(q[:, i] - ref)) <= 1e-15
    # single precision within today's f32 class (1e-3 mm); the cte columns
    # (mm K, sums of lengths times dT) within float rounding of reach * dT:
    # 2e-7 of it, in length 2e-7 * cte, about 1e-11 of the reach
    p32, j32 = errmodel.points_jacobians(m, em, th, temps, dtype=np.float32)
    assert p32.dtype == np.float32 and np.max(np.abs(p32 - p)) < 1e-3
    c0 = a.n_params + em.n_cols - n
    assert np.max(np.abs(j32 - j)[:, :, :c0]) < 1e-3
    reach = np.sum(np.abs(a.to_vector()[2 * n : 4 * n])) + np.sum(np.abs(a.tip_mm))
    dt = np.max(np.abs(temps - np.array(em.tref_c)))
    assert np.max(np.abs(j32 - j)[:, :, c0:]) < 2e-7 * reach * dt


@pytest.fixture
def scalar_kernel() -> Any:
    """The batch methods on the scalar kernel (the per-pose core) for one test."""
    before = core.kernel()
    core.set_kernel("scalar")
    yield
    core.set_kernel(before)


def test_no_error_model_is_bit_for_bit_the_plain_path(scalar_kernel: None) -> None:
    """(Per-pose temperatures run the per-pose core: compared with the scalar
    kernel; test_every_kernel_gives_the_per_pose_core covers the others.)"""
    rng = np.random.default_rng(27)
    for a in (Arm.paper(), random_arm(rng, 7, "mixed", "xyz")):
        m = Model(a)
        n = a.n_joints
        th = rng.uniform(-3, 3, (300, n))
        none = ErrorModel.none(n)
        assert none.n_cols == 0
        for dtype in (np.float64, np.float32):
            p0, j0 = m.points_jacobians(th, dtype=dtype)
            for temps in (None, np.array(none.tref_c), np.tile(none.tref_c, (300, 1))):
                p, j = errmodel.points_jacobians(m, none, th, temps, dtype=dtype)
                assert np.array_equal(p, p0) and np.array_equal(j, j0)
                assert np.array_equal(errmodel.points(m, none, th, temps, dtype=dtype), p0)
        # any CTE at the reference temperature, and K = 0 joints among corrected ones
        em = ErrorModel(
            harmonics=(((1e-3, 0.0),), *(((),) * (n - 1))),
            cte_per_k=(23e-6,) * n,
        )
        p, j = errmodel.points_jacobians(m, em, th, np.array(em.tref_c))
        q = errmodel.corrected_angles(em, th)
        assert np.array_equal(q[:, 1:], th[:, 1:]) and not np.array_equal(q[:, 0], th[:, 0])
        pq, jq = m.points_jacobians(q)
        assert np.array_equal(p, pq) and np.array_equal(j[:, :, : m.n_params], jq)


def test_every_kernel_gives_the_per_pose_core() -> None:
    rng = np.random.default_rng(8)
    a = random_arm(rng, 6, "mixed", "z")
    em = random_em(rng, 6)
    m = Model(a)
    th = rng.uniform(-3, 3, (150, 6))  # more than one group of 64
    t = rng.uniform(0, 40, 6)
    before = core.kernel()
    try:
        for dtype in (np.float64, np.float32):
            core.set_kernel("scalar")
            p1, j1 = errmodel.points_jacobians(m, em, th, np.tile(t, (150, 1)), dtype=dtype)
            for kern in core.available_kernels():
                core.set_kernel(kern)
                p2, j2 = errmodel.points_jacobians(m, em, th, t, dtype=dtype)
                if kern in ("scalar", "vec128"):
                    assert np.array_equal(p1, p2) and np.array_equal(j1, j2), kern
                else:  # fused multiply-adds: within the core's rounding
                    tol = 1e-9 if dtype == np.float64 else 2e-2
                    assert np.max(np.abs(p1 - p2)) < tol and np.max(np.abs(j1 - j2)) < tol, kern
    finally:
        core.set_kernel(before)


def test_harmonics_recovered_from_exact_points() -> None:
    """Noise-free inversion: K = 2 on every joint of the paper's arm, fitted
    by Gauss-Newton on the core's own harmonic columns from points of the
    true error model: recovered to 1e-9 rad."""
    rng = np.random.default_rng(2027)
    m = Model(Arm.paper())
    truth = ErrorModel(
        harmonics=tuple(
            tuple(
                (float(rng.uniform(-1e-4, 1e-4)), float(rng.uniform(-1e-4, 1e-4))) for _ in range(2)
            )
            for _ in range(6)
        )
    )
    th = rng.uniform(-math.pi, math.pi, (400, 6))
    target = errmodel.points(m, truth, th)
    est = np.zeros(24)
    for _ in range(6):
        em = ErrorModel(
            harmonics=tuple(
                tuple(
                    zip(
                        est[4 * i : 4 * i + 4 : 2],
                        est[4 * i + 1 : 4 * i + 4 : 2],
                        strict=True,
                    )
                )
                for i in range(6)
            )
        )
        p, j = errmodel.points_jacobians(m, em, th)
        r = (target - p).reshape(-1)
        jh = j[:, :, m.n_params :].reshape(-1, 24)
        est = est + np.linalg.lstsq(jh, r, rcond=None)[0]
    true = np.array([v for h in truth.harmonics for pair in h for v in pair])
    assert np.max(np.abs(est - true)) <= 1e-9


def test_bad_error_models_and_temperatures_are_refused() -> None:
    m = Model()
    th = np.zeros((3, 6))
    with pytest.raises(ValueError, match="at most 4 harmonics"):
        ErrorModel(harmonics=(((0.0, 0.0),) * 5, *(((),) * 5)))
    with pytest.raises(ValueError, match="finite"):
        ErrorModel(harmonics=(((math.nan, 0.0),), *(((),) * 5)))
    with pytest.raises(ValueError, match="sum"):
        ErrorModel(harmonics=(((0.06, 0.06),), *(((),) * 5)))
    with pytest.raises(ValueError, match="reference temperature"):
        ErrorModel(harmonics=((),) * 6, tref_c=(90.0,) * 6)
    with pytest.raises(ValueError, match="joints"):
        errmodel.points(m, ErrorModel.none(5), np.zeros((1, 5)))
    em = ErrorModel.none(6)
    for bad, status in ((85.5, -2), (-40.5, -2), (math.nan, -3), (math.inf, -3)):
        temps = np.full((3, 6), 20.0)
        temps[2, 4] = bad
        with pytest.raises(KinematicsError) as e:
            errmodel.points(m, em, th, temps)
        assert (e.value.status, e.value.index) == (status, 2)
        with pytest.raises(KinematicsError) as e:
            errmodel.points(m, em, th, temps[2])
        assert e.value.status == status
    # the C core's own checks, past the Python ones
    for single in (False, True):
        suffix = "f32" if single else "f64"
        c = em.to_c(single)
        cm = m.c_model32 if single else m.c_model
        p = ffi.new("float[3]" if single else "double[3]")
        q = ffi.new("float[6]" if single else "double[6]")
        point = getattr(lib, f"aacmm_point_em_{suffix}")
        assert point(cm, c, q, ffi.NULL, p) == 0
        c.harmonics[2] = 5
        assert getattr(lib, f"aacmm_errmodel_validate_{suffix}")(c) == -2
        assert point(cm, c, q, ffi.NULL, p) == -2
        c.harmonics[2] = 1
        c.c_rad[2][0] = math.nan
        assert point(cm, c, q, ffi.NULL, p) == -3
        c.c_rad[2][0] = 0.0
        validate = getattr(lib, f"aacmm_errmodel_validate_{suffix}")
        c.s_rad[2][1] = 1e-3  # past K = 1: ignored by the pose, refused by validation
        assert validate(c) == -2
        c.s_rad[2][1] = 0.0
        c.harmonics[6] = 1  # past N
        assert point(cm, c, q, ffi.NULL, p) == -2
        c.harmonics[6] = 0
        c.c_rad[2][0] = 0.09
        c.s_rad[2][0] = 0.09  # a sum beyond 0.1 rad: validation, and the pose's guard
        assert validate(c) == -2
        q[2] = math.pi / 4
        assert point(cm, c, q, ffi.NULL, p) == -2
        q[2] = 0.0
        c.c_rad[2][0] = c.s_rad[2][0] = 0.0
        c.cte_per_k[0] = 2e-3
        assert validate(c) == -2
        t = ffi.new("float[6]" if single else "double[6]", [20.0] * 6)
        assert point(cm, c, q, t, p) == -2
        c.cte_per_k[0] = math.nan
        assert point(cm, c, q, t, p) == -3
        c.cte_per_k[0] = 0.0
        t[5] = math.nan
        assert point(cm, c, q, t, p) == -3
        t[5] = 20.0
        c.joints = 5
        assert point(cm, c, q, ffi.NULL, p) == -2
        c.joints = 6
        q[3] = math.nan
        assert point(cm, c, q, ffi.NULL, p) == -3
        q[3] = 2000.0
        assert point(cm, c, q, ffi.NULL, p) == -2
