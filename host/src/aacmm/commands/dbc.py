"""``aacmm dbc``: the CAN database (DBC) of a device's node, for cantools and CAN tools.

The frame layout has one source, ``aacmm/data/aacmm.dbc`` (node 0); every
other node's identifiers are those plus the node id
(:func:`aacmm.protocol.can.dbc_text`). The package ships all sixteen as
``aacmm/data/dbc/aacmm-node<N>.dbc``; this command prints or writes one (or
all), so ``cantools decode`` and bus analysers decode a real capture.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from aacmm.commands.common import add_force_option
from aacmm.commands.exitcodes import OK, UsageError
from aacmm.fileio import check_outputs, write_output

NODES = range(16)


def _node(text: str) -> int:
    try:
        node = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if node not in NODES:
        raise argparse.ArgumentTypeError(f"node {node} outside 0..15")
    return node


def register(sub: Any) -> None:
    # (no aacmm.transport import here: it pulls python-can and cantools, and
    # every command's start-up would pay for it)
    p = sub.add_parser(
        "dbc",
        help="print or write the CAN database (DBC) of a node, for cantools and CAN tools",
        description="The DBC with the identifiers of CAN node N (by default the node the "
        "simulator and socketcan:// URLs use): sample, trigger and ISO-TP frames, so "
        "`cantools decode` and bus analysers decode a capture.",
    )
    p.add_argument(
        "--node",
        type=_node,
        default=None,
        metavar="N",
        help="CAN node 0..15 (default: the simulator's and the URLs' default node, 1)",
    )
    p.add_argument(
        "--all",
        action="store_true",
        help="all sixteen nodes: -o names a directory, files aacmm-node<N>.dbc",
    )
    p.add_argument("-o", "--output", metavar="PATH", help="write to PATH instead of stdout")
    add_force_option(p)
    p.set_defaults(func=cmd_dbc)


def cmd_dbc(args: argparse.Namespace) -> int:
    from aacmm.protocol.can import dbc_text
    from aacmm.transport import DEFAULT_CAN_NODE

    node = DEFAULT_CAN_NODE if args.node is None else args.node
    if args.all:
        if not args.output:
            raise UsageError("--all writes sixteen files: give the directory with -o DIR")
        directory = Path(args.output)
        if not directory.is_dir():
            raise UsageError(f"{directory} is not a directory")
        files = {n: directory / f"aacmm-node{n}.dbc" for n in NODES}
        check_outputs(files.values(), args.force)
        for n, path in files.items():
            write_output(path, dbc_text(n), force=args.force)
        print(f"wrote {len(files)} files aacmm-node0..15.dbc in {directory}", file=sys.stderr)
        return OK
    text = dbc_text(node)
    if args.output:
        check_outputs([args.output], args.force)
        write_output(args.output, text, force=args.force)
        print(f"wrote {args.output} (CAN node {node})", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return OK
