"""``aacmm model list|show|check``: the shipped arm models, and checking model files.

Model schema and the shipped models' sources: docs/models.md.
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from aacmm.commands.common import add_force_option
from aacmm.commands.exitcodes import OK


def register(sub: Any) -> None:
    p = sub.add_parser(
        "model",
        help="list the shipped arm models, show one, or check a model file",
        description="Arm models (docs/models.md): list the shipped models, show a model's "
        "joints and every parameter, check a model file (exit 2 with the reason if bad), or "
        "copy a shipped model to edit.",
    )
    ps = p.add_subparsers(dest="model_command", metavar="ACTION", required=True)
    ps.add_parser("list", help="the shipped models, one a line, name first").set_defaults(
        func=cmd_list
    )
    show = ps.add_parser("show", help="joints, parameters (with units), limits and encoders")
    show.add_argument("model", metavar="MODEL", help="a shipped model's name or a model file")
    show.add_argument("--json", action="store_true", help="print JSON")
    show.set_defaults(func=cmd_show)
    check = ps.add_parser("check", help="validate a model file (exit 2 with the reason if bad)")
    check.add_argument("model", metavar="FILE", help="a model file (or a shipped model's name)")
    check.set_defaults(func=cmd_check)
    ex = ps.add_parser("example", help="write a shipped model to a file, to edit for a new arm")
    ex.add_argument("name", help="the shipped model")
    ex.add_argument("-o", "--output", required=True, metavar="FILE", help="the file to write")
    add_force_option(ex)
    ex.set_defaults(func=cmd_example)


def cmd_list(args: argparse.Namespace) -> int:
    from aacmm.models import DEFAULT_MODEL, load_model, shipped_models

    for name in shipped_models():
        m = load_model(name)
        default = " (default)" if name == DEFAULT_MODEL else ""
        print(
            f"{name:14s} {m.n_joints} joints {m.n_params:2d} parameters "
            f"reach {m.reach_mm:6.0f} mm  {m.description}{default}"
        )
    return OK


def _limits(lo: float, hi: float) -> str:
    if math.isinf(lo):
        return "no limit"
    return f"{round(math.degrees(lo), 9):g} .. {round(math.degrees(hi), 9):g} deg"


def cmd_show(args: argparse.Namespace) -> int:
    from aacmm.models import load_model

    m = load_model(args.model)
    if args.json:
        print(json.dumps(m.to_dict(), indent=2))
        return OK
    mark = " (assumed)"
    print(f"model {m.name}: {m.description}")
    print(f"source: {m.source}")
    print(
        f"{m.n_joints} joints, {m.n_params} parameters, tip {m.arm.tip} "
        f"{list(m.arm.tip_mm)} mm, reach {m.reach_mm:g} mm"
    )
    for i, (j, (lo, hi), e) in enumerate(
        zip(m.arm.joints, m.joint_limits_rad, m.encoders, strict=True)
    ):
        k = i + 1
        beta = ", beta" if j.beta_rad is not None else ""
        print(
            f"  joint {k}: {j.convention}{mark if f'convention{k}' in m.assumed else ''}{beta}; "
            f"limits {_limits(lo, hi)}{mark if f'limits{k}' in m.assumed else ''}; "
            f"encoder {e.counts_per_rev} counts/rev, zero {e.zero_offset_counts}, "
            f"direction {e.direction:+d}, {e.interface}"
            f"{mark if f'encoder{k}' in m.assumed else ''}"
        )
    print(f"plans: calibration {m.calibration_plan}, verification {m.verification_plan}")
    print("parameters (Jacobian column order):")
    values = m.arm.to_vector()
    for name, v, unit in zip(m.arm.param_names, values, m.arm.param_units, strict=True):
        deg = f"  ({math.degrees(float(v)):.10g} deg)" if unit == "rad" else ""
        print(f"  {name:8s} {float(v)!r} {unit}{deg}{mark if name in m.assumed else ''}")
    if m.notes:
        print("notes:")
        for line in m.notes.splitlines():
            print(f"  {line}")
    return OK


def cmd_check(args: argparse.Namespace) -> int:
    from aacmm.models import load_model

    m = load_model(args.model)
    print(
        f"{args.model}: ok, model {m.name}, {m.n_joints} joints, {m.n_params} parameters, "
        f"{len(m.assumed)} assumed figures"
    )
    return OK


def cmd_example(args: argparse.Namespace) -> int:
    from pathlib import Path

    from aacmm.fileio import check_outputs, write_output
    from aacmm.models import shipped_model_path

    src = shipped_model_path(args.name)  # ModelError (exit 2) for an unknown name
    (out,) = check_outputs([Path(args.output)], args.force)
    write_output(out, src.read_bytes(), force=args.force)
    print(f"wrote {out}")
    return OK
