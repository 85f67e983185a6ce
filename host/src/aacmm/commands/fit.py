"""``aacmm fit`` and ``aacmm export``: ad-hoc features and point export.

``aacmm fit SOURCE FEATURE`` fits a point, line, plane, circle, sphere or
cylinder (orthogonal-distance least squares, :mod:`aacmm.geometry`) to
selected points of a session or a log, with form, uncertainty and optionally
the minimum-zone form; ``aacmm export SESSION --format xyz|ply|csv`` writes
the measured points with their labels for CAD and point-cloud tools.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aacmm.commands.common import add_force_option

if TYPE_CHECKING:
    from aacmm.geometry import Fit
    from aacmm.records.measured import Measured

FEATURES: tuple[str, ...] = ("point", "line", "plane", "circle", "sphere", "cylinder")
FORMATS: tuple[str, ...] = ("xyz", "ply", "csv")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "fit",
        help="fit a point, line, plane, circle, sphere or cylinder to measured points",
        description="Orthogonal-distance least-squares fit of one feature to points of a "
        "session or a log (points recomputed from the raw counts with the parameter set in "
        "force), with form (range of residuals), standard uncertainties and covariance.",
    )
    p.add_argument(
        "source",
        metavar="SOURCE",
        help="a session (aacmm capture), a log CSV, or a CSV of x, y, z points in mm",
    )
    p.add_argument("feature", choices=FEATURES, help="the feature to fit")
    sel = p.add_argument_group("point selection (default: every point)")
    sel.add_argument("--step", metavar="ID", help="session: only the points of this step")
    sel.add_argument(
        "--triggers",
        action="store_true",
        help="log: only the probe-button captures (the log's trigger file)",
    )
    sel.add_argument(
        "--points",
        metavar="LIST",
        help="1-based indices among the selected points: 1-25,30,40-",
    )
    g = p.add_argument_group("probe compensation")
    g.add_argument(
        "--probe-diameter",
        type=float,
        metavar="MM",
        help="probe ball diameter (default: the session plan's, else 0)",
    )
    g.add_argument("--inner", action="store_true", help="sphere/circle/cylinder: a hole or socket")
    g.add_argument(
        "--outward",
        metavar="X,Y,Z",
        help="plane: a direction from the material towards the probe (needed with a ball)",
    )
    p.add_argument("--axis", metavar="X,Y,Z", help="cylinder: a rough axis direction")
    p.add_argument(
        "--min-zone",
        action="store_true",
        help="plane/sphere: also the minimum-zone (Chebyshev) form",
    )
    p.add_argument("--json", metavar="FILE", help="write the fit as JSON ('-': stdout)")
    p.add_argument("--csv", metavar="FILE", help="write the points and their residuals")
    add_force_option(p)
    p.set_defaults(func=run_fit)

    e = sub.add_parser(
        "export",
        help="write a session's points with labels (xyz, ply, csv)",
        description="Export the measured points of a session (recomputed from the raw counts "
        "with the parameter set in force) with their labels: step, point, position, end, "
        "articulation.",
    )
    e.add_argument("session", metavar="SESSION", help="a session (aacmm capture) or a log CSV")
    e.add_argument(
        "--format",
        choices=FORMATS,
        help="output format (default: the one -o's suffix names: .xyz, .ply, .csv)",
    )
    e.add_argument("-o", "--output", metavar="FILE", help="output file (default: stdout)")
    e.add_argument("--step", metavar="ID", help="only the points of this step")
    add_force_option(e)
    e.set_defaults(func=run_export)


def parse_selection(spec: str, n: int) -> list[int]:
    """0-based indices from a 1-based list like ``1-25,30,40-`` over n points.

    Raises:
        UsageError: malformed, out of range, empty or repeated.
    """
    from aacmm.commands.exitcodes import UsageError

    out: list[int] = []
    for part in spec.split(","):
        part = part.strip()
        try:
            if "-" in part:
                a, b = part.split("-", 1)
                lo = int(a) if a.strip() else 1
                hi = int(b) if b.strip() else n
            else:
                lo = hi = int(part)
        except ValueError:
            raise UsageError(f"--points: {part!r} is not a number or range like 3-7") from None
        if not 1 <= lo <= hi <= n:
            raise UsageError(f"--points: {part!r} is outside 1..{n} (or reversed)")
        out.extend(range(lo - 1, hi))
    if len(set(out)) != len(out):
        raise UsageError("--points: a point is selected twice")
    return out


def _vector(text: str | None, what: str) -> tuple[float, float, float] | None:
    from aacmm.commands.exitcodes import UsageError

    if text is None:
        return None
    try:
        v = tuple(float(x) for x in text.split(","))
    except ValueError:
        v = ()
    if len(v) != 3 or not all(math.isfinite(x) for x in v) or not any(v):
        raise UsageError(f"{what}: give a non-zero vector as X,Y,Z, got {text!r}")
    return (v[0], v[1], v[2])


def _fit(args: argparse.Namespace, pts: Any, probe_r: float) -> Fit[Any]:
    from aacmm import geometry as g
    from aacmm.commands.exitcodes import UsageError

    f = args.feature
    if args.inner and f not in ("sphere", "circle", "cylinder"):
        raise UsageError("--inner applies to a sphere, circle or cylinder")
    if args.outward is not None and f != "plane":
        raise UsageError("--outward applies to a plane")
    if args.axis is not None and f != "cylinder":
        raise UsageError("--axis applies to a cylinder")
    if args.min_zone and f not in ("plane", "sphere"):
        raise UsageError("--min-zone is available for a plane or a sphere")
    if f == "point":
        return g.fit_point(pts)
    if f == "line":
        return g.fit_line(pts)
    if f == "plane":
        out = _vector(args.outward, "--outward")
        if probe_r > 0 and out is None:
            raise UsageError(
                "a plane probed with a ball needs --outward X,Y,Z (or --probe-diameter 0)"
            )
        return g.fit_plane(pts, probe_r, out)
    if f == "circle":
        return g.fit_circle(pts, probe_r, args.inner)
    if f == "sphere":
        return g.fit_sphere(pts, probe_r, args.inner)
    return g.fit_cylinder(pts, probe_r, args.inner, _vector(args.axis, "--axis"))


def _select(m: Measured, args: argparse.Namespace) -> list[int]:
    from aacmm.commands.exitcodes import UsageError

    idx = list(range(len(m.points)))
    if getattr(args, "step", None) is not None:
        idx = [i for i in idx if m.step_ids[i] == args.step]
        if not idx:
            known = ", ".join(dict.fromkeys(s for s in m.step_ids if s)) or "none"
            raise UsageError(f"no points of step {args.step!r} in {m.source} (steps: {known})")
    if getattr(args, "points", None) is not None:
        idx = [idx[k] for k in parse_selection(args.points, len(idx))]
    return idx


def fit_text(fit: Fit[Any], source: str, n_sel: str, mz: Any) -> str:
    """The printed result of ``aacmm fit``."""
    from dataclasses import asdict

    lines = [f"aacmm fit: {fit.kind} through {fit.n_points} points of {source}{n_sel}"]
    for k, v in asdict(fit.feature).items():
        if isinstance(v, tuple):
            lines.append(f"{k:<12} " + "  ".join(f"{x:.6f}" for x in v))
        else:
            lines.append(f"{k:<12} {v:.6f}")
    if fit.probe_radius:
        lines.append(f"probe        ball radius {fit.probe_radius:.4f} mm compensated")
    lines.append(f"form         {fit.form:.6f} mm (least squares), rms {fit.rms:.6f} mm")
    if "out_of_plane_form" in fit.extra:
        lines.append(f"out of plane {fit.extra['out_of_plane_form']:.6f} mm (range)")
    if mz is not None:
        lines.append(f"min. zone    {mz.form:.6f} mm ({mz.method})")
    if fit.dof > 0:
        lines.append(f"sigma        {fit.sigma:.6f} mm ({fit.dof} degrees of freedom)")
        unc = "  ".join(f"{k} {v:.6f}" for k, v in fit.std.items())
        lines.append(f"std. unc.    {unc}  (mm, rad)")
    else:
        lines.append(
            f"sigma        - (0 degrees of freedom: {fit.n_points} points fix a {fit.kind} "
            "exactly; more points give its sigma and uncertainties)"
        )
    return "\n".join(lines) + "\n"


def run_fit(args: argparse.Namespace) -> int:
    from aacmm import geometry as g
    from aacmm.commands.exitcodes import UsageError
    from aacmm.fileio import atomic_output, check_outputs, write_output
    from aacmm.plans.model import MAX_PROBE_DIAMETER_MM
    from aacmm.records.measured import load_points

    json_out = None if args.json in (None, "-") else Path(args.json)
    check_outputs([json_out, args.csv], args.force)
    m = load_points(Path(args.source), triggers=args.triggers)
    idx = _select(m, args)
    pts = m.points[idx]
    if args.probe_diameter is not None:
        if not (0 <= args.probe_diameter <= MAX_PROBE_DIAMETER_MM):  # also refuses NaN
            raise UsageError(
                f"--probe-diameter must be in 0..{MAX_PROBE_DIAMETER_MM:g} mm, "
                f"got {args.probe_diameter:g}"
            )
        probe_r = args.probe_diameter / 2.0
    else:
        probe_r = m.probe_diameter_mm / 2.0
    fit = _fit(args, pts, probe_r)
    mz = None
    if args.min_zone:
        mz = g.minimum_zone_plane(pts) if args.feature == "plane" else g.minimum_zone_sphere(pts)
    sel = f", step {args.step}" if getattr(args, "step", None) else ""
    if args.points is not None:
        sel += f", points {args.points}"
    doc = g.to_dict(fit)
    doc["source"] = str(args.source)
    doc["points"] = [m.names[i] for i in idx]
    if mz is not None:
        doc["min_zone_form_mm"] = mz.form
    text = json.dumps(doc, indent=2) + "\n"
    if json_out is not None:
        write_output(json_out, text, force=args.force)
    if args.csv is not None:
        with atomic_output(args.csv, force=args.force, newline="") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(["label", "x_mm", "y_mm", "z_mm", "residual_mm"])
            for i, r in zip(idx, fit.residuals, strict=True):
                w.writerow([m.names[i], *(f"{v:.6f}" for v in m.points[i]), f"{r:.6f}"])
    if args.json == "-":
        sys.stdout.write(text)
    else:
        sys.stdout.write(fit_text(fit, str(args.source), sel, mz))
        if "note" in m.meta:
            print(f"note         {m.meta['note']}")
    return 0


# ------------------------------------------------------------------ export


def export_text(m: Measured, idx: list[int], fmt: str) -> str:
    """The export file's content for the selected points.

    ``xyz``: three columns (``x y z`` in mm), nothing else, as point-cloud
    readers take it (numpy.loadtxt, trimesh, MeshLab, CloudCompare);
    ``ply``: the points with their labels as vertex properties, counted from 1
    (0: not applicable); ``csv``: the points with every label by name.
    """
    buf = io.StringIO()
    if fmt == "xyz":
        for i in idx:
            buf.write(" ".join(f"{v:.6f}" for v in m.points[i]) + "\n")
    elif fmt == "ply":
        buf.write("ply\nformat ascii 1.0\n")
        buf.write(f"comment aacmm export of {m.source.name}: ball centres in mm\n")
        buf.write(
            "comment step, point, position, articulation count from 1 as the prompts; "
            "end 1 = A, 2 = B; 0: not applicable\n"
        )
        for k, sid in enumerate(m.step_table()):
            buf.write(f"comment step {k + 1} = {sid}\n")
        buf.write(f"element vertex {len(idx)}\n")
        for p in ("x", "y", "z"):
            buf.write(f"property double {p}\n")
        for p in ("step", "point", "position", "end", "articulation"):
            buf.write(f"property int {p}\n")
        buf.write("end_header\n")
        for i in idx:
            nums = m.label_numbers(i)
            buf.write(
                " ".join(f"{v:.6f}" for v in m.points[i])
                + " "
                + " ".join(str(v) for v in nums)
                + "\n"
            )
    else:
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(
            [
                "index",
                "label",
                "step",
                "procedure",
                "artefact",
                "point",
                "position",
                "end",
                "articulation",
                "x_mm",
                "y_mm",
                "z_mm",
            ]
        )
        for i in idx:
            w.writerow([i + 1, m.names[i], *m.csv_labels(i), *(f"{v:.6f}" for v in m.points[i])])
    return buf.getvalue()


def export_format(fmt: str | None, output: str | None) -> str:
    """The export format: ``--format``, else the one ``-o``'s suffix names.

    Raises:
        UsageError: neither says one, or they disagree (``--format csv -o x.ply``).
    """
    from aacmm.commands.exitcodes import UsageError

    suffix = Path(output).suffix.lower().lstrip(".") if output else ""
    named = suffix if suffix in FORMATS else None
    if fmt is None:
        if named is None:
            where = f"{output} has no suffix of one" if output else "stdout has no file suffix"
            raise UsageError(f"give --format xyz, ply or csv ({where})")
        return named
    if named is not None and named != fmt:
        raise UsageError(f"--format {fmt}, but {output} names {named}: make them agree")
    return fmt


def run_export(args: argparse.Namespace) -> int:
    from aacmm.fileio import check_outputs, write_output
    from aacmm.records.measured import load_points

    fmt = export_format(args.format, args.output)
    check_outputs([args.output], args.force)
    m = load_points(Path(args.session))
    idx = _select(m, args)
    text = export_text(m, idx, fmt)
    if args.output is None:
        sys.stdout.write(text)
    else:
        write_output(args.output, text, force=args.force)
        print(f"{len(idx)} points written to {args.output} ({fmt})", file=sys.stderr)
    return 0
