"""Figures of a calibration (matplotlib ``Figure`` objects; the caller saves them).

No pyplot and no global state: each function builds a
:class:`matplotlib.figure.Figure`, which ``aacmm.fileio.save_figure`` writes.

* :func:`residual_figures` -- per plan step, each point's residual before and
  after (outliers marked);
* :func:`spectrum_figure` -- the singular values against the rank tolerance;
* :func:`correlation_figure` -- the correlation matrix of the free parameters;
* :func:`convergence_figure` -- chi^2 at every solver evaluation;
* :func:`uncertainty_figure` -- the propagated probe-point uncertainty over
  the workspace.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aacmm.calibration.identifiability import Identifiability
from aacmm.calibration.parameters import param_names
from aacmm.calibration.report import unit_residuals
from aacmm.calibration.results import CalibrationResult
from aacmm.uncertainty.report import UncertaintyResult


def _figure(w: float, h: float) -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=(w, h), layout="constrained")


def residual_figures(res: CalibrationResult) -> dict[int, Any]:
    """One figure per plan step with data: residual per point, before and after (um)."""
    pr = res.problem
    before = unit_residuals(pr, res.before)
    after = unit_residuals(pr, res.after)
    flagged = {p for o in res.outliers for p in o.poses}
    obs = pr.obs
    figs: dict[int, Any] = {}
    for step in np.unique(after.step):
        sel = np.flatnonzero(after.step == step)
        name = obs.step_names[step] if 0 <= step < len(obs.step_names) else ""
        kinds = sorted({str(k) for k in after.kind[sel]})
        signed = np.all(np.isfinite(after.signed_mm[sel]))
        yb = before.signed_mm[sel] if signed else before.size_mm[sel]
        ya = after.signed_mm[sel] if signed else after.size_mm[sel]
        x = np.arange(sel.size)
        fig = _figure(8, 3.6)
        ax = fig.add_subplot(2, 1, 1)
        ax.plot(x, yb * 1e3, "o", color="0.6", ms=3, label="before (start parameters)")
        ax.set_ylabel("um")
        ax.legend(fontsize=8, loc="upper right")
        ax.grid(alpha=0.3)
        ax2 = fig.add_subplot(2, 1, 2, sharex=ax)
        ax2.plot(x, ya * 1e3, "o", color="tab:blue", ms=3, label="after (calibrated)")
        bad = [i for i, u in enumerate(sel) if int(pr.unit_pose[u]) in flagged]
        if bad:
            ax2.plot(x[bad], ya[bad] * 1e3, "o", mfc="none", mec="red", ms=9, label="outlier")
        ax2.axhline(0.0, color="k", lw=0.5)
        ax2.set_ylabel("um")
        ax2.set_xlabel("length position" if kinds == ["length"] else "point (in the step's order)")
        ax2.legend(fontsize=8, loc="upper right")
        ax2.grid(alpha=0.3)
        what = (
            "length error"
            if signed and kinds == ["length"]
            else ("signed residual" if signed else "distance from the fitted feature")
        )
        label = f"step {step + 1} {name}" if name else f"step {step + 1}"
        fig.suptitle(f"{label} ({', '.join(kinds)}): {what}", fontsize=10)
        figs[int(step)] = fig
    return figs


def spectrum_figure(idn: Identifiability) -> Any:
    """Singular values (log) with the rank tolerance; unobservable ones in red."""
    fig = _figure(8, 3.6)
    ax = fig.add_subplot()
    s = np.maximum(idn.singular_values, 1e-18)
    x = np.arange(1, s.size + 1)
    colors = ["tab:blue" if i < idn.rank else "tab:red" for i in range(s.size)]
    ax.bar(x, s, color=colors)
    ax.set_yscale("log")
    ax.axhline(idn.tolerance, color="k", ls="--", lw=1, label=f"tolerance {idn.tolerance:.1e}")
    ax.set_xlabel("singular value index")
    ax.set_ylabel("column-scaled singular value")
    kinds = ", ".join(d.kind for d in idn.null) or "none"
    ax.set_title(f"rank {idn.rank} of {idn.n}; unobservable: {kinds}", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    return fig


def correlation_figure(res: CalibrationResult) -> Any:
    """The correlation matrix of the estimated parameters."""
    names = param_names(res.params)
    free = [names.index(n) for n in res.free]
    c = res.correlation[np.ix_(free, free)]
    fig = _figure(7, 6)
    ax = fig.add_subplot()
    im = ax.imshow(c, vmin=-1, vmax=1, cmap="coolwarm")
    ax.set_xticks(range(len(free)), [names[k] for k in free], rotation=90, fontsize=7)
    ax.set_yticks(range(len(free)), [names[k] for k in free], fontsize=7)
    fig.colorbar(im, ax=ax, shrink=0.8, label="correlation")
    ax.set_title("correlations of the calibrated parameters", fontsize=10)
    return fig


def convergence_figure(res: CalibrationResult) -> Any:
    """chi^2 at every residual evaluation of the solver, by stage."""
    fig = _figure(7, 3.2)
    ax = fig.add_subplot()
    chi = np.array([p.chi2 for p in res.history])
    stage = np.array([p.stage for p in res.history])
    for s in np.unique(stage):
        i = np.flatnonzero(stage == s)
        ax.semilogy(i + 1, np.maximum(chi[i], 1e-30), "o-", ms=3, label=f"stage {s}")
    dof = res.chi_square.dof
    if dof > 0:
        ax.axhline(dof, color="k", ls="--", lw=1, label=f"dof = {dof}")
    ax.set_xlabel("evaluation")
    ax.set_ylabel("chi^2")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def uncertainty_figure(ures: UncertaintyResult) -> Any:
    """3D standard uncertainty of the probe point (calibration only) against reach."""
    fig = _figure(7, 3.6)
    ax = fig.add_subplot()
    ws = ures.workspace or ures.poses
    reach = np.array([np.linalg.norm(p.point_mm) for p in ws])
    ax.plot(reach, [p.u3_lin * 1e3 for p in ws], "o", ms=3, label="linear J Sigma J^T")
    ax.plot(reach, [p.u3_mc * 1e3 for p in ws], "x", ms=4, label="Monte Carlo")
    ax.set_xlabel("distance of the tip from the base origin (mm)")
    ax.set_ylabel("u (um, k = 1)")
    ax.set_title("probe-point uncertainty from the calibrated parameters", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig
