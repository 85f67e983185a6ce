"""``aacmm log``: stream samples to a CSV file (``aacmm summary`` reads one back).

Files of a log ``run.csv`` (format in docs/cli.md):

- ``run.csv``: one row per streamed sample, columns :data:`aacmm.records.schema.LOG_COLUMNS`;
  readable by ``aacmm mc --log`` (:mod:`aacmm.analysis.poselog`);
- ``run.csv.json``: the sidecar (device info, parameter set and its CRC,
  units, start and end times, counters, gaps); written when the log starts
  (``"status": "running"``), after every reconnect, and atomically replaced
  at the end;
- ``run.triggers.csv``: probe-button captures (created at the first one);
- with ``--raw FILE`` over CAN: the raw frames in python-can's log formats.

Flush policy: rows go to the operating system every :data:`aacmm.records.logwriter.FLUSH_INTERVAL_S`
seconds or :data:`~aacmm.records.logwriter.FLUSH_ROWS` rows, whichever comes first, in single
``write`` calls of whole rows; so a logger killed with SIGKILL leaves a CSV
whose every line up to the last flush is complete. The files are fsynced
when the log ends.

Here: the command line and its checks. The run is :class:`aacmm.commands.logger.Logger`
(device, stream, reconnects) on :class:`aacmm.records.logwriter.LogWriter` (rows,
sidecar, summary), with :mod:`~aacmm.records.logsession` (counters),
:mod:`~aacmm.records.rawcan` (``--raw``) and :mod:`~aacmm.commands.stopflag` (signals).
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from aacmm.commands.common import add_connection_options, port_url
from aacmm.commands.exitcodes import UsageError
from aacmm.commands.logger import Logger

DEFAULT_RATE_HZ = 100


def register(sub: Any) -> None:
    p = sub.add_parser(
        "log",
        help="stream samples to a CSV file (+ JSON sidecar) until Ctrl-C, a duration or a count",
        description="Stream samples from the device into FILE.csv with a JSON sidecar "
        "FILE.csv.json; probe-button captures go to FILE.triggers.csv. Stops at Ctrl-C, "
        "SIGTERM, --duration or --count; the files are complete in every case.",
    )
    add_connection_options(p)
    p.add_argument("output", metavar="FILE.csv", help="the CSV file to write")
    p.add_argument(
        "-r",
        "--rate",
        type=int,
        default=DEFAULT_RATE_HZ,
        metavar="HZ",
        help=f"sample rate 1..1000 Hz (default {DEFAULT_RATE_HZ})",
    )
    p.add_argument("-d", "--duration", type=float, metavar="S", help="stop after S seconds")
    p.add_argument("-n", "--count", type=int, metavar="N", help="stop after N samples")
    p.add_argument(
        "--triggers",
        metavar="FILE",
        help="probe-button captures file (default: FILE.triggers.csv beside the log)",
    )
    p.add_argument("--no-triggers", action="store_true", help="do not record button captures")
    p.add_argument(
        "--raw",
        metavar="FILE",
        help="CAN only: also record the raw frames (.blf, .asc or .log, by suffix)",
    )
    p.add_argument(
        "--reconnect",
        action="store_true",
        help="when the device goes away, keep trying and continue the same log (gap recorded)",
    )
    p.add_argument(
        "--reconnect-timeout",
        type=float,
        metavar="S",
        help="with --reconnect: give up after S seconds without the device (default: never)",
    )
    p.add_argument(
        "--stall",
        type=float,
        default=2.0,
        metavar="S",
        help="no sample for S seconds means the link is lost (default 2)",
    )
    p.add_argument("-f", "--force", action="store_true", help="overwrite existing files")
    p.add_argument("-q", "--quiet", action="store_true", help="no live status line and no summary")
    p.set_defaults(func=cmd_log)


def cmd_log(args: argparse.Namespace) -> int:
    if not 1 <= args.rate <= 1000:
        raise UsageError(f"--rate {args.rate} outside 1..1000 Hz")
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise UsageError("--duration must be a positive number of seconds")
    if args.count is not None and args.count < 1:
        raise UsageError("--count must be at least 1")
    if args.reconnect_timeout is not None and not args.reconnect_timeout > 0:
        raise UsageError("--reconnect-timeout must be positive")
    if not args.stall > 0:
        raise UsageError("--stall must be positive")
    if args.no_triggers and args.triggers:
        raise UsageError("--triggers and --no-triggers exclude each other")
    url = port_url(args)
    return Logger(args, url).run()
