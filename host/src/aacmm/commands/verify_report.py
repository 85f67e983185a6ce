"""Presentation of a verification report: text, figures and the one-page PDF.

Figures are built on :class:`matplotlib.figure.Figure` directly (no pyplot,
no global state); the command saves them with the shared output helper.
"""

from __future__ import annotations

import datetime as _dt
from typing import TYPE_CHECKING, Any

import numpy as np

from aacmm import __version__

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from aacmm.verification.report import Report

RULE_TEXT = {
    "simple": "simple acceptance: a value conforms when it does not exceed the MPE",
    "iso14253-1": "ISO 14253-1 conformance: a value passes only when it does not exceed MPE - U",
}
UM = 1000.0


def _mm(v: float | None, signed: bool = False) -> str:
    if v is None:
        return "-"
    return f"{v:+.4f}" if signed else f"{v:.4f}"


SIGNED = frozenset({"p_size", "effective_diameter", "e_uni"})


def result_rows(rep: Report) -> list[list[str]]:
    """Table rows: test, value, MPE, U, limit, verdict, where, definition status."""
    rows = []
    for r in rep.results:
        d = r.decision
        mark = "" if r.definition.status == "public summary" else " *"
        rows.append(
            [
                r.name + mark,
                _mm(r.value_mm, r.key in SIGNED),
                _mm(d.mpe),
                _mm(d.u),
                _mm(d.limit),
                d.verdict,
                r.where,
            ]
        )
    return rows


HEADER = ["test", "value mm", "MPE mm", "U mm", "limit mm", "verdict", "where"]


def text_report(rep: Report, source: str) -> str:
    """The plain-text report (what ``aacmm verify`` prints)."""
    lines = [f"aacmm verify: {source}"]
    lines.append(f"plan       {rep.plan_name}" + (f" ({rep.plan_title})" if rep.plan_title else ""))
    lines.append(f"plan hash  sha256 {rep.plan_sha256[:16]}")
    for k in ("device", "firmware", "params_crc32", "errmodel", "captured"):
        if k in rep.meta:
            lines.append(f"{k:<10} {rep.meta[k]}")
    lines.append(f"probe      ball diameter {rep.probe_diameter_mm:.4f} mm")
    if "temperature" in rep.meta:
        lines.append(f"temp.      {rep.meta['temperature']}")
    elif rep.temperature_c is not None:
        lines.append(f"temp.      {rep.temperature_c:g} C")
    if "compensation" in rep.meta:
        lines.append(f"compens.   {rep.meta['compensation']}")
    lines.append(f"rule       {rep.decision_rule}: {RULE_TEXT[rep.decision_rule]}")
    lines.append("")
    table = [HEADER, *result_rows(rep)]
    widths = [max(len(r[i]) for r in table) for i in range(len(HEADER))]
    for r in table:
        lines.append(
            "  ".join(
                c.ljust(w) if i in (0, 5, 6) else c.rjust(w)
                for i, (c, w) in enumerate(zip(r, widths, strict=True))
            ).rstrip()
        )
    n_pass = sum(r.decision.passed for r in rep.results)
    n_fail = sum(r.decision.failed for r in rep.results)
    n_none = len(rep.results) - n_pass - n_fail
    lines.append("")
    lines.append(
        f"verdict    {rep.verdict} ({len(rep.results)} tests: {n_pass} passed, {n_fail} failed"
        + (f", {n_none} without MPE)" if n_none else ")")
    )
    lines.append(f"({VALUE_NOTE})")
    extra = _detail_lines(rep)
    if extra:
        lines += ["", *extra]
    assumed = [res for res in rep.results if res.definition.status != "public summary"]
    if assumed:
        lines.append("")
        lines.append("* definition assumed, not verified against the standard's text (not public):")
        for res in assumed:
            lines.append(f"  {res.name}: {res.definition.definition}")
    for n in rep.notes:
        lines.append(f"note: {n}")
    return "\n".join(lines) + "\n"


def _detail_lines(rep: Report) -> list[str]:
    out = []
    for s in rep.spheres:
        t = s.test
        out.append(
            f"sphere {s.step_id}: D {t.diameter:.4f} mm (u {2 * t.fit.std['radius']:.4f}), "
            f"size error {t.size_error:+.4f}, form {t.form:.4f} mm, {t.fit.n_points} points"
        )
    for loc in rep.locations:
        out.append(
            f"location {loc.step_id}: {len(loc.test.fits)} articulations, "
            f"L_Dia {loc.test.l_dia:.4f} mm"
        )
    for m in rep.lengths:
        lt = m.test
        out.append(
            f"length {m.step_id} position {m.position + 1}: {lt.length:.4f} mm "
            f"(calibrated {lt.cal_length:.4f}), error {lt.error:+.4f} mm, {m.decision.verdict}"
        )
    for st in rep.seats:
        pt = st.test
        hr = " ".join(f"{v:.4f}" for v in pt.half_range)
        out.append(
            f"seat {st.step_id}: {len(pt.deviations)} articulations, 2 sigma {pt.two_sigma:.4f}, "
            f"max {pt.max_deviation:.4f}, (max-min)/2 x y z {hr} mm"
        )
    for p in rep.planes:
        out.append(
            f"plane {p.step_id}: flatness {p.fit.form:.4f} mm (least squares), "
            f"{p.min_zone.form:.4f} mm (minimum zone)"
        )
    return out


# ------------------------------------------------------------------ figures


def _new(w: float, h: float) -> Figure:
    from matplotlib.figure import Figure

    return Figure(figsize=(w, h), layout="constrained")


def spat_figure(rep: Report) -> Figure:
    """SPAT scatter: per seat position (row) the articulations' deviations in three views."""
    n = len(rep.seats)
    fig = _new(10.0, 3.2 * n)
    axes = fig.subplots(n, 3, squeeze=False)
    views = ((0, 1, "x", "y"), (0, 2, "x", "z"), (1, 2, "y", "z"))
    for row, st in zip(axes, rep.seats, strict=True):
        dev = (st.points - st.test.mean) * UM
        r2 = st.test.two_sigma * UM
        lim = max(float(np.max(np.abs(dev))), r2) * 1.15 + 1e-3
        for ax, (i, j, a, b) in zip(row, views, strict=True):
            ax.scatter(dev[:, i], dev[:, j], s=18, c=np.arange(len(dev)), cmap="viridis")
            for k, (x, y) in enumerate(zip(dev[:, i], dev[:, j], strict=True)):
                ax.annotate(
                    str(k + 1), (x, y), fontsize=6, xytext=(2, 2), textcoords="offset points"
                )
            t = np.linspace(0, 2 * np.pi, 100)
            ax.plot(r2 * np.cos(t), r2 * np.sin(t), "k--", lw=0.8, label="2 sigma")
            ax.set_xlim(-lim, lim)
            ax.set_ylim(-lim, lim)
            ax.set_aspect("equal")
            ax.set_xlabel(f"{a} - mean (um)")
            ax.set_ylabel(f"{b} - mean (um)")
            ax.grid(alpha=0.3)
        row[0].set_title(
            f"{st.step_id}: 2 sigma {r2:.1f} um, (max-min)/2 {st.test.max_half_range * UM:.1f} um",
            loc="left",
            fontsize=9,
        )
        row[0].legend(fontsize=7, loc="lower right")
    fig.suptitle("Single-point articulation (each point one articulation, numbered)")
    return fig


def _unit(values_mm: Any) -> tuple[float, str]:
    """(scale, name) to plot errors in: um, or mm once they reach a millimetre."""
    big = float(np.max(np.abs(values_mm))) if np.size(values_mm) else 0.0
    return (1.0, "mm") if big >= 1.0 else (UM, "um")


def _e_uni_axes(ax: Axes, rep: Report) -> None:
    lengths = np.array([m.test.cal_length for m in rep.lengths])
    res = rep.result("e_uni")
    scale, unit = _unit([m.test.error for m in rep.lengths])
    errors = np.array([m.test.error for m in rep.lengths]) * scale
    colors = ["tab:red" if m.decision.failed else "tab:blue" for m in rep.lengths]
    ax.scatter(lengths, errors, c=colors, s=22, zorder=3)
    ax.axhline(0.0, color="k", lw=0.6)
    grid = np.linspace(0.0, 1.1 * float(lengths.max()), 60)
    e_uni = getattr(rep.mpe, "e_uni", None)
    if e_uni is not None:
        line = np.array([e_uni.at(float(x)) for x in grid]) * scale
        ax.plot(grid, line, "r-", lw=1, label="+-MPE")
        ax.plot(grid, -line, "r-", lw=1)
        if rep.decision_rule == "iso14253-1":
            u = max(m.decision.u for m in rep.lengths) * scale
            ax.plot(grid, line - u, "r:", lw=1, label="MPE - U")
            ax.plot(grid, -(line - u), "r:", lw=1)
    ax.set_xlim(0.0, float(grid[-1]))
    ax.set_xlabel("calibrated length (mm)")
    ax.set_ylabel(f"length error ({unit})")
    ax.set_title(
        f"E_Uni ({res.decision.verdict}): worst relative to its MPE\n"
        f"{res.value_mm * scale:+.{1 if unit == 'um' else 4}f} {unit} at {res.where}",
        loc="left",
        fontsize=8,
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)


def e_uni_figure(rep: Report) -> Figure:
    """Length error against length with the MPE lines (the usual E_Uni chart)."""
    fig = _new(7.0, 4.0)
    _e_uni_axes(fig.subplots(), rep)
    return fig


def sphere_figure(rep: Report) -> Figure:
    """Radial residuals of each sphere fit (and each articulation of a location test)."""
    sets: list[tuple[str, np.ndarray]] = [(s.step_id, s.test.fit.residuals) for s in rep.spheres]
    for loc in rep.locations:
        res = np.concatenate([f.residuals for f in loc.test.fits])
        sets.append((f"{loc.step_id} (articulations in turn)", res))
    fig = _new(8.0, 2.6 * len(sets))
    axes = fig.subplots(len(sets), 1, squeeze=False)[:, 0]
    for ax, (name, r) in zip(axes, sets, strict=True):
        idx = np.arange(1, len(r) + 1)
        ax.bar(idx, r * UM, color=np.where(r >= 0, "tab:blue", "tab:orange"))
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlabel("point")
        ax.set_ylabel("radial residual (um)")
        ax.set_title(f"{name}: range {np.ptp(r) * UM:.1f} um", loc="left", fontsize=9)
        ax.grid(alpha=0.3, axis="y")
    fig.suptitle("Least-squares sphere residuals")
    return fig


def figures(rep: Report) -> dict[str, Figure]:
    """The report's figures by file name (only those the session has data for)."""
    out: dict[str, Figure] = {}
    if rep.seats:
        out["spat.png"] = spat_figure(rep)
    if rep.lengths:
        out["e_uni.png"] = e_uni_figure(rep)
    if rep.spheres or rep.locations:
        out["spheres.png"] = sphere_figure(rep)
    return out


def figure_names(rep: Report) -> list[str]:
    """The file names :func:`figures` will produce (for checking outputs first)."""
    names = []
    if rep.seats:
        names.append("spat.png")
    if rep.lengths:
        names.append("e_uni.png")
    if rep.spheres or rep.locations:
        names.append("spheres.png")
    return names


# ------------------------------------------------------------------ one page


PAGE_W_IN, PAGE_H_IN = 8.27, 11.69  # A4 portrait
LEFT, RIGHT = 0.07, 0.93  # text margins (page fraction)
FOOT = 0.055  # the signature line sits below
MAX_NOTES = 6
#: what "value" and "where" mean in the results table (text report and page)
VALUE_NOTE = (
    "value: each test's worst value relative to its acceptance limit (the largest "
    "|value| / limit); where: the step (and position) it was measured at"
)


class _Page:
    """Top-down layout of the one-page report: every line measured, wrapped to the
    margins, and nothing placed below the foot (docs/verification.md)."""

    def __init__(self, fig: Figure) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg(fig)
        self.fig = fig
        self.renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
        self.y = 0.955

    def width(self, artist: Any) -> float:
        """An artist's width in page fraction."""
        bb = artist.get_window_extent(self.renderer)
        return float(bb.width) / float(self.fig.bbox.width)

    def line_height(self, size: float) -> float:
        return 1.3 * size / 72.0 / PAGE_H_IN

    def wrap(self, s: str, size: float, width: float, **kw: Any) -> list[str]:
        """``s`` split at spaces into lines no wider than ``width`` (page fraction)."""
        probe = self.fig.text(0, 0, "", fontsize=size, **kw)
        out: list[str] = []
        line = ""
        for word in s.split(" "):
            cand = f"{line} {word}" if line else word
            probe.set_text(cand)
            if line and self.width(probe) > width:
                out.append(line)
                line = "    " + word
            else:
                line = cand
        out.append(line)
        probe.remove()
        return out

    def text(self, s: str, size: float = 8.5, x: float = LEFT, **kw: Any) -> None:
        for part in self.wrap(s, size, RIGHT - x, **kw):
            self.fig.text(x, self.y, part, fontsize=size, va="top", **kw)
            self.y -= self.line_height(size) + 0.0015

    def fit_axes(self, ax: Axes, box: tuple[float, float, float, float]) -> None:
        """Move and shrink ``ax`` until everything it draws (labels, ticks, title,
        legend) lies within ``box`` = (x0, y0, x1, y1), page fraction."""
        x0, y0, x1, y1 = box
        ax.set_position((x0, y0, x1 - x0, y1 - y0))
        inv = self.fig.transFigure.inverted()
        for _ in range(4):
            tight = ax.get_tightbbox(self.renderer)
            if tight is None:
                break
            tb = inv.transform_bbox(tight)
            pos = ax.get_position()
            left, right = pos.x0 - tb.x0, tb.x1 - pos.x1
            below, above = pos.y0 - tb.y0, tb.y1 - pos.y1
            nx0, nx1 = x0 + left, x1 - right
            ny0, ny1 = y0 + below, y1 - above
            if nx1 - nx0 < 0.05 or ny1 - ny0 < 0.03:
                break
            if (
                max(abs(nx0 - pos.x0), abs(nx1 - pos.x1), abs(ny0 - pos.y0), abs(ny1 - pos.y1))
                < 1e-4
            ):
                break
            ax.set_position((nx0, ny0, nx1 - nx0, ny1 - ny0))


def _results_table(page: _Page, rep: Report) -> None:
    """The results table, its font shrunk until it fits between the margins."""
    rows = result_rows(rep)
    height = 0.021 * (len(rows) + 1)
    ax = page.fig.add_axes((LEFT - 0.02, page.y - height, RIGHT - LEFT + 0.04, height))
    ax.axis("off")
    for size in (7.0, 6.5, 6.0, 5.5, 5.0, 4.5):
        table = ax.table(
            cellText=rows, colLabels=HEADER, loc="upper center", cellLoc="right", colLoc="center"
        )
        table.auto_set_font_size(False)
        table.set_fontsize(size)
        table.auto_set_column_width(list(range(len(HEADER))))
        if page.width(table) <= RIGHT - LEFT + 0.04 or size == 4.5:
            break
        table.remove()
    for (r, c), cell in table.get_celld().items():
        if r > 0 and c in (0, 6):
            cell.get_text().set_horizontalalignment("left")
        if r > 0 and cell.get_text().get_text() in ("PASS", "FAIL"):
            cell.get_text().set_color(
                "tab:green" if cell.get_text().get_text() == "PASS" else "tab:red"
            )
    drawn = page.fig.transFigure.inverted().transform_bbox(table.get_window_extent(page.renderer))
    page.y = float(drawn.y0) - 0.006
    page.text(VALUE_NOTE, 6.5, style="italic")


def _length_rows(rep: Report) -> list[str]:
    """Every length position as one fixed-width row (mm)."""
    w = max([len(m.step_id) for m in rep.lengths] + [4])
    rows = [f"{'step':<{w}} pos   measured calibrated    error verdict"]
    for m in rep.lengths:
        lt = m.test
        rows.append(
            f"{m.step_id:<{w}} {m.position + 1:>3} {lt.length:>10.4f} {lt.cal_length:>10.4f} "
            f"{lt.error:>+8.4f} {m.decision.verdict}"
        )
    return rows


def _details(page: _Page, rep: Report) -> None:
    """Every detail line of the text report: prose lines, then the lengths as a
    table flowing into as many columns as fit; what cannot fit (a plan far larger
    than a page) is counted and pointed to report.txt."""
    prose = [line for line in _detail_lines(rep) if not line.startswith("length ")]
    rows = _length_rows(rep) if rep.lengths else []
    notes = [f"Note: {n}" for n in rep.notes[:MAX_NOTES]]
    if len(rep.notes) > MAX_NOTES:
        notes.append(f"... and {len(rep.notes) - MAX_NOTES} more notes: see report.txt")
    tail = 3 * page.line_height(6.5) + 0.01  # definitions, assumptions, the pointer
    page.text(
        "Details (mm; every value of every test is in report.txt and report.json "
        "beside this page):",
        7,
        weight="bold",
    )
    for size in (6.5, 6.0, 5.5, 5.0):
        lh = page.line_height(size) + 0.0015
        avail = page.y - FOOT - tail - lh * len(notes)
        need_prose = sum(len(page.wrap(t, size, RIGHT - LEFT)) for t in prose) * lh
        if not rows:
            fits = need_prose <= avail
            cols, per_col = 1, 0
        else:
            probe = page.fig.text(0, 0, max(rows, key=len), fontsize=size, family="monospace")
            col_w = page.width(probe) + 0.025
            probe.remove()
            max_cols = max(1, int((RIGHT - LEFT + 0.02) // col_w))
            body = len(rows) - 1
            room = int((avail - need_prose) // lh) - 1  # rows per column below the header
            cols = min(max_cols, max(1, -(-body // max(room, 1))))
            per_col = -(-body // cols)
            fits = room >= 1 and per_col <= room
        if fits or size == 5.0:
            break
    budget = int(avail // lh) - (3 if rows else 0)  # rows: their header, one row, a pointer
    used = 0
    for k, t in enumerate(prose):
        n = len(page.wrap(t, size, RIGHT - LEFT))
        if used + n > budget - (1 if k < len(prose) - 1 else 0):
            page.text(
                f"... and {len(prose) - k} more detail lines, not shown for want of room: see "
                "report.txt (in the same folder as this PDF)",
                size,
                weight="bold",
            )
            break
        page.text(t, size)
        used += n
    shown = len(rows) - 1
    if rows:
        room = int((page.y - FOOT - tail - lh * len(notes)) // lh) - 1
        per_col = min(per_col, max(room, 0))
        shown = min(len(rows) - 1, per_col * cols)
        top = page.y
        for c in range(cols):
            chunk = rows[1 + c * per_col : 1 + min((c + 1) * per_col, shown)]
            if not chunk:
                break
            x = LEFT + c * col_w
            page.y = top
            for line in (rows[0], *chunk):
                page.fig.text(x, page.y, line, fontsize=size, va="top", family="monospace")
                page.y -= lh
        page.y = top - lh * (1 + per_col)
    if shown < len(rows) - 1:
        page.text(
            f"... and {len(rows) - 1 - shown} more length positions, not shown for want of "
            "room: see report.txt (in the same folder as this PDF)",
            size,
            weight="bold",
        )
    for note in notes:
        page.text(note, size)


def one_page(rep: Report, source: str, when: _dt.datetime | None = None) -> Figure:
    """An A4 page a lab can file: identification, rule, results, verdict, charts,
    every detail line (or where the rest is), notes; nothing outside the page.

    Text is measured without font hinting, so that the measured widths are the
    ones the PDF has (hinting narrows small text on screen by up to 8 %)."""
    import matplotlib

    with matplotlib.rc_context({"text.hinting": "none", "text.hinting_factor": 1}):
        return _one_page(rep, source, when)


def _one_page(rep: Report, source: str, when: _dt.datetime | None) -> Figure:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(PAGE_W_IN, PAGE_H_IN))
    page = _Page(fig)
    when = when or _dt.datetime.now(_dt.UTC)
    page.text("Arm performance verification", 16, weight="bold")
    page.y -= 0.008
    page.text("ISO 10360-12:2016 and ASME B89.4.22-2004 tests, evaluated by aacmm " + __version__)
    page.text(f"Session: {source}")
    page.text(
        f"Plan: {rep.plan_name}"
        + (f" -- {rep.plan_title}" if rep.plan_title else "")
        + f" (sha256 {rep.plan_sha256[:16]})"
    )
    arm = ", ".join(
        f"{label} {rep.meta[k]}"
        for k, label in (
            ("device", "device"),
            ("firmware", "firmware"),
            ("params_crc32", "parameter set"),
            ("errmodel", "error model"),
            ("captured", "captured"),
        )
        if k in rep.meta
    )
    if arm:
        page.text(f"Arm: {arm}")
    tc = f", temperature {rep.temperature_c:g} C" if rep.temperature_c is not None else ""
    page.text(f"Probe ball diameter {rep.probe_diameter_mm:.4f} mm{tc}")
    if "temperature" in rep.meta:
        page.text(f"Temperature: {rep.meta['temperature']}")
    if "compensation" in rep.meta:
        page.text(f"Compensation: {rep.meta['compensation']}")
    page.text(f"Decision rule: {rep.decision_rule} -- {RULE_TEXT[rep.decision_rule]}")
    page.text(f"Evaluated {when.strftime('%Y-%m-%d %H:%M UTC')}")
    page.y -= 0.01
    color = {"PASS": "tab:green", "FAIL": "tab:red"}.get(rep.verdict, "tab:gray")
    page.text(f"VERDICT: {rep.verdict}", 20, weight="bold", color=color)
    page.y -= 0.006
    _results_table(page, rep)
    page.y -= 0.012
    charts = [k for k, has in (("e_uni", bool(rep.lengths)), ("spat", bool(rep.seats))) if has]
    if charts:
        ch = 0.22
        w = (RIGHT - LEFT) / len(charts)
        for i, k in enumerate(charts):
            cax = fig.add_axes((LEFT + i * w, page.y - ch, w, ch))
            if k == "e_uni":
                _e_uni_axes(cax, rep)
            else:
                _spat_summary_axes(cax, rep)
            gap = 0.02 if i < len(charts) - 1 else 0.0
            page.fit_axes(cax, (LEFT + i * w, page.y - ch, LEFT + (i + 1) * w - gap, page.y))
        page.y -= ch + 0.012
    _details(page, rep)
    assumed = [r for r in rep.results if r.definition.status != "public summary"]
    page.y -= 0.004
    page.text(
        "Definitions. The standards' texts are not public; each result states the definition "
        "implemented (docs/verification.md).",
        6.5,
    )
    if assumed:
        page.text(
            "* assumed, not verified against the standard: " + "; ".join(r.name for r in assumed),
            6.5,
        )
    fig.text(
        LEFT,
        0.035,
        "Operator: ____________________    Signature: ____________________    Date: ____________",
        fontsize=8,
    )
    return fig


def _spat_summary_axes(ax: Axes, rep: Report) -> None:
    names = [s.step_id for s in rep.seats]
    x = np.arange(len(names))
    vals = [s.test.two_sigma for s in rep.seats] + [s.test.max_half_range for s in rep.seats]
    scale, unit = _unit(vals)
    ax.bar(x - 0.2, [s.test.two_sigma * scale for s in rep.seats], 0.4, label="2 sigma")
    ax.bar(x + 0.2, [s.test.max_half_range * scale for s in rep.seats], 0.4, label="(max-min)/2")
    for key, style in (("spat_2sigma", "C0--"), ("spat_range", "C1--")):
        mpe = rep.result(key).decision.mpe
        if mpe is not None:
            ax.axhline(mpe * scale, color=style[:2], ls="--", lw=1)
    ax.set_xticks(x, names, fontsize=7)
    ax.set_ylabel(unit)
    ax.set_title("Single-point articulation, per seat\n(dashed: MPE)", loc="left", fontsize=8)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, axis="y")


def report_json(rep: Report, source: str) -> dict[str, Any]:
    d = rep.to_dict()
    d["source"] = source
    d["aacmm_version"] = __version__
    return d
