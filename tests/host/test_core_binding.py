"""The cffi binding against the public headers (issue 25 item; issue 26).

``aacmm._build_core`` generates the binding's declarations from the headers
(the C preprocessor, no hand-kept copy) and keeps them in the built
extension; these tests fail when the extension was built from declarations
other than the headers' as they are now (a stale build), when a function a
header declares is missing from it, or when a constant the Python side
spells out differs from the header's.
"""

from __future__ import annotations

import importlib.util
import math
import re
from pathlib import Path
from types import ModuleType

import pytest
from aacmm import arm, core
from aacmm._core import ffi, lib

pytestmark = pytest.mark.timeout(60)

ROOT = Path(__file__).resolve().parents[2]
BUILD = ROOT / "host" / "src" / "aacmm" / "_build_core.py"


def _build_core() -> ModuleType:
    spec = importlib.util.spec_from_file_location("aacmm_build_core_test", BUILD)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_extension_declarations_are_the_headers() -> None:
    built: str = ffi.string(lib.aacmm_binding_cdef).decode("ascii")
    now: str = _build_core().header_cdef()
    assert built == now, "aacmm._core was built from other headers: rebuild it (make setup)"


def test_every_declared_function_is_bound() -> None:
    build = _build_core()
    names: set[str] = set()
    for header in build.PUBLIC_HEADERS:
        text = (ROOT / "firmware" / "include" / header).read_text(encoding="utf-8")
        text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
        names |= set(re.findall(r"\b(aacmm_[a-z0-9_]+)\s*\(", text))
    assert len(names) > 60
    missing = sorted(n for n in names if not hasattr(lib, n))
    assert not missing, f"declared in the headers but not in the binding: {missing}"


def test_python_constants_equal_the_headers() -> None:
    assert (core.JOINTS, core.JAC_ROWS, core.JAC_COLS) == (
        lib.AACMM_JOINTS,
        lib.AACMM_JAC_ROWS,
        lib.AACMM_JAC_COLS,
    )
    assert (core.TILE_F64, core.TILE_F32) == (lib.AACMM_SIMD_TILE_F64, lib.AACMM_SIMD_TILE_F32)
    assert (arm.JOINTS_MIN, arm.JOINTS_MAX, arm.PARAMS_MAX) == (
        lib.AACMM_JOINTS_MIN,
        lib.AACMM_JOINTS_MAX,
        lib.AACMM_PARAMS_MAX,
    )
    assert core.LENGTH_MAX_MM == lib.AACMM_LENGTH_MAX_MM
    assert core.JOINT_ANGLE_MAX_RAD == lib.AACMM_JOINT_ANGLE_MAX_RAD
    assert math.isclose(core.PARAM_ANGLE_MAX_RAD, lib.AACMM_PARAM_ANGLE_MAX_RAD, rel_tol=1e-15)
    assert core.KERNELS == tuple(
        ffi.string(lib.aacmm_kernel_name(i)).decode() for i in range(lib.AACMM_KERNEL_COUNT)
    )
    assert arm.CONVENTIONS == ("standard", "modified")
    assert (lib.AACMM_DH_STANDARD, lib.AACMM_DH_MODIFIED) == (0, 1)
    assert (lib.AACMM_TIP_Z, lib.AACMM_TIP_XYZ) == (1, 3)
