"""The 200-truth harmonics study of docs/calibration.md (``make harmonics-study-figures``).

The study of tests/host/harmonics_study.py (the data of
tests/host/test_calibration_harmonics_study.py, same seeds): 200 random
one-head truths on the shipped kinematic-calibration plan, each calibrated
with ``harmonics=2`` and as the arm alone, and its ideal-encoder twin likewise;
every calibration judged as ``aacmm demo --check`` judges an arm. Writes
docs/figures/harmonics-study.png and docs/figures/harmonics-study.json (the
distributions over runs, the verdicts, the 3-sigma rates, every run's RMS
length errors, run 0's precision budget: the predicted RMS with each
joint's harmonics known; and the precision cost of the shipped plan against
two nine-seat designs, the same 200 runs on the first of them, and 50 runs
with the simulator's encoder noise too) and prints the summary (about 50 s).
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from aacmm.plans import load_plan
from matplotlib.figure import Figure

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests" / "host"))

from harmonics_study import PLAN, Study, precision_budget, spread_plan, study, summary  # noqa: E402

RUNS = 200
LABELS = {
    "full": "one-head encoders, harmonics=2 (full model)",
    "dh": "one-head encoders, arm alone (DH only)",
    "base": "ideal encoders, harmonics=2",
    "base_dh": "ideal encoders, arm alone",
}
COLOURS = {"full": "tab:green", "dh": "tab:red", "base": "tab:blue", "base_dh": "tab:gray"}


def figure(st: Study, out: Path) -> None:
    fig = Figure(figsize=(10.0, 4.2), layout="constrained")
    left, right = fig.subplots(1, 2)
    order = np.argsort(st.rms("base"))
    x = np.arange(1, len(order) + 1)
    for name in ("dh", "full", "base", "base_dh"):
        marker = "." if name != "base" else "_"
        y = 1e3 * st.rms(name)[order]
        left.plot(x, y, marker, color=COLOURS[name], label=LABELS[name], ms=5)
    left.set_yscale("log")
    left.set_xlabel("run (sorted by the ideal twin's harmonics=2 RMS)")
    left.set_ylabel("RMS length error over the reach (um)")
    left.set_title(f"{len(order)} one-head truths, kinematic-calibration plan", fontsize=9)
    left.legend(fontsize=7, loc="center left")
    for a, b, colour, label in (
        ("full", "base", "tab:green", "full model / same calibration, ideal twin"),
        ("full", "base_dh", "tab:olive", "full model / arm alone, ideal twin"),
        ("dh", "base", "tab:red", "DH only / full model, ideal twin"),
    ):
        r = np.sort(st.ratio(a, b))
        right.step(r, np.arange(1, r.size + 1) / r.size, where="post", color=colour, label=label)
    right.axvline(1.5, color="black", ls="--", lw=1, label="1.5x")
    right.axvline(5.0, color="black", ls=":", lw=1, label="5x")
    right.set_xscale("log")
    right.set_xlabel("ratio of RMS length errors, per run (log)")
    right.set_ylabel("fraction of runs")
    right.set_title("per-run ratios (cumulative)", fontsize=9)
    right.legend(fontsize=7, loc="lower right")
    fig.savefig(out, dpi=100)


def designs() -> list[dict[str, object]]:
    """The precision cost (predicted RMS of the full model over the arm alone's) of
    the shipped plan and of two nine-seat designs, runs 0 and 1 (operator seeds 1, 2)."""
    out: list[dict[str, object]] = []
    for name, plan in (
        (PLAN, load_plan(PLAN)),
        ("9 seats x 9 articulations + the same bars", spread_plan(9)),
        ("9 seats x 18 articulations + the same bars", spread_plan(18)),
    ):
        for seed in (0, 1):
            b = precision_budget(seed, plan, seed + 1)
            out.append(
                {
                    "design": name,
                    "points": len(plan.slots),
                    "seed": seed,
                    "full_um": b["all"],
                    "arm_alone_um": b["arm alone"],
                    "cost": b["all"] / b["arm alone"],
                    "joint_4_known_um": b["joint 4 known"],
                    "observability_joint_4": [
                        b[f"observability {w}4_{k}"] for k in (1, 2) for w in "cs"
                    ],
                }
            )
    return out


def main() -> None:
    t0 = time.perf_counter()
    st = study(RUNS)
    seconds = time.perf_counter() - t0
    figures = ROOT / "docs" / "figures"
    figure(st, figures / "harmonics-study.png")
    s = summary(st)
    s["command"] = (
        "make harmonics-study-figures  (.venv/bin/python scripts/harmonics_study_figures.py)"
    )
    s["seconds"] = seconds
    s["precision_budget_seed_0_um"] = precision_budget(0)
    s["designs"] = designs()
    nine = summary(study(RUNS, plan=spread_plan(9)))
    nine.pop("per_run")
    s["nine_seats_x_9_study"] = {k: v for k, v in nine.items() if k != "within_3_sigma"}
    noisy = summary(study(50, encoder_noise=True))
    s["with_encoder_noise_50_runs"] = {
        k: noisy[k] for k in ("rms_um", "full_over_base", "dh_over_base", "verdicts", "chi2_ratio")
    }
    runs = s.pop("per_run")
    assert isinstance(runs, list)
    text = json.dumps(s, indent=1)[:-2]  # every run on one line of its own
    lines = ",\n  ".join(json.dumps(r) for r in runs)
    text += f',\n "per_run": [\n  {lines}\n ]\n}}\n'
    json.loads(text)
    (figures / "harmonics-study.json").write_text(text)
    print(json.dumps(s, indent=1))
    print("(wrote docs/figures/harmonics-study.png, docs/figures/harmonics-study.json)")


if __name__ == "__main__":
    main()
