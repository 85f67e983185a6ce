"""Build hook: the project metadata lives in pyproject.toml; this file adds the
cffi extension ``aacmm._core`` (the firmware kinematics core) and bundles its
C sources into the sdist, so that ``host/`` alone builds an sdist whose wheel
compiles anywhere (no repository needed)."""

from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.sdist import sdist

HERE = Path(__file__).resolve().parent


def _build_core() -> object:
    """The extension's build script (aacmm/_build_core.py), loaded by path."""
    spec = importlib.util.spec_from_file_location(
        "aacmm_build_core", HERE / "src" / "aacmm" / "_build_core.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class SdistWithCSources(sdist):  # type: ignore[misc]
    """sdist that also carries the firmware C sources under csrc/."""

    def make_release_tree(self, base_dir: str, files: list[str]) -> None:
        super().make_release_tree(base_dir, files)
        for src, rel in _build_core().c_sources():  # type: ignore[attr-defined]
            dst = Path(base_dir) / "csrc" / rel
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst)


setup(
    cffi_modules=["src/aacmm/_build_core.py:ffibuilder"],
    cmdclass={"sdist": SdistWithCSources},
)
