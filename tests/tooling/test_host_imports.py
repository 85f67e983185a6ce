"""The host package's import structure (issue 25): no module that only passes
on names defined elsewhere, names imported from where they are defined, no
library importing ``aacmm.commands``, no import cycle between modules nor
between packages. Each check is first shown to catch its defect in a small
package written to ``tmp_path``; then it runs on host/src/aacmm."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
from hostimports import (
    Module,
    cycles,
    forbidden_imports,
    indirect_imports,
    load_package,
    package_cycles,
    reexport_modules,
)

pytestmark = pytest.mark.timeout(120)

ROOT = Path(__file__).resolve().parents[2]
HOST_SRC = ROOT / "host" / "src"
#: the one module outside aacmm.commands that may import it: the command line
CLI = frozenset({"aacmm.cli"})


def write_package(root: Path, files: dict[str, str]) -> Path:
    """Files named by their path below `root` (``pkg/a.py``), dedented; every
    folder of a file gets an ``__init__.py`` unless one is given."""
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text), encoding="utf-8")
    for rel in files:
        for parent in Path(rel).parents:
            if str(parent) != "." and not (root / parent / "__init__.py").exists():
                (root / parent / "__init__.py").write_text("", encoding="utf-8")
    return root


@pytest.fixture(scope="module")
def host() -> dict[str, Module]:
    modules = load_package(HOST_SRC, "aacmm")
    # the reader found the package: its layers and well-known modules
    assert {"aacmm.cli", "aacmm.commands.calibrate", "aacmm.records.files"} <= set(modules)
    assert "aacmm.commands.calibrate" in modules["aacmm.cli"].imports or any(
        i.startswith("aacmm.commands") for i in modules["aacmm.cli"].imports
    )
    return modules


# ------------------------------------------------------------ the checks catch their defect


def test_reexport_only_module_is_found(tmp_path: Path) -> None:
    write_package(
        tmp_path,
        {
            "pkg/parts.py": """
                def one() -> int:
                    return 1
                def two() -> int:
                    return 2
                THREE = 3
            """,
            # the defect: a module whose public names are the parts' names
            "pkg/api.py": """
                from pkg.parts import THREE, one, two
                def four() -> int:
                    return 4
                __all__ = ["THREE", "four", "one", "two"]
            """,
            # no __all__, but others take the imported names from here
            "pkg/hub.py": """
                from pkg.parts import one, two
                def helper() -> int:
                    return one() + two()
            """,
            "pkg/user.py": """
                from pkg.hub import one, two
            """,
            # a module that uses imports and defines its names is fine
            "pkg/normal.py": """
                from pkg.parts import one
                def five() -> int:
                    return one() + 4
                def six() -> int:
                    return 6
            """,
            # a package's __init__ is its face: re-exporting there is the rule
            "pkg/__init__.py": """
                from pkg.parts import one, two
                __all__ = ["one", "two"]
            """,
        },
    )
    modules = load_package(tmp_path, "pkg")
    found = reexport_modules(modules)
    assert found == [
        "pkg.api: 3 of 4 public names imported",
        "pkg.hub: 2 of 3 public names imported",
    ]
    # and the importer of a name from a module that only passes it on
    indirect = indirect_imports(modules)
    assert indirect == [
        "pkg.user (pkg.user:2) takes one from pkg.hub",
        "pkg.user (pkg.user:2) takes two from pkg.hub",
    ]


def test_import_of_commands_from_a_library_is_found(tmp_path: Path) -> None:
    write_package(
        tmp_path,
        {
            "pkg/commands/run.py": "from pkg.lib.core import work\nX = 1\n",
            "pkg/commands/util.py": "Y = 2\n",
            "pkg/cli.py": "from pkg.commands import run\n",
            "pkg/lib/core.py": "def work() -> int:\n    return 1\n",
            # the defects: at the top, inside a function, relative, and for typing only
            "pkg/lib/bad_top.py": "from pkg.commands.util import Y\n",
            "pkg/lib/bad_lazy.py": """
                def f() -> int:
                    from pkg.commands import util
                    return util.Y
            """,
            "pkg/lib/bad_relative.py": "from ..commands.run import X\n",
            "pkg/lib/bad_typing.py": """
                from typing import TYPE_CHECKING
                if TYPE_CHECKING:
                    import pkg.commands.run
            """,
        },
    )
    modules = load_package(tmp_path, "pkg")
    assert forbidden_imports(modules, "pkg.commands", frozenset({"pkg.cli"})) == [
        "pkg.lib.bad_lazy imports pkg.commands.util",
        "pkg.lib.bad_relative imports pkg.commands.run",
        "pkg.lib.bad_top imports pkg.commands.util",
        "pkg.lib.bad_typing imports pkg.commands.run",
    ]
    # the command line itself is found too when it is not allowed
    assert "pkg.cli imports pkg.commands.run" in forbidden_imports(modules, "pkg.commands")


def test_import_cycles_are_found(tmp_path: Path) -> None:
    write_package(
        tmp_path,
        {
            # a <-> b, the return edge inside a function (a lazy import is still a cycle)
            "pkg/a.py": "from pkg.b import g\ndef f() -> int:\n    return g()\n",
            "pkg/b.py": "def g() -> int:\n    from pkg.a import f\n    return 1\n",
            # c -> d -> e -> c, relative imports
            "pkg/sub/c.py": "from .d import D\n",
            "pkg/sub/d.py": "from pkg.sub.e import E\nD = 1\n",
            "pkg/sub/e.py": "from . import c\nE = 2\n",
            # a module importing a sibling through the package face: no cycle
            "pkg/face/__init__.py": "from pkg.face.x import X\n",
            "pkg/face/x.py": "from pkg.face import y\nX = 1\n",
            "pkg/face/y.py": "Y = 2\n",
            # a cycle needed for type checking only is none at run time
            "pkg/t1.py": "from pkg.t2 import T2\nT1 = 1\n",
            "pkg/t2.py": (
                "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                "    from pkg.t1 import T1\nT2 = 2\n"
            ),
        },
    )
    modules = load_package(tmp_path, "pkg")
    assert cycles(modules) == [["pkg.a", "pkg.b"], ["pkg.sub.c", "pkg.sub.d", "pkg.sub.e"]]


def test_package_cycles_are_found(tmp_path: Path) -> None:
    write_package(
        tmp_path,
        {
            # no module cycle, but the packages low and high import each other
            "pkg/low/base.py": "X = 1\n",
            "pkg/low/helper.py": "def h() -> int:\n    from pkg.high.top import Y\n    return Y\n",
            "pkg/high/top.py": "from pkg.low.base import X\nY = X + 1\n",
            "pkg/other/ok.py": "from pkg.low.base import X\n",
        },
    )
    modules = load_package(tmp_path, "pkg")
    assert cycles(modules) == []
    assert package_cycles(modules, "pkg") == [["pkg.high", "pkg.low"]]


# ------------------------------------------------------------ on host/src/aacmm


def test_host_has_no_reexport_only_module(host: dict[str, Module]) -> None:
    found = reexport_modules(host)
    assert not found, "modules that pass on names defined elsewhere: " + "; ".join(found)


def test_host_modules_import_names_from_where_they_are_defined(
    host: dict[str, Module],
) -> None:
    found = indirect_imports(host)
    assert not found, "import these from their defining module: " + "; ".join(found)


def test_host_libraries_do_not_import_commands(host: dict[str, Module]) -> None:
    found = forbidden_imports(host, "aacmm.commands", CLI)
    assert not found, "commands/ is the top layer: " + "; ".join(found)


def test_host_has_no_import_cycle(host: dict[str, Module]) -> None:
    assert cycles(host) == []
    assert package_cycles(host, "aacmm") == []
