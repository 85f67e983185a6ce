"""cffi build script: binds the firmware's kinematics core into ``aacmm._core``.

Run by setuptools (``cffi_modules`` in host/setup.py) when the package is
built or installed; it compiles the firmware's own C sources (in a checkout
the repository's firmware/, in an sdist the copy setup.py bundled under
csrc/), so the host analysis runs exactly the code the arm runs.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sysconfig
import tempfile
from pathlib import Path

from cffi import FFI

_HERE = Path(__file__).resolve().parent
HOST = _HERE.parents[1]  # host/src/aacmm -> host
# The firmware's C sources: bundled under host/csrc/ in an sdist (setup.py's
# sdist command copies them there), else the repository's firmware/ next to host/.
_BUNDLED = HOST / "csrc" / "firmware"
_CHECKOUT = HOST.parent / "firmware"
FIRMWARE = _BUNDLED if _BUNDLED.is_dir() else _CHECKOUT
FW_INC = FIRMWARE / "include"
FW_SRC = FIRMWARE / "src"
SOURCES = [
    FW_SRC / "status.c",
    FW_SRC / "encoder.c",
    FW_SRC / "shape.c",
    FW_SRC / "kinematics_f64.c",
    FW_SRC / "kinematics_f32.c",
    FW_SRC / "analysis.c",
    FW_SRC / "simd" / "simd_dispatch.c",
    FW_SRC / "simd" / "simd_f64.c",
    FW_SRC / "simd" / "simd_f32.c",
]


def c_sources() -> list[tuple[Path, str]]:
    """Every file the extension is compiled from, as (path, path under csrc/).

    The sources above and every header they may include: the public headers
    and the core's own (firmware/src and firmware/src/simd, not the device,
    simulator or protocol directories).
    """
    root = FIRMWARE.parent
    files = sorted(FW_INC.glob("aacmm/*.h"))
    for d in (FW_SRC, FW_SRC / "simd"):
        files += sorted(p for p in d.iterdir() if p.suffix in (".c", ".h"))
    return [(p, p.relative_to(root).as_posix()) for p in files]


if not (FW_SRC / "kinematics_impl.h").is_file():
    raise RuntimeError(
        f"aacmm: the C sources of the kinematics core are missing (looked in {_BUNDLED} and "
        f"{_CHECKOUT}): build the package from the repository's host/ directory, or from an "
        "sdist made there (python -m build --sdist host/ or pip wheel host/)"
    )

#: The public headers the extension binds, in include order: everything they
#: declare is the binding (aacmm.core wraps it).
PUBLIC_HEADERS = ("aacmm/status.h", "aacmm/kinematics.h", "aacmm/analysis.h", "aacmm/simd.h")


def _preprocess(extra: list[str]) -> str:
    """The public headers through the C compiler's preprocessor (``-E``).

    System headers are replaced by empty stubs (cffi knows ``size_t`` and the
    ``<stdint.h>`` types), so only aacmm's own declarations come out.
    """
    cc = shlex.split(os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc")
    src = "".join(f'#include "{h}"\n' for h in PUBLIC_HEADERS)
    with tempfile.TemporaryDirectory() as tmp:
        for stub in ("stddef.h", "stdint.h"):
            (Path(tmp) / stub).write_text("", encoding="ascii")
        cmd = [*cc, "-E", "-P", "-nostdinc", "-I", tmp, "-I", str(FW_INC), *extra, "-x", "c", "-"]
        done = subprocess.run(cmd, input=src, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"aacmm: preprocessing the core's headers failed: {done.stderr.strip()}")
    return done.stdout


_MACRO = re.compile(r"#define (AACMM_[A-Z0-9_]+) (.+)")


def header_cdef() -> str:
    """The cffi declarations of the public headers, generated from them.

    Every type and function exactly as the headers declare it (the
    preprocessor expands the size macros), and the headers' object-like
    AACMM_ macros as constants: integer ones as ``#define NAME ...`` and
    floating ones as ``static const double NAME;`` (cffi reads both values
    from the compiled headers). Include guards (no value) are left out. So the
    binding cannot drift from the headers: there is no second copy to drift.
    """
    lines = [_preprocess([])]
    for m in sorted(_MACRO.finditer(_preprocess(["-dM"])), key=lambda m: m.group(1)):
        name, value = m.group(1), m.group(2).strip()
        if "(" in name or value == "":
            continue
        if re.search(r"[0-9]\.[0-9]|e[+-]?[0-9]", value):
            lines.append(f"static const double {name};")
        else:
            lines.append(f"#define {name} ...")
    return "\n".join(lines) + "\n"


CDEF = header_cdef()

ffibuilder = FFI()
ffibuilder.cdef(CDEF)
# The declarations the extension was built from, kept in it: the core suite
# (tests/host/test_core_binding.py) compares them with the headers as they
# are now, so a stale build fails there rather than computing with a
# layout the headers no longer have.
ffibuilder.cdef("extern const char aacmm_binding_cdef[];")


# One translation unit (a "unity build") that includes the firmware sources:
# no object files land outside the build directory, and the compiler may
# inline the core's per-pose function into the analysis loops.
#
# No -march: the extension runs on any CPU of its architecture (x86-64
# baseline, arm64). The wide batch kernels (AVX2, AVX-512) are compiled under
# target attributes inside firmware/src/simd and chosen at run time
# (aacmm/simd.h). No FMA contraction: the kernels then give the scalar
# kernel's results bit for bit.
UNITY = "".join(f'#include "{p.relative_to(FW_SRC).as_posix()}"\n' for p in SOURCES)
# (ASCII, so JSON's string escapes are C's.)
UNITY += f"const char aacmm_binding_cdef[] = {json.dumps(CDEF)};\n"
ffibuilder.set_source(
    "aacmm._core",
    UNITY,
    include_dirs=[str(FW_INC), str(FW_SRC)],
    depends=[str(p) for p in SOURCES],
    extra_compile_args=["-std=c99", "-O3", "-fno-math-errno", "-ffp-contract=off"],
    libraries=["m"],
)

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
