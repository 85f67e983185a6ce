"""The ``aacmm`` command line tool."""

from __future__ import annotations

import argparse
import importlib
import sys
from typing import Any

from aacmm import __version__

# Modules that add subcommands: each has register(subparsers), and each parser
# it adds sets ``func`` (args -> exit status). Keep their top-level imports
# light; import heavy modules inside the command functions.
COMMAND_MODULES: tuple[str, ...] = (  # the order of `aacmm --help`: the arm owner's workflow
    "aacmm.commands.device",
    "aacmm.commands.sim",
    "aacmm.commands.model",
    "aacmm.commands.log",
    "aacmm.commands.summary",
    "aacmm.commands.plan",
    "aacmm.commands.capture",
    "aacmm.commands.view",
    "aacmm.commands.verify",
    "aacmm.commands.calibrate",
    "aacmm.commands.fit",
    "aacmm.commands.mc",
    "aacmm.commands.uncertainty",
    "aacmm.commands.tolerance",
    "aacmm.commands.dbc",
    "aacmm.commands.demo",
)

DESCRIPTION = """\
The host tool of aacmm, an open stack for articulated arm coordinate measuring
machines: talk to an arm or the simulator, capture measurement plans, verify and
calibrate the arm, and analyse its error budget."""

EPILOG = """\
by task:
  start here       demo (the whole job on the simulator, in about a minute)
  the arm          info, params, measure, compute, log, summary, sim, model
  measuring        plan, capture, view, fit, export
  the arm's state  verify (ISO 10360-12, ASME B89.4.22), calibrate
  error budgets    mc, uncertainty, tolerance
  CAN tools        dbc

docs/tutorial.md is the demo's session with a real arm. Every command, option and
exit status: docs/cli.md; `aacmm COMMAND --help` for one command.
"""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="aacmm",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"aacmm {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run one command; its exit status (docs/cli.md, aacmm.commands.exitcodes).

    Errors end in one line on stderr, never a traceback; Ctrl-C ends in
    ``aacmm COMMAND: interrupted`` and status 130 wherever it lands (parsing,
    imports, the work); a stdout closed by its reader (``aacmm mc | head``)
    ends the command quietly, status 0, as for other command-line tools.
    """
    command = ""
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        command = args.command or ""
        func = getattr(args, "func", None)
        if args.command is None or func is None:
            parser.print_help()
            sys.stdout.flush()
            return 0
        status = _run(func, args)
        sys.stdout.flush()  # a closed pipe shows here, not at interpreter exit
        return status
    except KeyboardInterrupt:
        from aacmm.commands.exitcodes import INTERRUPTED

        print(f"aacmm {command}: interrupted" if command else "aacmm: interrupted", file=sys.stderr)
        return INTERRUPTED
    except BrokenPipeError:
        _stdout_gone()
        return 0


def _run(func: Any, args: argparse.Namespace) -> int:
    # Errors end in one line on stderr and a documented exit status
    # (aacmm.commands.exitcodes, docs/cli.md), never a traceback.
    from aacmm.commands.exitcodes import exit_code
    from aacmm.errors import AacmmError

    try:
        return int(func(args))
    except BrokenPipeError:
        raise
    except (AacmmError, ValueError) as exc:
        print(f"aacmm {args.command}: error: {exc}", file=sys.stderr)
        return exit_code(exc)
    except OSError as exc:
        print(f"aacmm {args.command}: error: {exc}", file=sys.stderr)
        return exit_code(exc)


def _stdout_gone() -> None:
    """The reader of stdout went away: say nothing more, there or at exit."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


if __name__ == "__main__":
    sys.exit(main())
