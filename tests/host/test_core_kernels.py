"""The batch kernels across SIMD lanes, as the Python package runs them.

Issue 17: every kernel this CPU runs agrees with the scalar one over 10^6
poses within the issue's 1e-12 mm (the extension is built without FMA
contraction, so the kernels without FMA agree bit for bit; those with FMA,
fused at the same places, agree bit for bit with each other);
``AACMM_KERNEL`` forces a kernel (``make test`` runs the core suite on the
scalar one); the extension needs nothing beyond the x86-64 baseline outside
the kernels chosen at run time.
"""

from __future__ import annotations

import math
import os
import platform
import subprocess
import sys

import aacmm._core
import numpy as np
import pytest
from aacmm import core
from aacmm.core import Model, Params, perturbed_points
from portability import vector_instruction_functions

pytestmark = pytest.mark.timeout(120)
OTHER_KERNELS = [k for k in core.available_kernels() if k != "scalar"]
#: The kernels that fuse multiply-adds (aacmm/simd.h), and the first of them
#: this CPU runs: the others with FMA must equal it bit for bit.
FUSED = ("avx2", "avx512")
FUSED_PEER = next((k for k in OTHER_KERNELS if k in FUSED), None)


def test_fused_kernels_are_the_documented_ones() -> None:
    fused = [k for i, k in enumerate(core.KERNELS) if aacmm._core.lib.aacmm_kernel_fused(i)]
    assert tuple(fused) == FUSED


@pytest.fixture
def restore_kernel() -> object:
    before = core.kernel()
    yield
    core.set_kernel(before)


def test_kernel_selection(restore_kernel: object) -> None:
    assert core.available_kernels()[0] == "scalar"
    assert core.set_kernel("scalar") == "scalar" and core.kernel() == "scalar"
    assert core.set_kernel("auto") == core.available_kernels()[-1]
    with pytest.raises(ValueError, match="unknown batch kernel 'sse9'"):
        core.set_kernel("sse9")
    missing = [k for k in core.KERNELS if k not in core.available_kernels()]
    for k in missing:
        with pytest.raises(ValueError, match="cannot run on this CPU"):
            core.set_kernel(k)


@pytest.mark.skipif(not OTHER_KERNELS, reason="no batch kernel beyond the scalar one here")
@pytest.mark.parametrize("name", OTHER_KERNELS)
def test_kernel_equals_scalar_over_1e6_poses(name: str, restore_kernel: object) -> None:
    fused = name in FUSED
    peer = FUSED_PEER if fused and FUSED_PEER != name else None
    rng = np.random.default_rng(17)
    prm = Params.from_vector(Params().to_vector() + rng.normal(0.0, 1e-3, 25))
    model = Model(prm)
    worst_p = worst_j = 0.0
    for _ in range(10):
        th = rng.uniform(-math.pi, math.pi, (100_000, 6))
        core.set_kernel("scalar")
        p0, j0 = model.points_jacobians(th)
        s0, q0 = model.abs_jacobian_sums(th)
        core.set_kernel(name)
        p1, j1 = model.points_jacobians(th)
        s1, q1 = model.abs_jacobian_sums(th)
        worst_p = max(worst_p, float(np.max(np.abs(p1 - p0))))
        worst_j = max(worst_j, float(np.max(np.abs(j1 - j0) / np.maximum(1.0, np.abs(j0)))))
        # the sums add up lane by lane (fused or not): another order and
        # rounding of n additions of positive terms, each within n eps of the
        # exact sum
        tol = 2 * th.shape[0] * np.finfo(np.float64).eps
        assert np.all(np.abs(s1 - s0) <= tol * s0) and np.all(np.abs(q1 - q0) <= tol * q0)
        if peer is not None:
            core.set_kernel(peer)
            pr, jr = model.points_jacobians(th)
            assert np.array_equal(p1, pr) and np.array_equal(j1, jr)
    print(
        f"measured: {name} vs scalar, 10^6 poses: point {worst_p:.3g} mm, "
        f"Jacobian {worst_j:.3g} (relative to max(1, |entry|))"
    )
    assert worst_p <= 1e-12  # the bound
    assert worst_j <= 1e-12
    if not fused:
        assert worst_p == 0.0 and worst_j == 0.0  # in fact bit for bit
    # single precision and the perturbed models of the uncertainty Monte Carlo
    th = rng.uniform(-math.pi, math.pi, (20_000, 6))
    delta = rng.normal(0.0, 1e-4, (64, 25))
    core.set_kernel("scalar")
    pf0, jf0 = model.points_jacobians(th, dtype=np.float32)
    pp0 = perturbed_points(prm, delta, th[:37])
    core.set_kernel(name)
    pf1, jf1 = model.points_jacobians(th, dtype=np.float32)
    pp1 = perturbed_points(prm, delta, th[:37])
    assert pf1.dtype == np.float32 and jf1.shape == (20_000, 3, 25)
    if fused:
        assert np.max(np.abs(pf1 - pf0)) <= 1e-3 and np.max(np.abs(jf1 - jf0)) <= 1e-3
        assert np.max(np.abs(pp1 - pp0)) <= 1e-12
    else:
        assert np.array_equal(pf1, pf0) and np.array_equal(jf1, jf0)
        assert np.array_equal(pp1, pp0)
    if peer is not None:
        core.set_kernel(peer)
        pfr, jfr = model.points_jacobians(th, dtype=np.float32)
        assert np.array_equal(pf1, pfr) and np.array_equal(jf1, jfr)
        assert np.array_equal(perturbed_points(prm, delta, th[:37]), pp1)


def test_float32_close_to_float64() -> None:
    th = np.random.default_rng(5).uniform(-math.pi, math.pi, (10_000, 6))
    p64, j64 = Model().points_jacobians(th)
    p32, j32 = Model().points_jacobians(th, dtype=np.float32)
    assert np.max(np.abs(p32 - p64)) < 1e-3 and np.max(np.abs(j32 - j64)) < 2e-3
    with pytest.raises(ValueError, match="float64 or float32"):
        Model().points(th, dtype=np.int32)


def _run(code: str, kernel: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, core.ENV_KERNEL: kernel}
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env
    )


def test_environment_variable_forces_a_kernel() -> None:
    out = _run("import aacmm.core as c; print(c.kernel())", "scalar")
    assert out.returncode == 0 and out.stdout.strip() == "scalar", out.stderr
    out = _run("import aacmm.core as c; print(c.kernel())", "auto")
    assert out.stdout.strip() == core.available_kernels()[-1]
    out = _run("import aacmm.core as c; c.Model().points([0.0] * 6)", "avx9")
    assert out.returncode != 0 and "AACMM_KERNEL: unknown batch kernel 'avx9'" in out.stderr
    # the command line says it in one line, exit status 2
    env = {**os.environ, core.ENV_KERNEL: "avx9"}
    cli = subprocess.run(
        [sys.executable, "-m", "aacmm.cli", "mc", "-n", "10"],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )
    assert cli.returncode == 2
    assert cli.stderr.strip().splitlines() == [
        "aacmm mc: error: AACMM_KERNEL: unknown batch kernel 'avx9' "
        "(auto, scalar, vec128, avx2, avx512)"
    ]


@pytest.mark.skipif(platform.machine() != "x86_64", reason="x86-64 instruction check")
def test_extension_needs_only_baseline_x86_64_outside_the_wide_kernels() -> None:
    """VEX/EVEX (AVX and later) instructions appear only in the AVX2/AVX-512
    kernels, which run after the CPU check: the rest of the extension, the
    scalar fallback included, runs on any x86-64 (no -march in the build)."""
    so = aacmm._core.__file__
    assert so is not None
    wide, other = vector_instruction_functions(so)
    assert wide, "no AVX2/AVX-512 kernel found in the extension"
    assert other == [], other


def test_scaled_sums_equal_sums_of_the_scaled_poses(restore_kernel: object) -> None:
    """The Monte Carlo's fused form (poses = unit * scale + offset formed in C)
    gives the sums of the poses formed with numpy first, bit for bit."""
    rng = np.random.default_rng(8)
    unit = rng.random((5000, 6))
    scale = rng.uniform(0.5, 6.3, 6)
    offset = rng.uniform(-3.2, 0.0, 6)
    th = unit * scale
    th += offset
    model = Model()
    for name in core.available_kernels():
        core.set_kernel(name)
        s0, q0 = model.abs_jacobian_sums(th)
        s1, q1 = model.abs_jacobian_sums(unit, scale, offset)
        assert np.array_equal(s0, s1) and np.array_equal(q0, q1), name
    bad = unit.copy()
    bad[700, 2] = np.nan
    with pytest.raises(core.KinematicsError) as ei:
        model.abs_jacobian_sums(bad, scale, offset)
    assert ei.value.index == 700


@pytest.mark.parametrize("name", core.available_kernels())
def test_tiled_layout_equals_row_major(name: str, restore_kernel: object) -> None:
    """``points_jacobians_tiled``: pose l's entry (r, c) at [l // T, r, c, l % T],
    bit for bit the row-major values of the same kernel, in both precisions;
    the last tile's padding lanes repeat the last pose; 64-byte aligned."""
    core.set_kernel(name)
    rng = np.random.default_rng(23)
    model = Model()
    for dtype, tile in ((np.float64, core.TILE_F64), (np.float32, core.TILE_F32)):
        for n in (1, tile - 1, tile, tile + 1, 3 * tile + 5, 1003):
            th = rng.uniform(-math.pi, math.pi, (n, 6))
            p, j = model.points_jacobians(th, dtype=dtype)
            pt, jt = model.points_jacobians_tiled(th, dtype=dtype)
            assert jt.dtype == dtype and jt.shape == (-(-n // tile), 3, 25, tile)
            assert jt.ctypes.data % 64 == 0 and jt.flags.c_contiguous
            assert np.array_equal(pt, p)
            assert np.array_equal(core.untile_jacobians(jt, n), j)
            last = (n - 1) // tile
            for lane in range(n - last * tile, tile):
                assert np.array_equal(jt[last, :, :, lane], j[-1])
            pose = n // 2
            assert np.array_equal(jt[pose // tile, :, :, pose % tile], j[pose])
    with pytest.raises(core.KinematicsError) as err:
        model.points_jacobians_tiled(np.array([[0.0, 0.1, 0.2, 0.3, 0.4, 0.5], [np.nan] * 6]))
    assert err.value.index == 1
    with pytest.raises(ValueError, match="do not fill"):
        core.untile_jacobians(np.zeros((2, 3, 25, 8)), 17)
    with pytest.raises(ValueError, match="shape"):
        core.untile_jacobians(np.zeros((2, 75, 8)), 9)
