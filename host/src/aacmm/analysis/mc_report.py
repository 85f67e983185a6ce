"""Monte Carlo coefficient results beside the paper's Table 2, and their reports.

:class:`CoefficientResult` (what :mod:`aacmm.analysis.mc` computes), the
comparison with the paper (:func:`compare_with_paper`), and the reports
:func:`format_report` (text), :func:`csv_text`, :func:`to_json` and
:func:`figure` (a matplotlib Figure). Pure functions; the ``aacmm mc``
command writes the files.

Any arm (issue 26): Table 2 is the paper's arm's (:attr:`CoefficientResult.is_paper`);
for another arm the reports give its own coefficients, every parameter of
it (:attr:`CoefficientResult.param_names`), without a comparison, and the
figure its N joints without the paper's markers.
"""

from __future__ import annotations

import csv
import io
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

import numpy as np

from aacmm.core import AXES, JOINTS, PARAM_NAMES, PARAM_UNITS, FloatArray

#: The arm model whose published Table 2 the reports compare with.
PAPER_MODEL = "gao2013"

#: Table 2 columns: (Jacobian row, Jacobian column offset, label).
TABLE2_COLUMNS: tuple[tuple[int, int, str], ...] = (
    (0, 6, "dfx/dalpha"),
    (1, 6, "dfy/dalpha"),
    (2, 6, "dfz/dalpha"),
    (0, 0, "dfx/dtheta"),
    (1, 0, "dfy/dtheta"),
    (2, 0, "dfz/dtheta"),
)


@dataclass(frozen=True)
class CoefficientResult:
    """Mean absolute error-transfer coefficients over a set of poses.

    Arrays are (3, P): rows x, y, z; columns :attr:`param_names` (the paper's
    arm: :data:`aacmm.core.PARAM_NAMES`, P = 25; any arm: its own, issue 26).
    ``mean_abs`` is the mean of |J| (mm/rad for theta, alpha; mm/mm for d,
    a, l), ``std_abs`` its sample standard deviation over the poses and
    ``sem`` the standard error of the mean. ``unit_norm_max_dev`` is the
    largest | ||J[:, k]|| - 1 | over the d, a, l columns and
    ``dfz_dtheta1_max`` the largest |df_z/dtheta_1| (any arm: the length columns,
    d, a and the tip, and theta1), both over the first
    ``checked_poses`` poses. Adaptive runs fill ``runs``, ``converged`` and
    ``tolerance`` (the JCGM 101 numerical tolerance delta per entry).
    ``model``: the arm model's name (None: the paper's arm, or an unnamed arm).
    """

    n: int
    mean_abs: FloatArray
    std_abs: FloatArray
    sem: FloatArray
    source: str
    seed: int | None
    joints: tuple[str, ...]
    unit_norm_max_dev: float
    dfz_dtheta1_max: float
    checked_poses: int
    elapsed_s: float
    threads: int
    runs: int = 1
    converged: bool | None = None
    tolerance: FloatArray | None = field(default=None)
    param_names: tuple[str, ...] = PARAM_NAMES
    model: str | None = None

    @property
    def is_paper(self) -> bool:
        """True for the paper's arm (its 25 parameters, model gao2013 or unnamed):
        the result the paper's Table 2 is compared with."""
        return self.param_names == PARAM_NAMES and self.model in (None, PAPER_MODEL)

    @property
    def n_joints(self) -> int:
        """N, the arm's joints (the theta columns)."""
        return sum(1 for n in self.param_names if n.startswith("theta"))

    @property
    def param_units(self) -> tuple[str, ...]:
        """The unit of each parameter (rad for theta, alpha, beta; mm otherwise)."""
        return tuple(
            "rad" if n.startswith(("theta", "alpha", "beta")) else "mm" for n in self.param_names
        )

    def table2(self) -> FloatArray:
        """The (6, 6) Table 2 layout: rows joints 1..6, columns :data:`TABLE2_COLUMNS`.

        Raises ValueError for a result of another arm than the paper's (:attr:`is_paper`).
        """
        if not self.is_paper:
            raise ValueError("Table 2 is the layout of the paper's arm (model gao2013)")
        return _table2(self.mean_abs)

    def table2_sem(self) -> FloatArray:
        """Standard errors in the Table 2 layout (the paper's arm only, as :meth:`table2`)."""
        if not self.is_paper:
            raise ValueError("Table 2 is the layout of the paper's arm (model gao2013)")
        return _table2(self.sem)


def _table2(a: FloatArray) -> FloatArray:
    out = np.empty((JOINTS, len(TABLE2_COLUMNS)))
    for c, (row, off, _) in enumerate(TABLE2_COLUMNS):
        out[:, c] = a[row, off : off + JOINTS]
    return out


def paper_table2() -> FloatArray:
    """The paper's Table 2 (6, 6) in mm/rad, from the package's data copy."""
    text = resources.files("aacmm").joinpath("data", "paper_table2.csv").read_text("utf-8")
    rows = [
        r
        for r in csv.reader(line for line in text.splitlines() if line and not line.startswith("#"))
    ]
    header, body = rows[0], rows[1:]
    if [h for h, _ in zip(header[1:], TABLE2_COLUMNS, strict=True)] != [
        c[2].replace("/", "_") for c in TABLE2_COLUMNS
    ]:
        raise ValueError("paper_table2.csv: unexpected columns")  # pragma: no cover
    return np.array([[float(v) for v in r[1:]] for r in body], dtype=np.float64)


@dataclass(frozen=True)
class PaperComparison:
    """One Table 2 entry beside the paper's value.

    ``rel_dev`` is (ours - paper) / paper, or ``None`` where the paper's
    value is 0 (df_z/dtheta_1, compared as an absolute value instead).
    """

    joint: int
    column: str
    ours: float
    sem: float
    paper: float
    rel_dev: float | None


def compare_with_paper(result: CoefficientResult) -> list[PaperComparison]:
    """Every Table 2 entry of ``result`` beside the paper's value."""
    ours, sem, paper = result.table2(), result.table2_sem(), paper_table2()
    out = []
    for i in range(JOINTS):
        for c, (_, _, label) in enumerate(TABLE2_COLUMNS):
            p = float(paper[i, c])
            rel = None if p == 0.0 else (float(ours[i, c]) - p) / p
            out.append(PaperComparison(i + 1, label, float(ours[i, c]), float(sem[i, c]), p, rel))
    return out


def max_rel_deviation(result: CoefficientResult) -> tuple[float, PaperComparison]:
    """The largest |relative deviation| from the paper and its entry."""
    comps = [c for c in compare_with_paper(result) if c.rel_dev is not None]
    worst = max(comps, key=lambda c: abs(c.rel_dev or 0.0))
    return abs(worst.rel_dev or 0.0), worst


def _header(result: CoefficientResult) -> list[str]:
    lines = [
        f"Mean |error transfer coefficient| (mm/rad) over {result.n} poses ({result.source})",
        f"joints: {', '.join(result.joints) if len(set(result.joints)) > 1 else result.joints[0]}"
        + (f"; seed {result.seed}" if result.seed is not None else ""),
    ]
    if result.converged is not None:
        lines.append(
            f"adaptive (JCGM 101 7.9): {result.runs} runs, {result.n} trials, "
            + ("converged" if result.converged else "NOT converged (max trials reached)")
        )
    return lines


def _arm_report(result: CoefficientResult) -> str:
    """The report of an arm other than the paper's: every coefficient, no Table 2."""
    name = result.model or "given arm"
    lines = _header(result)
    lines.insert(
        1,
        f"arm: {name} ({result.n_joints} joints, {len(result.param_names)} parameters); "
        "the paper's Table 2 is of its own arm (gao2013): no comparison",
    )
    head = f"{'param':<8} {'unit':>6}" + "".join(f"{f'|df{a}/dq|':>12}{'+-se':>8}" for a in AXES)
    lines += ["", head, "-" * len(head)]
    for k, (pname, unit) in enumerate(zip(result.param_names, result.param_units, strict=True)):
        lines.append(
            f"{pname:<8} {'mm/' + unit:>6}"
            + "".join(
                f"{result.mean_abs[r, k]:12.4g}{result.sem[r, k]:8.2g}" for r in range(len(AXES))
            )
        )
    lines += [
        "",
        f"length columns (d, a, tip): | ||dp/dq|| - 1 | <= {result.unit_norm_max_dev:.1e} "
        f"over {result.checked_poses} poses (norm 1)",
        f"df_z/dtheta_1 = 0: max |df_z/dtheta_1| = {result.dfz_dtheta1_max:g} over "
        f"{result.checked_poses} poses, mean |.| = {result.mean_abs[2, 0]:g} over all {result.n}",
        f"compute: {result.elapsed_s * 1e3:.1f} ms on {result.threads} thread(s), "
        f"{result.n / max(result.elapsed_s, 1e-9) / 1e6:.2f} Mposes/s",
    ]
    return "\n".join(lines)


def format_report(result: CoefficientResult) -> str:
    """The terminal report: Table 2 layout beside the paper, and the checks (the
    paper's arm); for another arm every coefficient and the checks."""
    if not result.is_paper:
        return _arm_report(result)
    ours, sem, paper = result.table2(), result.table2_sem(), paper_table2()
    lines = [
        f"Mean |error transfer coefficient| (mm/rad) over {result.n} poses ({result.source})",
        f"joints: {', '.join(result.joints) if len(set(result.joints)) > 1 else result.joints[0]}"
        + (f"; seed {result.seed}" if result.seed is not None else ""),
    ]
    if result.converged is not None:
        lines.append(
            f"adaptive (JCGM 101 7.9): {result.runs} runs, {result.n} trials, "
            + ("converged" if result.converged else "NOT converged (max trials reached)")
        )
    head = f"{'i':>2}  {'':6}" + "".join(f"{c[2]:>12}" for c in TABLE2_COLUMNS)
    lines += ["", head, "-" * len(head)]
    for i in range(JOINTS):
        lines.append(f"{i + 1:>2}  {'mean':6}" + "".join(f"{v:12.2f}" for v in ours[i]))
        lines.append(f"{'':>2}  {'+-se':6}" + "".join(f"{v:12.2f}" for v in sem[i]))
        lines.append(f"{'':>2}  {'paper':6}" + "".join(f"{v:12.2f}" for v in paper[i]))
        devs = []
        for c in range(len(TABLE2_COLUMNS)):
            devs.append(
                f"{'(abs)':>12}"
                if paper[i, c] == 0.0
                else f"{100.0 * (ours[i, c] - paper[i, c]) / paper[i, c]:+11.2f}%"
            )
        lines.append(f"{'':>2}  {'dev':6}" + "".join(devs))
    worst, entry = max_rel_deviation(result)
    lines += [
        "",
        f"max |relative deviation| from the paper: {100.0 * worst:.2f} % "
        f"(joint {entry.joint}, {entry.column})",
        f"Eq. 11-13: | ||dp/dd_i||, ||dp/da_i||, ||dp/dl|| - 1 | <= "
        f"{result.unit_norm_max_dev:.1e} over {result.checked_poses} poses (norm 1)",
        f"df_z/dtheta_1 = 0: max |df_z/dtheta_1| = {result.dfz_dtheta1_max:g} over "
        f"{result.checked_poses} poses, mean |.| = {result.mean_abs[2, 0]:g} over all {result.n}",
        f"compute: {result.elapsed_s * 1e3:.1f} ms on {result.threads} thread(s), "
        f"{result.n / max(result.elapsed_s, 1e-9) / 1e6:.2f} Mposes/s",
    ]
    return "\n".join(lines)


def csv_text(result: CoefficientResult) -> str:
    """All 3 P coefficients (75 for the paper's arm) as CSV text, one row per (axis,
    parameter), with the paper's value (the paper's arm; empty for another)."""
    paper = paper_table2()
    is_paper = result.is_paper
    units = PARAM_UNITS if is_paper else result.param_units
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(["axis", "parameter", "unit", "mean_abs", "std", "sem", "paper", "rel_dev"])
    for r, axis in enumerate(AXES):
        for k, name in enumerate(result.param_names):
            pv: float | None = None
            if is_paper and k < 12:
                col = (3 if k < 6 else 0) + r
                pv = float(paper[k % 6, col])
            rel = "" if pv is None or pv == 0.0 else f"{(result.mean_abs[r, k] - pv) / pv:.6g}"
            w.writerow(
                [
                    axis,
                    name,
                    f"mm/{units[k]}",
                    f"{result.mean_abs[r, k]:.10g}",
                    f"{result.std_abs[r, k]:.6g}",
                    f"{result.sem[r, k]:.6g}",
                    "" if pv is None else f"{pv:g}",
                    rel,
                ]
            )
    return buf.getvalue()


def to_json(result: CoefficientResult) -> dict[str, Any]:
    """A JSON-ready dict of the result (coefficients, Table 2 for the paper's arm,
    checks, metadata)."""
    coeffs = {
        name: {
            axis: {
                "mean_abs": float(result.mean_abs[r, k]),
                "std": float(result.std_abs[r, k]),
                "sem": float(result.sem[r, k]),
            }
            for r, axis in enumerate(AXES)
        }
        for k, name in enumerate(result.param_names)
    }
    if result.is_paper:
        units = {"theta": "mm/rad", "alpha": "mm/rad", "d": "mm/mm", "a": "mm/mm", "l": "mm/mm"}
    else:
        units = {n: f"mm/{u}" for n, u in zip(result.param_names, result.param_units, strict=True)}
    out: dict[str, Any] = {
        "n": result.n,
        "source": result.source,
        "seed": result.seed,
        "joints": list(result.joints),
        "threads": result.threads,
        "elapsed_s": result.elapsed_s,
        "units": units,
        "coefficients": coeffs,
    }
    checks = {
        "unit_norm_max_dev": result.unit_norm_max_dev,
        "dfz_dtheta1_max_abs": result.dfz_dtheta1_max,
        "checked_poses": result.checked_poses,
    }
    if not result.is_paper:
        out["checks"] = checks
        out["arm"] = {
            "model": result.model,
            "joints": result.n_joints,
            "parameters": list(result.param_names),
        }
    else:
        comps = compare_with_paper(result)
        worst, _ = max_rel_deviation(result)
        out["table2"] = [
            {
                "joint": c.joint,
                "column": c.column,
                "ours": c.ours,
                "sem": c.sem,
                "paper": c.paper,
                "rel_dev": c.rel_dev,
            }
            for c in comps
        ]
        out["max_abs_rel_dev"] = worst
        out["checks"] = checks
    if result.converged is not None:
        out["adaptive"] = {
            "runs": result.runs,
            "trials": result.n,
            "converged": result.converged,
            "max_tolerance": float(np.max(result.tolerance))
            if result.tolerance is not None
            else None,
        }
    return out


def joints_title(joints: Sequence[str]) -> str:
    """The joint distribution in words, joints sharing one grouped:
    ``all joints uniform[-180, 180) deg`` or
    ``joint 2 normal(0, 10) deg; joints 1, 3-6 uniform[-180, 180) deg``."""
    groups: dict[str, list[int]] = {}
    for i, d in enumerate(joints, start=1):
        groups.setdefault(d, []).append(i)
    if len(groups) == 1:
        return f"all joints {joints[0]}"

    def span(ids: list[int]) -> str:
        runs: list[list[int]] = []
        for i in ids:
            if runs and i == runs[-1][-1] + 1:
                runs[-1].append(i)
            else:
                runs.append([i])
        return ", ".join(str(r[0]) if len(r) == 1 else f"{r[0]}-{r[-1]}" for r in runs)

    parts = sorted(groups.items(), key=lambda kv: len(kv[1]))
    return "; ".join(f"joint{'s' if len(ids) > 1 else ''} {span(ids)} {d}" for d, ids in parts)


def figure(result: CoefficientResult) -> Any:
    """A matplotlib Figure: the alpha and theta coefficients per joint and axis.

    Bars: mean |coefficient| of this run (q_i = alpha_i left, theta_i
    right), with error bars of +-1 standard error of the mean (thin black
    lines, no caps); for the paper's arm the paper's Table 2 values as white
    diamonds with a black edge, so they cannot be mistaken for the error
    bars (another arm: its N joints, no diamonds, its model in the title). The title
    names the poses and their distribution. Built without pyplot (no global
    state; safe from threads); save it with :func:`aacmm.fileio.save_figure`.
    """
    from matplotlib.artist import Artist
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    n = result.n_joints
    paper: FloatArray | None
    if result.is_paper:
        ours, sem, paper = result.table2(), result.table2_sem(), paper_table2()
    else:  # the same layout, N joints: columns alpha x, y, z then theta x, y, z
        cols = [(r, off) for off in (n, 0) for r in range(len(AXES))]
        ours = np.stack([result.mean_abs[r, off : off + n] for r, off in cols], axis=1)
        sem = np.stack([result.sem[r, off : off + n] for r, off in cols], axis=1)
        paper = None
    fig = Figure(figsize=(11, 5.0), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    x = np.arange(1, n + 1)
    width = 0.26
    colors = ("tab:blue", "tab:orange", "tab:green")
    for p, (ax, g) in enumerate(zip(axes, (r"\alpha", r"\theta"), strict=True)):
        for r in range(len(AXES)):
            c = 3 * p + r
            xs = x + (r - 1) * width
            ax.bar(xs, ours[:, c], width, color=colors[r])
            ax.errorbar(xs, ours[:, c], yerr=sem[:, c], fmt="none", ecolor="black", elinewidth=1)
            if paper is None:
                continue
            ax.plot(
                xs,
                paper[:, c],
                linestyle="none",
                marker="D",
                markersize=5,
                markerfacecolor="white",
                markeredgecolor="black",
            )
        ax.set_title(rf"Mean |error transfer coefficient| of ${g}_i$ (mm/rad)")
        ax.set_xlabel("joint $i$")
        ax.set_xticks(x)
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylabel("mm/rad")
    handles: list[Artist] = [
        Patch(color=colors[r], label=rf"$|\partial f_{a} / \partial q_i|$, this run")
        for r, a in enumerate(AXES)
    ]
    handles.append(
        Line2D([], [], color="black", linewidth=1, label=r"error bar: $\pm 1$ standard error")
    )
    if paper is not None:
        handles.append(
            Line2D(
                [],
                [],
                linestyle="none",
                marker="D",
                markerfacecolor="white",
                markeredgecolor="black",
                label="paper, Table 2",
            )
        )
    fig.legend(handles=handles, loc="outside lower center", ncols=5, fontsize=8, frameon=False)
    seed = f", seed {result.seed}" if result.seed is not None else ""
    title = f"{result.n} poses ({result.source}{seed}); {joints_title(result.joints)}"
    if not result.is_paper:
        title = f"{result.model or 'given arm'} ({n} joints): {title}"
    fig.suptitle("\n".join(textwrap.wrap(title, 150)), fontsize=9)
    return fig
