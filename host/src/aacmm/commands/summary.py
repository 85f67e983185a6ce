"""``aacmm summary``: what a log (``aacmm log``) or a capture session holds.

A log: samples, duration, rate while connected, reconnect gaps, lost samples,
triggers and the extent of the point cloud (the same lines ``aacmm log``
prints when it ends). A session: plan, status, device, parameter sets and
points per step. Both give the range of the link temperatures the device read
(overall and per link), a session also the temperatures its capture runs
state. Both work on files cut short by kill -9. The figures come from
:mod:`aacmm.records.summary`; this module prints them and turns damage into
exit status 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from aacmm.commands.exitcodes import OK


def register(sub: Any) -> None:
    s = sub.add_parser(
        "summary",
        help="summarise a log (samples, rate, lost, extent) or a capture session",
        description="Read FILE.csv and its sidecar and print samples, rate, lost samples "
        "and the extent of the point cloud; or, for a capture session folder, its plan, "
        "status and points per step. Works on files cut short by kill -9.",
    )
    s.add_argument("output", metavar="FILE.csv|SESSION", help="the log or session folder")
    s.add_argument("--json", action="store_true", help="print JSON")
    s.set_defaults(func=cmd_summary)


def format_summary(d: dict[str, Any], files: list[Path] | None = None) -> str:
    """The summary lines; the rate is taken over the time connected, and each
    reconnect gap is listed with its length (#14.7)."""
    rate = f"{d['rate_hz']:.1f} Hz" if d.get("rate_hz") else "- Hz"
    gaps = d.get("gap_s") or []
    if gaps:
        each = ", ".join("?" if g is None else f"{g:.1f} s" for g in gaps)
        rate += f" while connected; {len(gaps)} gap{'s' if len(gaps) > 1 else ''}: {each}"
    presses = d.get("presses")
    # a press and its release are two trigger rows: people count the presses
    buttons = (
        f"triggers {d['triggers']}"
        if presses is None
        else f"presses {presses} ({d['triggers']} button edges)"
    )
    lines = [
        f"samples {d['samples']} in {d['duration_s']:.2f} s ({rate}), "
        f"lost {d['lost_samples']}, {buttons}, reconnects {d['reconnects']}"
    ]
    ext = d.get("extent_mm")
    if ext:
        lines.append(
            "extent "
            + ", ".join(
                f"{ax} {e['min']:.3f} .. {e['max']:.3f} ({e['size']:.3f})" for ax, e in ext.items()
            )
            + " mm"
        )
    else:
        lines.append("extent - (no valid points)")
    temps = temperature_line(d.get("temperature_c"), int(d.get("samples") or 0), "samples")
    if temps:
        lines.append(temps)
    if files:
        lines.append("files " + " ".join(str(f) for f in files))
    return "\n".join(lines)


def temperature_line(t: dict[str, Any] | None, rows: int, what: str) -> str | None:
    """``temperatures 20.00 .. 21.40 C (read at 80 of 80 points; link 1 ...)``: the
    range of the link temperatures the device read, None when it read none."""
    if not t:
        return None
    links = "; ".join(
        f"link {j} -" if r is None else f"link {j} {_span(r['min'], r['max'])}"
        for j, r in enumerate(t["links"], 1)
    )
    return (
        f"temperatures {_span(t['min'], t['max'])} C (all links read at {t['rows_read']} "
        f"of {rows} {what}; {links})"
    )


def _span(lo: float, hi: float) -> str:
    return f"{lo:.2f}" if lo == hi else f"{lo:.2f} .. {hi:.2f}"


def _damaged(path: Path, damage: list[str]) -> int:
    """A damaged file ends the summary with one line and exit status 2 (bad input)."""
    if not damage:
        return OK
    from aacmm.records.files import RecordError

    raise RecordError(f"{path}: damaged: {'; '.join(damage)}")


def cmd_summary(args: argparse.Namespace) -> int:
    from aacmm.records import summarize_file, summarize_session

    path = Path(args.output)
    if path.is_dir():
        d = summarize_session(path)
        if args.json:
            print(json.dumps(d, indent=2), flush=True)
            return _damaged(path, d["damage"])
        sets = ", ".join(f"0x{c:08x}" for c in d["param_sets"]) or "-"
        status = f"{d['status']}, damaged" if d["damage"] else d["status"]
        print(f"session {path} ({status}): {d['points']} of {d['of']} points")
        print(f"plan {d['plan']}: {d['title']}")
        print(f"device serial {d['device_serial_number']}, parameter sets {sets}")
        print(f"runs {', '.join(d['runs']) or '-'}")
        for st in d["steps"]:
            print(f"  {st['id']:16s} {st['procedure']:12s} {st['points']:4d} of {st['of']}")
        temps = temperature_line(d["temperature_c"], d["points"], "points")
        if temps:
            print(temps)
        if d["stated_temperature_c"]:
            stated = ", ".join(f"{t:g}" for t in d["stated_temperature_c"])
            print(f"stated at capture (aacmm capture --temperature): {stated} C")
        sys.stdout.flush()
        return _damaged(path, d["damage"])
    d = summarize_file(path)
    if args.json:
        print(json.dumps(d, indent=2))
    else:
        status = f"{d['status']}, damaged" if d["damage"] else d["status"]
        print(f"log {d['file']} ({status})")
        print(format_summary(d))
    sys.stdout.flush()
    return _damaged(path, d["damage"])
