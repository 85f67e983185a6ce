"""The ``aacmm`` command line tool."""

from __future__ import annotations

import argparse
import importlib
import sys

from aacmm import __version__

# Modules that add subcommands: each has register(subparsers), and each parser
# it adds sets ``func`` (args -> exit status). Keep their top-level imports
# light; import heavy modules inside the command functions.
COMMAND_MODULES: tuple[str, ...] = ("aacmm.analysis.cli",)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="aacmm", description="aacmm host tool")
    parser.add_argument("--version", action="version", version=f"aacmm {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    func = getattr(args, "func", None)
    if args.command is None or func is None:
        parser.print_help()
        return 0
    return int(func(args))


if __name__ == "__main__":
    sys.exit(main())
