"""``aacmm verify``: ISO 10360-12 / ASME B89.4.22 verification of a captured session.

Reads the session (its plan, and the raw counts of every accepted point with
the parameter set in force), recomputes the points with the C core, runs the
tests the plan's steps allow (:mod:`aacmm.verification.report`) and prints
the text report; ``--report DIR`` also writes the JSON, the figures and a
one-page PDF. Exit status 7 when the verdict is FAIL (everything is still
written), 2 for a session that cannot be verified.

``--params FILE`` applies the error model of FILE's ``[errmodel]`` table
(encoder harmonics, the links' thermal expansion) to the session's raw
counts; FILE must hold the parameter set the session was captured with.
Per point and link the device's link temperature wins (a session whose
points carry them); where it read none, ``--temperature C`` (the links'
temperature stated for the session) or else the temperature each capture run
states (``aacmm capture --temperature``, the session's ``runs``) is used;
a statement more than 1 degC from the readings gets one warning
(:func:`aacmm.records.measured.link_temperatures`). The lengths are scaled by
FILE's CTEs at them, and the report says which temperature (range) and which
compensation it used; a session with temperatures reports them even without
``--params`` (compensated when the set in force has the thermal block: the
device compensated, each point is recomputed at its readings). Bad input (a
temperature outside -40 .. 85 degC or not a number, a FILE of another set,
without an error model, or with CTEs and a point whose temperature nobody
stated): one line, exit status 2, nothing written.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from aacmm.commands.common import add_force_option, link_temperature

if TYPE_CHECKING:
    from aacmm.errmodel import ErrorModel
    from aacmm.records.measured import Measured

REPORT_TEXT = "report.txt"
REPORT_JSON = "report.json"
REPORT_PDF = "report.pdf"


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "verify",
        help="ISO 10360-12 / ASME B89.4.22 verification of a captured session",
        description="Evaluate a captured session against its plan's MPEs: P_Size, P_Form, "
        "L_Dia, E_Uni (ISO 10360-12), effective diameter, single-point articulation "
        "(2 sigma, SPAT), volumetric performance (ASME B89.4.22). Prints the text report; "
        "exit status 7 if the verdict is FAIL.",
    )
    p.add_argument("session", metavar="SESSION", help="a session written by aacmm capture")
    p.add_argument(
        "--report",
        metavar="DIR",
        help=f"write {REPORT_TEXT}, {REPORT_JSON}, {REPORT_PDF}, the figures "
        "(spat.png, e_uni.png, spheres.png), report.html (self-contained, interactive 3-D) "
        "and view.json (aacmm view DIR) into DIR (created if missing)",
    )
    p.add_argument("--json", metavar="FILE", help="write the JSON report to FILE ('-': stdout)")
    p.add_argument(
        "--partial",
        action="store_true",
        help="evaluate an incomplete session (the steps measured so far)",
    )
    p.add_argument(
        "--l-dia-fit",
        choices=("free", "fixed"),
        default="free",
        help="L_Dia: fit each articulation's sphere with a free radius (default) or with the "
        "calibrated radius (centre only; less sensitive to probing noise)",
    )
    p.add_argument(
        "--params",
        metavar="FILE",
        help="apply the error model of FILE's [errmodel] table (encoder harmonics, the links' "
        "thermal expansion cte_per_k, tref_c) to the session's readings; FILE must hold the "
        "parameter set the session was captured with",
    )
    p.add_argument(
        "--temperature",
        metavar="C",
        help="the links' temperature during the session, degC (-40 .. 85), for links the "
        "device did not read (its readings win): the lengths are scaled by --params FILE's "
        "CTEs at it (default: what each capture run states, aacmm capture --temperature)",
    )
    add_force_option(p)
    p.add_argument("-q", "--quiet", action="store_true", help="print only the verdict line")
    p.set_defaults(func=run_verify)


def _compensation(args: argparse.Namespace) -> tuple[ErrorModel | None, float | None]:
    """The error model of ``--params`` and the ``--temperature``, checked (UsageError)."""
    from aacmm.commands.exitcodes import UsageError
    from aacmm.records.paramfile import has_thermal, load_param_file_errmodel

    temp = link_temperature(args.temperature)
    if args.params is None:
        if temp is not None:
            raise UsageError(
                "--temperature needs the links' thermal expansion coefficients: "
                "--params FILE with cte_per_k in its [errmodel] table"
            )
        return None, None
    _, _, em = load_param_file_errmodel(args.params)
    if em is None:
        raise UsageError(f"--params {args.params}: no [errmodel] table, nothing to apply")
    if temp is not None and not has_thermal(em):
        raise UsageError(
            f"--temperature: {args.params} has no thermal expansion coefficients "
            "(cte_per_k in its [errmodel] table): nothing to compensate"
        )
    return em, temp


def _check_set(m: Measured, file: str) -> None:
    """The parameter file holds the set every point was captured with (UsageError)."""
    from aacmm.commands.exitcodes import UsageError
    from aacmm.records import ParamSetRecord
    from aacmm.records.paramfile import load_param_file_errmodel

    assert m.labels is not None
    own = ParamSetRecord.from_device(load_param_file_errmodel(file)[0])
    for rec in {p.param_set.crc32: p.param_set for p in m.labels}.values():
        if rec.model != own.model or rec.encoders != own.encoders:
            raise UsageError(
                f"--params {file}: holds parameter set {own.crc_hex}, the session was captured "
                f"with {rec.crc_hex}: its error model belongs to another set"
            )


def run_verify(args: argparse.Namespace) -> int:
    from aacmm.commands import verify_report as vr
    from aacmm.commands.exitcodes import NOT_MET, UsageError
    from aacmm.fileio import check_outputs, save_figure, write_output
    from aacmm.records.measured import (
        TemperatureNotStatedError,
        link_temperatures,
        load_session,
        span_text,
    )
    from aacmm.verification.report import evaluate
    from aacmm.verification.rules import FAIL, NO_MPE

    json_out = None if args.json in (None, "-") else Path(args.json)
    check_outputs([json_out], args.force)
    if args.report is not None:  # before the work: the report's folder and its fixed files
        from aacmm.fileio import check_output_dir
        from aacmm.view.html import report_names

        check_output_dir(
            args.report,
            [REPORT_TEXT, REPORT_JSON, REPORT_PDF, *report_names()],
            args.force,
            what=f"--report {args.report}",
        )
    em, temp = _compensation(args)
    m = load_session(Path(args.session), partial=args.partial)
    try:
        temps, temp_meta = link_temperatures(m, em, temp, args.params)
    except TemperatureNotStatedError as exc:
        raise UsageError(
            f"--params {args.params}: its [errmodel] table has the links' thermal expansion "
            f"and {exc}: give --temperature C (or aacmm capture --temperature C)"
        ) from None
    temp_warning = temp_meta.pop("temperature_warning", None)
    if temp_warning is not None:
        print(f"aacmm verify: warning: {temp_warning}", file=sys.stderr, flush=True)
    if em is not None:
        from aacmm.records.paramfile import describe_errmodel

        _check_set(m, args.params)
        m = load_session(Path(args.session), partial=args.partial, errmodel=em, temp_c=temps)
    assert m.plan is not None and m.labels is not None
    meta = {**m.meta, **temp_meta}
    if em is not None:
        meta["compensation"] = f"{describe_errmodel(em)} ({args.params})"
    rep = evaluate(
        m.plan, m.labels, m.points, meta=meta, name=m.meta.get("plan"), l_dia_fit=args.l_dia_fit
    )
    if temp_meta:
        lo, hi = temp_meta["temperature_range_c"]
        planned = rep.temperature_c
        notes = rep.notes
        if planned is not None and not lo == hi == planned:
            done = (
                "compensated to the parameters' reference"
                if temps is not None
                else ("not compensated")
            )
            notes = (
                *notes,
                f"the plan states the test at {planned:g} C; the session was taken at "
                f"{span_text([lo, hi])} ({done})",
            )
        if temp_warning is not None:
            notes = (*notes, temp_warning)
        band = m.plan.verification.band_problem([lo, hi])
        if band is not None:
            notes = (*notes, f"{band}: the session was not taken in stable conditions")
        rep = replace(rep, temperature_c=hi if lo == hi else None, notes=notes)
    source = str(args.session)
    text = vr.text_report(rep, source)
    doc = json.dumps(vr.report_json(rep, source), indent=2) + "\n"

    if rep.verdict == NO_MPE:  # refused before any file is written
        raise UsageError("no measured test has an MPE in the plan: nothing was judged")
    if args.report is not None:
        out = Path(args.report)
        if out.exists() and not out.is_dir():
            raise UsageError(f"--report {out}: not a directory")
        try:
            out.mkdir(exist_ok=True)
        except OSError as exc:
            raise UsageError(
                f"--report {out}: cannot create the directory: {exc.strerror}"
            ) from None
        from aacmm.view.html import report_names, write_report
        from aacmm.view.scene import verification_scene

        names = [REPORT_TEXT, REPORT_JSON, REPORT_PDF, *vr.figure_names(rep), *report_names()]
        check_outputs([out / n for n in names], args.force)
        write_output(out / REPORT_TEXT, text, force=args.force)
        write_output(out / REPORT_JSON, doc, force=args.force)
        for name, fig in vr.figures(rep).items():
            save_figure(fig, out / name, force=args.force, dpi=110)
        save_figure(vr.one_page(rep, source), out / REPORT_PDF, force=args.force)
        title = f"verification of {Path(source).name}: {rep.plan_title}"
        write_report(out, verification_scene(m.plan, m.labels, m.points, rep, title), args.force)
    if json_out is not None:
        write_output(json_out, doc, force=args.force)

    if args.json == "-":
        sys.stdout.write(doc)
    elif args.quiet:
        print(f"verdict {rep.verdict}")
    else:
        sys.stdout.write(text)
        if args.report is not None:
            print(f"report written to {args.report}")
    return NOT_MET if rep.verdict == FAIL else 0
