"""Type stub of the cffi extension built from firmware/src (see _build_core.py)."""

from typing import Any

ffi: Any
lib: Any
