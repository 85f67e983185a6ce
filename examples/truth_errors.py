#!/usr/bin/env python3
"""What a random truth does to an uncalibrated arm: the figures of docs/simulator.md.

    .venv/bin/python examples/truth_errors.py [--seeds 1-10] [--plan kinematic-calibration]

For each seed, the simulated operator's choreography of the plan on the arm
``--truth random:SEED`` (aacmm.simulation: the same articulations, probing
noise, eccentricity and encoder noise as ``aacmm sim --scenario``), the true
encoders' counts, and the points the device's stored set (the nominal arm)
computes from them in double precision -- what ``aacmm capture`` records,
without the link. Prints per seed the seat dispersion (RMS and largest
distance of a seat's points from their centroid) and the ball-bar length
errors (RMS and largest |measured - calibrated|), then one JSON line with
the spread over the seeds. The operator's choices use the seed ``aacmm sim``
uses by default (``--seed 0``), so the articulations are those of
``aacmm sim --scenario PLAN --truth random:SEED``.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from aacmm.core import Model, Params
from aacmm.plans import load_plan
from aacmm.simulation.ik import Arm, solve
from aacmm.simulation.scenario import choreograph
from aacmm.simulation.truth import random_truth


def seeds_arg(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def measure(plan_name: str, seed: int, operator_seed: int = 0) -> dict[str, float]:
    plan = load_plan(plan_name)
    truth = random_truth(seed)
    arm = Arm(truth.params)
    rng = np.random.default_rng(operator_seed)  # as `aacmm sim --seed 0`
    choreo = choreograph(plan, arm, rng)
    thetas = []
    for p in choreo.points:
        probed = p.target_mm + truth.probing_offset_mm(rng)
        thetas.append(solve(arm, probed, p.theta, posture=p.theta).theta)
    counts = truth.counts(np.array(thetas), rng)
    points, _ = Model(Params()).points_from_counts(counts, truth.encoders)
    disp: list[float] = []
    bars: list[float] = []
    for step in plan.steps:
        rows = [i for i, p in enumerate(choreo.points) if p.slot.step_index == step.index]
        if step.procedure == "cone":
            q = points[rows]
            disp += list(np.linalg.norm(q - q.mean(axis=0), axis=1))
        elif step.procedure == "length":
            art = plan.artefacts[str(step.artefact)]
            length = float(getattr(art, "length_mm"))  # noqa: B009
            for a, b in zip(rows[0::2], rows[1::2], strict=True):
                bars.append(float(np.linalg.norm(points[b] - points[a])) - length)
    d, e = np.array(disp), np.abs(np.array(bars))
    return {
        "seed": seed,
        "cone_rms_mm": float(np.sqrt((d**2).mean())) if d.size else float("nan"),
        "cone_max_mm": float(d.max()) if d.size else float("nan"),
        "bar_rms_mm": float(np.sqrt((e**2).mean())) if e.size else float("nan"),
        "bar_max_mm": float(e.max()) if e.size else float("nan"),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=seeds_arg, default=seeds_arg("1-10"))
    ap.add_argument("--plan", default="kinematic-calibration")
    args = ap.parse_args()
    rows = [measure(args.plan, s) for s in args.seeds]
    print(f"{'seed':>4} {'cone rms':>9} {'cone max':>9} {'bar rms':>9} {'bar max':>9}  (mm)")
    for r in rows:
        print(
            f"{r['seed']:4d} {r['cone_rms_mm']:9.3f} {r['cone_max_mm']:9.3f} "
            f"{r['bar_rms_mm']:9.3f} {r['bar_max_mm']:9.3f}"
        )
    summary = {
        k: [round(min(r[k] for r in rows), 3), round(max(r[k] for r in rows), 3)]
        for k in ("cone_rms_mm", "cone_max_mm", "bar_rms_mm", "bar_max_mm")
    }
    print(json.dumps({"plan": args.plan, "seeds": args.seeds, "range": summary}))


if __name__ == "__main__":
    main()
