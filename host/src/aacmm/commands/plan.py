"""``aacmm plan list|show|check|example``: the shipped plans, and checking plan files.

Plan schema: docs/plans.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from aacmm.commands.common import add_force_option
from aacmm.commands.exitcodes import NOT_MET, OK, UsageError


def register(sub: Any) -> None:
    p = sub.add_parser(
        "plan",
        help="list the shipped measurement plans, show or check a plan file",
        description="Measurement plans (docs/plans.md): list the shipped plans, show a "
        "plan's steps and points, check a plan file, or copy a shipped plan to edit.",
    )
    ps = p.add_subparsers(dest="plan_command", metavar="ACTION", required=True)
    ps.add_parser("list", help="the shipped plans").set_defaults(func=cmd_list)
    show = ps.add_parser("show", help="steps, artefacts and every point of a plan")
    show.add_argument("plan", metavar="PLAN", help="a plan file or a shipped plan's name")
    show.add_argument("--points", action="store_true", help="also list every point")
    show.add_argument("--json", action="store_true", help="print JSON")
    show.set_defaults(func=cmd_show)
    check = ps.add_parser(
        "check",
        help="validate a plan file (exit 2 with the reason if bad); with --model, also "
        "whether the arm reaches every target (exit 7 if not)",
    )
    check.add_argument("plan", metavar="PLAN", help="a plan file or a shipped plan's name")
    check.add_argument(
        "--model",
        metavar="NAME|FILE",
        help="an arm model (aacmm model list, or a model file): list every target it cannot "
        "reach within its joint limits, one a line, and exit 7 if there is one",
    )
    check.set_defaults(func=cmd_check)
    ex = ps.add_parser("example", help="write a shipped plan to a file, to edit")
    ex.add_argument("name", help="the shipped plan")
    ex.add_argument("-o", "--output", required=True, metavar="FILE", help="the file to write")
    add_force_option(ex)
    ex.set_defaults(func=cmd_example)


def cmd_list(args: argparse.Namespace) -> int:
    from aacmm.plans import load_plan, shipped_plans

    names = shipped_plans()
    width = max(24, *(len(n) for n in names))
    for name in names:
        plan = load_plan(name)
        steps = f"{len(plan.steps):2d} step{'s' if len(plan.steps) != 1 else ' '}"
        print(f"{name:{width}s} {steps} {len(plan.slots):4d} points  {plan.title}")
    return OK


def cmd_show(args: argparse.Namespace) -> int:
    from aacmm.plans import load_plan

    plan = load_plan(args.plan)
    if args.json:
        d: dict[str, Any] = plan.summary()
        if args.points:
            d["slots"] = [
                {
                    "index": s.index,
                    "step_id": s.step_id,
                    "position_index": s.position_index,
                    "end": s.end,
                    "articulation_index": s.articulation_index,
                    "point_index": s.point_index,
                    "target_mm": None if s.target is None else list(s.target.tip_mm),
                    "text": s.text,
                }
                for s in plan.slots
            ]
        print(json.dumps(d, indent=2))
        return OK
    print(f"plan {plan.name}: {plan.title} ({len(plan.slots)} points, sha256 {plan.sha256[:12]})")
    print(f"probe ball {plan.probe.ball_diameter_mm:g} mm")
    for a in plan.artefacts.values():
        extra = ""
        for key in ("diameter_mm", "length_mm"):
            if hasattr(a, key):
                extra = f" {key.removesuffix('_mm')} {getattr(a, key):g} mm"
        ref = " (calibrated reference)" if a.location_reference else ""
        loc = "" if a.location_mm is None else f" at {list(a.location_mm)}{ref}"
        print(f"  artefact {a.id}: {a.type}{extra}{loc}")
    for st in plan.steps:
        print(
            f"  step {st.index + 1} {st.id}: {st.procedure} on {st.artefact or '-'}, "
            f"{st.points} points" + (f" ({st.preset})" if st.preset else "")
        )
        if args.points:
            for s in plan.step_slots(st.index):
                print(f"    {s.index:4d}  {s.text}")
    return OK


def cmd_check(args: argparse.Namespace) -> int:
    from aacmm.plans import load_plan

    plan = load_plan(args.plan)
    if args.model is None:
        print(f"{plan.name}: ok, {len(plan.steps)} steps, {len(plan.slots)} points")
        return OK
    from aacmm.models import load_model
    from aacmm.simulation.reach import check_reach

    model = load_model(args.model)
    report = check_reach(plan, model)
    for item in report.unreachable:
        xyz = ", ".join(f"{v:g}" for v in item.target_mm)
        print(f"{item.number}: {item.label} at [{xyz}] mm: {item.reason}")
    for step in report.unchecked:
        print(f"note: step {step} has no nominal target (location_mm): not checked")
    bad, total = len(report.unreachable), len(report.items)
    verdict = "reaches every target" if not bad else f"cannot reach {bad} of {total} targets"
    print(
        f"{plan.name}: {len(plan.steps)} steps, {len(plan.slots)} points, {total} targets; "
        f"model {model.name} {verdict}"
    )
    return OK if not bad else NOT_MET


def cmd_example(args: argparse.Namespace) -> int:
    from pathlib import Path

    from aacmm.plans import shipped_plan_path, shipped_plans

    try:
        src = shipped_plan_path(args.name)
    except KeyError:
        raise UsageError(
            f"no shipped plan {args.name!r} (shipped: {', '.join(shipped_plans())})"
        ) from None
    from aacmm.fileio import check_outputs, write_output

    (out,) = check_outputs([Path(args.output)], args.force)
    write_output(out, src.read_bytes(), force=args.force)
    print(f"wrote {out}", file=sys.stdout)
    return OK
