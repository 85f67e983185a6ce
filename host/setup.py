"""Build hook: the project metadata lives in pyproject.toml; this file only
adds the cffi extension ``aacmm._core`` (the firmware kinematics core)."""

from setuptools import setup

setup(cffi_modules=["src/aacmm/_build_core.py:ffibuilder"])
