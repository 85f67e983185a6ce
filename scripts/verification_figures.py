"""Regenerate the figures of docs/verification.md (``make verification-figures``).

- bias: radius errors of the geometric and the algebraic (Kasa) sphere fits
  over 1,000 seeded 60-degree caps (25 points, 25.4 mm sphere) with 5 um and
  50 um isotropic noise, the data of tests/host/test_geometry.py;
- sessions: the simulated arm ``random:21`` on the shipped ISO 10360-12 plan
  plus two seats (tests/host/test_verify_sim.py), verified before and after
  ``aacmm calibrate`` on a kinematic-calibration session; the figures of both
  reports and the one-page report of the calibrated arm (pdftoppm). Prints
  both result tables (about a minute).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from aacmm.geometry import fit_spheres, kasa_spheres
from matplotlib.figure import Figure

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests" / "host"))

from test_geometry import CAP_RADIUS, CAPS, _noisy_caps  # noqa: E402


def bias_figure(out: Path) -> None:
    fig = Figure(figsize=(9.0, 3.6), layout="constrained")
    axes = fig.subplots(1, 2)
    for ax, (sigma, seed) in zip(axes, [(0.005, 11), (0.050, 12)], strict=True):
        pts = _noisy_caps(seed, sigma)
        geo = (fit_spheres(pts).radii - CAP_RADIUS) * 1000.0
        alg = (kasa_spheres(pts)[1] - CAP_RADIUS) * 1000.0
        bins = np.linspace(min(geo.min(), alg.min()), max(geo.max(), alg.max()), 50)
        for data, name, color in ((geo, "geometric", "tab:blue"), (alg, "algebraic", "tab:red")):
            se = data.std(ddof=1) / np.sqrt(CAPS)
            ax.hist(
                data,
                bins=bins,
                alpha=0.5,
                color=color,
                label=f"{name}: mean {data.mean():+.1f} um = {data.mean() / se:+.1f} SE",
            )
            ax.axvline(data.mean(), color=color, lw=1.5)
        ax.axvline(0.0, color="k", lw=0.8)
        ax.set_xlabel("fitted radius - true radius (um)")
        ax.set_title(f"{CAPS} caps, 60 deg, 25 points, noise {sigma * 1000:g} um", fontsize=9)
        ax.legend(fontsize=7)
    fig.savefig(out, dpi=100)


def session_figures(out: Path) -> None:
    import shutil
    import subprocess
    import tempfile

    import test_verify_sim as t
    from aacmm.plans import shipped_plan_path
    from clihelp import run

    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        plan = base / "verify-sim.toml"
        text = shipped_plan_path("iso10360-12").read_text()
        plan.write_text(text.replace("[mpe]\n", "[mpe]\n" + t.MPE_EXTRA) + t.SEATS)
        before, _, _ = t.capture(base / "before", plan, "random:21")
        kin, _, _ = t.capture(base / "kin", "kinematic-calibration", "random:21")
        cal = base / "cal.toml"
        assert run("calibrate", str(kin), "-o", str(cal), "-q").returncode == 0
        after, _, _ = t.capture(base / "after", plan, "random:21", params=cal)
        for name, session in (("before", before), ("after", after)):
            rep = base / f"report-{name}"
            p = run("verify", str(session), "--report", str(rep))
            print(f"--- {name} calibration (exit {p.returncode})\n{p.stdout}")
            for fig in ("e_uni", "spat", "spheres"):
                shutil.copy(rep / f"{fig}.png", out / f"verification-{fig}-{name}.png")
        subprocess.run(
            [
                "pdftoppm",
                "-r",
                "60",
                "-png",
                "-singlefile",
                str(base / "report-after" / "report.pdf"),
                str(out / "verification-report"),
            ],
            check=True,
        )


def main() -> int:
    out = ROOT / "docs" / "figures"
    out.mkdir(exist_ok=True)
    bias_figure(out / "verification-bias.png")
    session_figures(out)
    print(f"figures written to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
