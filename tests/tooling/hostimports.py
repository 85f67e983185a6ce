"""The import structure of a Python package, read from its sources with `ast`
(nothing is imported or run): which module imports which, the cycles among
them, and the modules that only pass on names defined elsewhere.

Used by `test_host_imports.py` on host/src/aacmm (issue 25) and on small
synthetic packages that show each check catches its defect.

Rules the checks apply:
- a module is a dotted name (``aacmm.records.files``); a package is the
  module of its ``__init__.py`` (``aacmm.records``);
- an edge a -> b is an ``import`` or ``from ... import`` in a (at any depth,
  including function bodies; those in ``if TYPE_CHECKING:`` blocks are kept
  apart, in ``type_imports``) naming b,
  or naming a submodule b of a package (``from aacmm.records import files``:
  an edge to ``aacmm.records.files``, and to ``aacmm.records`` only if other
  names come from the package itself);
  the implicit import of a parent package that Python does on the way is not
  an edge (every module of a package would otherwise be in a cycle with its
  ``__init__``);
- a module's public names are its ``__all__`` when it has one, else the
  top-level names it defines without a leading underscore and the names it
  imports that other modules take from it; a public name is *imported* when
  the module binds it with an import statement.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class Module:
    """One source file of the package."""

    name: str
    path: Path
    is_package: bool
    tree: ast.Module
    imports: set[str] = field(default_factory=set)
    # modules named only in `if TYPE_CHECKING:` blocks (no run-time edge)
    type_imports: set[str] = field(default_factory=set)
    # (line, imported module, names) for every `from X import ...` found
    from_imports: list[tuple[int, str, tuple[str, ...]]] = field(default_factory=list)


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _import_nodes(tree: ast.AST) -> list[tuple[ast.Import | ast.ImportFrom, bool]]:
    """Every import statement at any depth, with True for those inside an
    ``if TYPE_CHECKING:`` block."""
    found: list[tuple[ast.Import | ast.ImportFrom, bool]] = []

    def walk(node: ast.AST, typing_only: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child.test):
                for sub in child.body:
                    walk_stmt(sub, True)
                for sub in child.orelse:
                    walk_stmt(sub, typing_only)
                continue
            walk_stmt(child, typing_only)

    def walk_stmt(node: ast.AST, typing_only: bool) -> None:
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            found.append((node, typing_only))
        walk(node, typing_only)

    walk(tree, False)
    return found


def _resolve(module: Module, node: ast.ImportFrom) -> str:
    if node.level == 0:
        return node.module or ""
    parts = module.name.split(".")
    base = parts if module.is_package else parts[:-1]
    if node.level > 1:
        base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def load_package(src_root: Path, package: str) -> dict[str, Module]:
    """Every module of `package` (a folder below `src_root`) with its imports
    of other modules of the same package."""
    modules: dict[str, Module] = {}
    for path in sorted((src_root / package).rglob("*.py")):
        rel = path.relative_to(src_root).with_suffix("")
        parts = list(rel.parts)
        is_package = parts[-1] == "__init__"
        if is_package:
            parts = parts[:-1]
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        modules[".".join(parts)] = Module(".".join(parts), path, is_package, tree)
    prefix = package + "."
    for mod in modules.values():
        for node, typing_only in _import_nodes(mod.tree):
            edges = mod.type_imports if typing_only else mod.imports
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name in modules:
                        edges.add(alias.name)
                continue
            target = _resolve(mod, node)
            if target != package and not target.startswith(prefix):
                continue
            names = tuple(alias.name for alias in node.names)
            if not typing_only:
                mod.from_imports.append((node.lineno, target, names))
            submodules = [f"{target}.{n}" for n in names if f"{target}.{n}" in modules]
            edges.update(submodules)
            if target in modules and len(submodules) < len(names):
                edges.add(target)  # names of the module itself, not only submodules
        mod.imports.discard(mod.name)
        mod.type_imports.discard(mod.name)
    return modules


def cycles(modules: dict[str, Module]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan),
    each sorted, the list sorted: every import cycle lies in one of them."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0

    def visit(v: str) -> None:
        nonlocal counter
        index[v] = low[v] = counter
        counter += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(modules[v].imports):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp: list[str] = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(modules):
        if v not in index:
            visit(v)
    return sorted(found)


def _top_level_bindings(tree: ast.Module) -> tuple[set[str], set[str], list[str] | None]:
    """(names defined, names bound by an import, __all__ or None) at the top
    level of a module, looking into top-level if/try blocks."""
    defined: set[str] = set()
    imported: set[str] = set()
    all_names: list[str] | None = None

    def targets(node: ast.expr) -> list[str]:
        if isinstance(node, ast.Name):
            return [node.id]
        if isinstance(node, (ast.Tuple, ast.List)):
            return [n for elt in node.elts for n in targets(elt)]
        return []

    def scan(body: list[ast.stmt]) -> None:
        nonlocal all_names
        for stmt in body:
            if isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                defined.add(stmt.name)
            elif isinstance(stmt, ast.Import):
                for alias in stmt.names:
                    imported.add(alias.asname or alias.name.split(".")[0])
            elif isinstance(stmt, ast.ImportFrom):
                for alias in stmt.names:
                    imported.add(alias.asname or alias.name)
            elif isinstance(stmt, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
                tgts = stmt.targets if isinstance(stmt, ast.Assign) else [stmt.target]
                for tgt in tgts:
                    for name in targets(tgt):
                        if name == "__all__" and stmt.value is not None:
                            value = stmt.value
                            if isinstance(value, (ast.List, ast.Tuple)):
                                all_names = [
                                    e.value
                                    for e in value.elts
                                    if isinstance(e, ast.Constant) and isinstance(e.value, str)
                                ]
                        defined.add(name)
            elif isinstance(stmt, ast.If):
                if not _is_type_checking(stmt.test):
                    scan(stmt.body)
                scan(stmt.orelse)
            elif isinstance(stmt, ast.Try):
                scan(stmt.body)
                for handler in stmt.handlers:
                    scan(handler.body)
                scan(stmt.orelse)
                scan(stmt.finalbody)

    scan(tree.body)
    return defined - imported, imported, all_names


def taken_names(modules: dict[str, Module]) -> dict[str, set[str]]:
    """For each module, the names other modules take from it with
    ``from M import n``."""
    taken: dict[str, set[str]] = {name: set() for name in modules}
    for mod in modules.values():
        for _line, target, names in mod.from_imports:
            if target in taken and target != mod.name:
                taken[target].update(n for n in names if n != "*")
    return taken


def public_names(mod: Module, taken: set[str]) -> tuple[list[str], set[str]]:
    """(the module's public names, those of them bound by an import).

    The public names are ``__all__`` when the module has one; else the names
    it defines without a leading underscore and the imported names other
    modules take from it (`taken`)."""
    defined, imported, all_names = _top_level_bindings(mod.tree)
    if all_names is not None:
        names = list(dict.fromkeys(all_names))
    else:
        public = {n for n in defined if not n.startswith("_")}
        names = sorted(public | (imported & taken))
    return names, {n for n in names if n in imported}


def reexport_modules(modules: dict[str, Module]) -> list[str]:
    """Modules other than a package's __init__ most of whose public names are
    bound by an import: each line names the module and its counts."""
    taken = taken_names(modules)
    found: list[str] = []
    for mod in modules.values():
        if mod.is_package:
            continue
        names, imported = public_names(mod, taken[mod.name])
        if names and 2 * len(imported) > len(names):
            found.append(f"{mod.name}: {len(imported)} of {len(names)} public names imported")
    return sorted(found)


def indirect_imports(modules: dict[str, Module]) -> list[str]:
    """`from M import n` where M is a module (not a package) of the package
    that does not define n but imports it: the importer should import n from
    where it is defined (or from the package's face)."""
    bound = {name: _top_level_bindings(mod.tree) for name, mod in modules.items()}
    found: list[str] = []
    for mod in modules.values():
        for line, target, names in mod.from_imports:
            if target not in modules or modules[target].is_package:
                continue
            defined, imported, _ = bound[target]
            for n in names:
                if n != "*" and n in imported and n not in defined:
                    rel = mod.path.name if mod.is_package else mod.name
                    found.append(f"{mod.name} ({rel}:{line}) takes {n} from {target}")
    return sorted(found)


def forbidden_imports(
    modules: dict[str, Module], target: str, allowed: frozenset[str] = frozenset()
) -> list[str]:
    """Modules outside the package `target` (and not in `allowed`) that import
    it or one of its modules, at run time or for type checking only (e.g. a
    library importing aacmm.commands)."""
    found: list[str] = []
    for mod in modules.values():
        if mod.name == target or mod.name.startswith(target + ".") or mod.name in allowed:
            continue
        named = mod.imports | mod.type_imports
        bad = sorted(i for i in named if i == target or i.startswith(target + "."))
        if bad:
            found.append(f"{mod.name} imports {', '.join(bad)}")
    return sorted(found)


def package_cycles(modules: dict[str, Module], package: str) -> list[list[str]]:
    """:func:`cycles` between the subpackages and top-level modules of
    `package` (``aacmm.records``, ``aacmm.cli``, ...): every module stands for
    the one it lies in, and an import inside one of them is no edge."""

    def top(name: str) -> str:
        parts = name.split(".")
        return ".".join(parts[:2]) if len(parts) > 1 else name

    merged: dict[str, Module] = {}
    for mod in modules.values():
        t = top(mod.name)
        if t == package:
            continue  # the package's own __init__: the version string only
        m = merged.setdefault(t, Module(t, mod.path, True, ast.Module(body=[], type_ignores=[])))
        m.imports.update(top(i) for i in mod.imports if top(i) not in (t, package))
    return cycles(merged)
