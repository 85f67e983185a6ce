"""The analysis layer's shape: pure libraries, commands in aacmm.commands, a clean API.

Regression tests for issue 14 items 12 (the ``mc`` and ``uncertainty``
commands lived in ``aacmm.analysis.cli``), 9 (``aacmm.core`` exported ``np``,
``ffi`` and ``lib``; ``uncertainty.load_spec("example")`` worked only in the
CLI) and 7 (``aacmm uncertainty --help`` showed "95 %%").
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import subprocess
import sys
import types
from pathlib import Path

import aacmm.analysis
import aacmm.core
import numpy as np
import pytest
from aacmm import uncertainty as unc
from aacmm.cli import COMMAND_MODULES, build_parser

pytestmark = pytest.mark.timeout(60)
ANALYSIS_DIR = Path(aacmm.analysis.__file__).parent


def _analysis_modules() -> list[Path]:
    return sorted(ANALYSIS_DIR.glob("*.py"))


def test_analysis_is_a_pure_library() -> None:
    """No argument parsing, no printing, no exits in aacmm.analysis."""
    found = []
    for path in _analysis_modules():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import | ast.ImportFrom):
                names = [a.name for a in node.names]
                mod = node.module if isinstance(node, ast.ImportFrom) else None
                if "argparse" in names or mod == "argparse" or (mod or "").endswith(".cli"):
                    found.append(f"{path.name}:{node.lineno} imports argparse/cli")
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
                if node.func.id in ("print", "exit", "input"):
                    found.append(f"{path.name}:{node.lineno} calls {node.func.id}()")
            elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
                if node.value.id == "sys" and node.attr in ("stdout", "exit", "argv"):
                    found.append(f"{path.name}:{node.lineno} uses sys.{node.attr}")
    assert not found, found
    assert "cli" not in {m.name for m in pkgutil.iter_modules([str(ANALYSIS_DIR)])}


def test_every_command_lives_in_commands() -> None:
    assert all(m.startswith("aacmm.commands.") for m in COMMAND_MODULES), COMMAND_MODULES
    assert "aacmm.commands.mc" in COMMAND_MODULES
    assert "aacmm.commands.uncertainty" in COMMAND_MODULES
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    choices = getattr(sub, "choices", {})
    for name in ("mc", "uncertainty"):
        func = choices[name].get_default("func")
        assert func.__module__ == f"aacmm.commands.{name}"


def test_core_all_is_the_public_api() -> None:
    public = set(aacmm.core.__all__)
    assert not {"np", "npt", "ffi", "lib", "math", "annotations"} & public
    for name in public:
        assert hasattr(aacmm.core, name), name
    # everything defined in the module under a public name is exported
    own = {
        n
        for n, v in vars(aacmm.core).items()
        if not n.startswith("_")
        and not isinstance(v, types.ModuleType)
        and getattr(v, "__module__", "aacmm.core") == "aacmm.core"
        and n not in ("annotations", "ffi", "lib")
    }
    assert own <= public, own - public
    ns: dict[str, object] = {}
    exec("from aacmm.core import *", ns)
    assert not {"np", "ffi", "lib"} & set(ns)


def test_load_spec_example_from_the_library() -> None:
    spec = unc.load_spec(unc.EXAMPLE_SPEC)
    assert spec.u_vector().shape == (25,) and np.all(spec.u_vector() >= 0)
    assert spec.u_vector().max() > 0
    assert spec.poses_rad.shape[1] == 6


def test_uncertainty_help_shows_a_single_percent() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "aacmm.cli", "uncertainty", "--help"],
        capture_output=True,
        text=True,
        timeout=30,
        check=True,
    )
    assert "%%" not in out.stdout
    assert "95 % intervals" in " ".join(out.stdout.split())


def test_commands_import_light() -> None:
    """The command modules import no numpy at registration (fast ``aacmm --help``)."""
    code = (
        "import sys; import aacmm.commands.mc, aacmm.commands.uncertainty; "
        "print('numpy' in sys.modules)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=30, check=True
    )
    assert out.stdout.strip() == "False"
    importlib.import_module("aacmm.commands.mc")
