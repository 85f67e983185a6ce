"""``aacmm verify``: ISO 10360-12 / ASME B89.4.22 verification of a captured session.

Reads the session (its plan, and the raw counts of every accepted point with
the parameter set in force), recomputes the points with the C core, runs the
tests the plan's steps allow (:mod:`aacmm.verification.report`) and prints
the text report; ``--report DIR`` also writes the JSON, the figures and a
one-page PDF. Exit status 7 when the verdict is FAIL (everything is still
written), 2 for a session that cannot be verified.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from aacmm.commands.common import add_force_option

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
    add_force_option(p)
    p.add_argument("-q", "--quiet", action="store_true", help="print only the verdict line")
    p.set_defaults(func=run_verify)


def run_verify(args: argparse.Namespace) -> int:
    from aacmm.commands import verify_report as vr
    from aacmm.commands.exitcodes import NOT_MET, UsageError
    from aacmm.fileio import check_outputs, save_figure, write_output
    from aacmm.records.measured import load_session
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
    m = load_session(Path(args.session), partial=args.partial)
    assert m.plan is not None and m.labels is not None
    rep = evaluate(
        m.plan, m.labels, m.points, meta=m.meta, name=m.meta.get("plan"), l_dia_fit=args.l_dia_fit
    )
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
