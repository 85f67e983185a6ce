#!/usr/bin/env python3
"""Worst-case stack depth from GCC's -fcallgraph-info=su output.

Usage: stack_usage.py DIR_OR_CI_FILES... ENTRY [ENTRY...]

Reads every *.ci file under the given directories (or the .ci files named),
joins the call graphs across translation units and prints, for each entry
function, the deepest stack a call from it can use: the sum of frame sizes
along the worst call path. Functions without a frame size (library code such
as memcpy or ldexpf) are listed as "external" with the path that reaches them:
their own use must be added from their documentation. Recursion and dynamic
frames are reported and make the result a lower bound. Output is one line of
JSON per entry.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

NODE = re.compile(r'node: \{ title: "([^"]+)" label: "([^"]*)"')
EDGE = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')
SIZE = re.compile(r"\\n(\d+) bytes \((static|dynamic[^)]*)\)")


def load(paths: list[Path]) -> tuple[dict[str, tuple[int | None, bool]], dict[str, set[str]]]:
    frames: dict[str, tuple[int | None, bool]] = {}
    calls: dict[str, set[str]] = {}
    for path in paths:
        text = path.read_text()
        for title, label in NODE.findall(text):
            m = SIZE.search(label)
            if m:
                frames[title] = (int(m.group(1)), m.group(2) != "static")
            else:
                frames.setdefault(title, (None, False))
        for src, dst in EDGE.findall(text):
            calls.setdefault(src, set()).add(dst)
    return frames, calls


def worst(
    entry: str, frames: dict[str, tuple[int | None, bool]], calls: dict[str, set[str]]
) -> tuple[int, list[str], set[str], bool]:
    """(bytes, path, externals reached, exact) for the deepest path from entry."""
    externals: set[str] = set()
    exact = True
    memo: dict[str, tuple[int, list[str]]] = {}

    def visit(fn: str, stack: tuple[str, ...]) -> tuple[int, list[str]]:
        nonlocal exact
        if fn in stack:
            exact = False  # recursion: depth unbounded by the static graph
            return 0, [fn + " (recursion)"]
        if fn in memo:
            return memo[fn]
        size, dynamic = frames.get(fn, (None, False))
        if size is None:
            externals.add(fn.split(":")[-1])
            return 0, [fn.split(":")[-1] + " (external)"]
        if dynamic:
            exact = False
        best = (0, [])
        for callee in sorted(calls.get(fn, ())):
            best = max(best, visit(callee, (*stack, fn)), key=lambda t: t[0])
        result = (size + best[0], [fn.split(":")[-1], *best[1]])
        memo[fn] = result
        return result

    total, path = visit(entry, ())
    return total, path, externals, exact


def main(argv: list[str]) -> int:
    files: list[Path] = []
    entries: list[str] = []
    for arg in argv:
        p = Path(arg)
        if p.is_dir():
            files.extend(sorted(p.rglob("*.ci")))
        elif p.suffix == ".ci" and p.exists():
            files.append(p)
        else:
            entries.append(arg)
    if not files or not entries:
        print("usage: stack_usage.py DIR_OR_CI_FILES... ENTRY [ENTRY...]", file=sys.stderr)
        return 2
    frames, calls = load(files)
    status = 0
    for entry in entries:
        if entry not in frames:
            print(f"stack_usage: no function {entry!r} in the call graph", file=sys.stderr)
            status = 1
            continue
        total, path, externals, exact = worst(entry, frames, calls)
        print(
            json.dumps(
                {
                    "entry": entry,
                    "worst_stack_bytes": total,
                    "path": path,
                    "external_calls": sorted(externals),
                    "exact": exact,
                }
            )
        )
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
