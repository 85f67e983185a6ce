"""Results of :func:`aacmm.uncertainty.propagate` and their reports.

:class:`UncertaintyResult` holds one :class:`PoseResult` per pose and the
budget (:class:`BudgetEntry`); :func:`format_report` (terminal text),
:func:`to_json` (JSON-ready data), :func:`csv_text` (one row per pose and
axis) and :func:`figure` (a matplotlib Figure) present it. Pure functions:
the ``aacmm uncertainty`` command writes the files.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from aacmm.core import AXES, JOINTS, FloatArray
from aacmm.uncertainty.spec import ANGLE_UNITS, UncertaintySpec


@dataclass(frozen=True)
class PoseResult:
    """Uncertainty of the probe point at one pose (mm; deviations from the nominal point).

    ``u_lin``/``u_mc``: standard uncertainty per axis (3,); ``bias_mc``: MC
    mean minus nominal point; ``ci_lin``/``ci_mc`` (3, 2): 95 % coverage
    intervals of the deviation; ``u3_*``: sqrt(u_x^2 + u_y^2 + u_z^2);
    ``r95_mc``: 95 % quantile of the distance to the nominal point;
    ``contrib`` (P,): variance contributions sum_r J_rk^2 u_k^2 (mm^2);
    ``valid``: JCGM 101 section 8 agreement at tolerance ``delta`` (3,).
    """

    theta_rad: FloatArray
    point_mm: FloatArray
    u_lin: FloatArray
    u_mc: FloatArray
    bias_mc: FloatArray
    ci_lin: FloatArray
    ci_mc: FloatArray
    u3_lin: float
    u3_mc: float
    r95_mc: float
    contrib: FloatArray
    delta: FloatArray
    valid: bool


@dataclass(frozen=True)
class BudgetEntry:
    """One parameter's place in the budget (averaged over the analysed poses).

    ``u``: its standard uncertainty (rad or mm); ``sensitivity``: RMS over
    poses of ||J[:, k]|| (mm per rad or mm per mm); ``contribution_mm``:
    sqrt of its mean variance contribution; ``share``: fraction of the total.
    With correlated parameters a contribution (J Sigma J^T split by parameter)
    can be negative: its sign is kept on ``contribution_mm`` and ``share``.
    """

    name: str
    unit: str
    u: float
    sensitivity: float
    contribution_mm: float
    share: float


@dataclass(frozen=True)
class UncertaintyResult:
    """Result of :func:`propagate` over ``poses`` (given poses, then workspace poses).

    ``quantiles`` says how the Monte Carlo quantiles were formed ("exact", or
    from histograms when the trials exceed the memory budget); ``threads``
    how many threads computed them.
    """

    spec: UncertaintySpec
    trials: int
    seed: int
    ndig: int
    poses: tuple[PoseResult, ...]
    n_given: int
    budget: tuple[BudgetEntry, ...]
    group_shares: dict[str, float]
    elapsed_s: float
    quantiles: str = "exact"
    threads: int = 1
    #: The workspace poses' joint ranges [low, high) rad (None: every joint in [-pi, pi)).
    workspace_ranges_rad: tuple[tuple[float, float], ...] | None = None

    def workspace_text(self) -> str:
        """How the workspace poses were drawn, in words (degrees)."""
        r = self.workspace_ranges_rad
        if r is None:
            return "joints uniform in [-180, 180) deg"
        parts = ", ".join(f"[{math.degrees(lo):g}, {math.degrees(hi):g})" for lo, hi in r)
        return f"joints uniform within the arm's limits: {parts} deg"

    @property
    def given(self) -> tuple[PoseResult, ...]:
        """Results at the poses given explicitly."""
        return self.poses[: self.n_given]

    @property
    def workspace(self) -> tuple[PoseResult, ...]:
        """Results at the random workspace poses."""
        return self.poses[self.n_given :]

    def ratio_range(self) -> tuple[float, float]:
        """Min and max of u_mc / u_lin over all poses and axes (u_lin > 0)."""
        r = np.concatenate([p.u_mc[p.u_lin > 0] / p.u_lin[p.u_lin > 0] for p in self.poses])
        return float(r.min()), float(r.max())

    def valid_fraction(self) -> float:
        """Fraction of poses where the JCGM 101 section 8 check passes."""
        return float(np.mean([p.valid for p in self.poses]))


def _fmt_unit(e: BudgetEntry) -> str:
    if e.unit == "rad":
        return f"{e.u / ANGLE_UNITS['arcsec']:.3g} arcsec"
    return f"{e.u * 1e3:.3g} um"


def format_report(res: UncertaintyResult, top: int = 10, pose_rows: int = 8) -> str:
    """Terminal report: per-pose table (given poses), workspace summary, budget."""
    um = 1e3
    lines = [
        f"Probe-point uncertainty: Monte Carlo (JCGM 101, {res.trials} trials) vs "
        f"linear J Sigma J^T (GUM); values in um; 95 % intervals of the deviation",
        f"agreement: JCGM 101 sec. 8 check with {res.ndig} significant digit(s) of u_lin",
    ]
    if res.spec.model is not None or res.spec.joints != JOINTS or len(res.spec.items) != 25:
        arm = res.spec.arm
        lines.append(
            f"arm: {res.spec.model or 'given arm'} ({arm.n_joints} joints, "
            f"{arm.n_params} parameters)"
        )
    pw = 4 + 5 * res.spec.joints  # the pose column's width (34 for six joints)
    shown = list(res.given) or list(res.workspace[:pose_rows])
    title = "given poses" if res.given else f"first {len(shown)} workspace poses"
    lines += [
        "",
        f"{title}:",
        f"{'pose (deg)':>{pw}} {'ax':>2} {'u_lin':>8} {'u_mc':>8} {'ratio':>6} "
        f"{'bias_mc':>8} {'95% lin':>19} {'95% mc':>19} ok",
    ]
    for p in shown:
        pose = ",".join(f"{math.degrees(t):.0f}" for t in p.theta_rad)
        for r, ax in enumerate(AXES):
            ratio = p.u_mc[r] / p.u_lin[r] if p.u_lin[r] > 0 else float("nan")
            lines.append(
                f"{pose if r == 0 else '':>{pw}} {ax:>2} {p.u_lin[r] * um:8.3f} "
                f"{p.u_mc[r] * um:8.3f} {ratio:6.3f} {p.bias_mc[r] * um:+8.3f} "
                f"[{p.ci_lin[r, 0] * um:+8.3f},{p.ci_lin[r, 1] * um:+8.3f}] "
                f"[{p.ci_mc[r, 0] * um:+8.3f},{p.ci_mc[r, 1] * um:+8.3f}] "
                + ("yes" if r == 0 and p.valid else ("NO" if r == 0 else ""))
            )
        lines.append(
            f"{'':>{pw}} 3D u_lin {p.u3_lin * um:.3f}, u_mc {p.u3_mc * um:.3f}, "
            f"95 % of MC points within {p.r95_mc * um:.3f} of nominal"
        )
    ws = res.workspace
    if ws:
        ul = np.array([p.u_lin for p in ws])
        umc = np.array([p.u_mc for p in ws])
        lines += [
            "",
            f"workspace ({len(ws)} random poses, {res.workspace_text()}):",
            "  RMS u per axis (x, y, z), linear: "
            + ", ".join(f"{v * um:.3f}" for v in np.sqrt((ul**2).mean(axis=0)))
            + "; Monte Carlo: "
            + ", ".join(f"{v * um:.3f}" for v in np.sqrt((umc**2).mean(axis=0))),
            f"  3D u: median {np.median([p.u3_mc for p in ws]) * um:.3f}, "
            f"max {max(p.u3_mc for p in ws) * um:.3f}; 95 % radius: median "
            f"{np.median([p.r95_mc for p in ws]) * um:.3f}, "
            f"max {max(p.r95_mc for p in ws) * um:.3f}",
        ]
    lo, hi = res.ratio_range()
    lines.append(
        f"agreement over all {len(res.poses)} poses: u_mc/u_lin in [{lo:.4f}, {hi:.4f}]"
        f", JCGM 101 sec. 8 check passed at {100 * res.valid_fraction():.0f} % of poses"
    )
    lines += [
        "",
        f"budget (mean over the {len(res.poses)} poses; share of the 3D variance):",
        f"  {'param':<8} {'u':>14} {'sensitivity':>18} {'contrib um':>11} {'share':>8}",
    ]
    for e in res.budget[:top]:
        # per unit of the parameter as the model takes it (rad or mm), whatever
        # unit its u is shown in (arcsec, um)
        sens = f"{e.sensitivity:.3f} mm/{e.unit}"
        lines.append(
            f"  {e.name:<8} {_fmt_unit(e):>14} {sens:>18} "
            f"{e.contribution_mm * um:11.3f} {100 * e.share:7.2f}%"
        )
    g = res.group_shares
    ang_groups = [k for k in g if k in ("theta", "alpha", "beta")]
    len_groups = [k for k in g if k not in ang_groups]
    ang = sum(g[k] for k in ang_groups)
    lines += [
        "  groups: " + ", ".join(f"{k} {100 * v:.2f}%" for k, v in g.items()),
        f"  => angles ({', '.join(sorted(ang_groups))}): {100 * ang:.1f} % of the variance; "
        f"lengths ({', '.join(len_groups)}): {100 * (1 - ang):.1f} %"
        + (
            " -- alpha and theta dominate, as the paper concludes"
            if ang > 0.5 and ang_groups == ["theta", "alpha"]
            else ""
        ),
        f"compute: {res.elapsed_s:.2f} s on {res.threads} thread(s); MC quantiles: {res.quantiles}",
    ]
    return "\n".join(lines)


def to_json(res: UncertaintyResult) -> dict[str, Any]:
    """A JSON-ready dict (mm and rad)."""

    def pose(p: PoseResult) -> dict[str, Any]:
        return {
            "theta_rad": p.theta_rad.tolist(),
            "point_mm": p.point_mm.tolist(),
            "u_lin_mm": p.u_lin.tolist(),
            "u_mc_mm": p.u_mc.tolist(),
            "bias_mc_mm": p.bias_mc.tolist(),
            "ci95_lin_mm": p.ci_lin.tolist(),
            "ci95_mc_mm": p.ci_mc.tolist(),
            "u3_lin_mm": p.u3_lin,
            "u3_mc_mm": p.u3_mc,
            "r95_mc_mm": p.r95_mc,
            "jcgm101_delta_mm": p.delta.tolist(),
            "agree": p.valid,
        }

    lo, hi = res.ratio_range()
    units = res.spec.param_units
    arm = res.spec.arm
    return {
        "trials": res.trials,
        "seed": res.seed,
        "ndig": res.ndig,
        "arm": {
            "model": res.spec.model,
            "joints": arm.n_joints,
            "parameters": list(res.spec.param_names),
        },
        "uncertainties": {
            i.name: {"u": i.u, "unit": units[k], "distribution": i.distribution}
            for k, i in enumerate(res.spec.items)
        },
        "given_poses": [pose(p) for p in res.given],
        "workspace_poses": [pose(p) for p in res.workspace],
        **(
            {}
            if res.workspace_ranges_rad is None
            else {
                "workspace_joint_ranges_deg": [
                    [math.degrees(lo), math.degrees(hi)] for lo, hi in res.workspace_ranges_rad
                ]
            }
        ),
        "agreement": {"ratio_min": lo, "ratio_max": hi, "valid_fraction": res.valid_fraction()},
        "budget": [
            {
                "name": e.name,
                "unit": e.unit,
                "u": e.u,
                "sensitivity": e.sensitivity,
                "sensitivity_unit": f"mm/{e.unit}",
                "contribution_mm": e.contribution_mm,
                "share": e.share,
            }
            for e in res.budget
        ],
        "group_shares": res.group_shares,
        "elapsed_s": res.elapsed_s,
        "threads": res.threads,
        "mc_quantiles": res.quantiles,
    }


def csv_columns(joints: int = JOINTS) -> tuple[str, ...]:
    """CSV columns of :func:`csv_text` for an arm of ``joints`` joints."""
    return ("pose", "kind", *(f"theta{i}_deg" for i in range(1, joints + 1)), *_CSV_TAIL)


_CSV_TAIL: tuple[str, ...] = (
    "axis",
    "point_mm",
    "u_lin_um",
    "u_mc_um",
    "ratio",
    "bias_mc_um",
    "ci95_lin_lo_um",
    "ci95_lin_hi_um",
    "ci95_mc_lo_um",
    "ci95_mc_hi_um",
    "u3_lin_um",
    "u3_mc_um",
    "r95_mc_um",
    "agree",
)
#: CSV columns of :func:`csv_text` for the paper's six joints, one row per pose and axis.
CSV_COLUMNS: tuple[str, ...] = csv_columns(JOINTS)


def csv_text(res: UncertaintyResult) -> str:
    """Every pose and axis as CSV text (:func:`csv_columns` of the arm's joints;
    :data:`CSV_COLUMNS` for the paper's; lengths in um, angles in deg)."""
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(csv_columns(res.spec.joints))
    um = 1e3
    for i, p in enumerate(res.poses):
        kind = "given" if i < res.n_given else "workspace"
        angles = [f"{math.degrees(t):.6f}" for t in p.theta_rad]
        for r, axis in enumerate(AXES):
            ratio = p.u_mc[r] / p.u_lin[r] if p.u_lin[r] > 0 else float("nan")
            w.writerow(
                [
                    i,
                    kind,
                    *angles,
                    axis,
                    f"{p.point_mm[r]:.6f}",
                    f"{p.u_lin[r] * um:.6g}",
                    f"{p.u_mc[r] * um:.6g}",
                    f"{ratio:.6g}",
                    f"{p.bias_mc[r] * um:.6g}",
                    f"{p.ci_lin[r, 0] * um:.6g}",
                    f"{p.ci_lin[r, 1] * um:.6g}",
                    f"{p.ci_mc[r, 0] * um:.6g}",
                    f"{p.ci_mc[r, 1] * um:.6g}",
                    f"{p.u3_lin * um:.6g}",
                    f"{p.u3_mc * um:.6g}",
                    f"{p.r95_mc * um:.6g}",
                    "yes" if p.valid else "no",
                ]
            )
    return buf.getvalue()


def figure(res: UncertaintyResult, top: int = 12) -> Any:
    """A matplotlib Figure of the result, built without pyplot.

    Left: u_mc against u_lin per pose and axis (um), with the line of
    agreement; middle: the distribution over the poses of the 3D standard
    uncertainty and of the 95 % radius (um); right: the ``top`` largest
    shares of the budget. Save it with :func:`aacmm.fileio.save_figure`.
    """
    from matplotlib.figure import Figure

    um = 1e3
    fig = Figure(figsize=(14, 4.6), layout="constrained")
    ax_agree, ax_dist, ax_budget = fig.subplots(1, 3)
    ul = np.array([p.u_lin for p in res.poses]) * um
    umc = np.array([p.u_mc for p in res.poses]) * um
    for r, axis in enumerate(AXES):
        ax_agree.plot(ul[:, r], umc[:, r], ".", markersize=4, label=f"{axis}")
    top_u = float(max(ul.max(), umc.max())) * 1.05
    ax_agree.plot([0, top_u], [0, top_u], "k-", linewidth=0.8, label="$u_{MC} = u_{lin}$")
    ax_agree.set_xlabel(r"$u_{lin}$ (linear, $J \Sigma J^T$), $\mu$m")
    ax_agree.set_ylabel(r"$u_{MC}$ (Monte Carlo, JCGM 101), $\mu$m")
    lo, hi = res.ratio_range()
    ax_agree.set_title(f"per pose and axis: $u_{{MC}}/u_{{lin}}$ in [{lo:.3f}, {hi:.3f}]")
    ax_agree.legend(fontsize=8)
    ax_agree.grid(alpha=0.3)
    u3 = np.array([p.u3_mc for p in res.poses]) * um
    r95 = np.array([p.r95_mc for p in res.poses]) * um
    bins = max(5, min(40, len(res.poses) // 3))
    ax_dist.hist(u3, bins=bins, alpha=0.7, label="3D standard uncertainty $u_3$")
    ax_dist.hist(r95, bins=bins, alpha=0.7, label="95 % radius $r_{95}$")
    ax_dist.set_xlabel(r"$\mu$m")
    ax_dist.set_ylabel("poses")
    ax_dist.set_title(f"over the {len(res.poses)} poses")
    ax_dist.legend(fontsize=8)
    entries = list(res.budget[:top])[::-1]
    ax_budget.barh([e.name for e in entries], [100 * e.share for e in entries])
    ax_budget.set_xlabel("share of the 3D variance (%)")
    g = res.group_shares
    tex = {"theta": r"$\theta$", "alpha": r"$\alpha$", "beta": r"$\beta$"}
    ax_budget.set_title(
        "budget: " + ", ".join(f"{tex.get(k, k)} {100 * v:.1f} %" for k, v in g.items()),
        fontsize=9,
    )
    ax_budget.grid(axis="x", alpha=0.3)
    arm = f"{res.spec.model}: " if res.spec.model is not None else ""
    fig.suptitle(
        f"{arm}Probe-point uncertainty, {res.trials} trials (seed {res.seed}), "
        f"{res.n_given} given + {len(res.poses) - res.n_given} workspace poses",
        fontsize=10,
    )
    return fig
