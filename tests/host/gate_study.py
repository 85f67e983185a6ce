"""Sessions of a simulated arm without the device, for the quality-gate tests (issue 24).

The arm is a :class:`aacmm.simulation.truth.Truth` (the simulator's: true
geometry, eccentric encoders, encoder noise, probing noise). For each slot of
a plan the probe tip is put on the slot's nominal target plus the truth's
probing noise by the *true* geometry (inverse kinematics of
tests/host/calib_synth.py, from a random articulation), and the encoders read
those angles as the simulator's do (``Truth.counts``: eccentricity and noise).
The device computes with the parameter set in force. So a session here is what
``aacmm sim --truth ... --scenario PLAN`` + ``aacmm capture`` record, at the
cost of a few milliseconds instead of seconds, with articulations from random
starts instead of the simulated operator's.

:func:`write_session` writes it as ``aacmm capture`` does (for the command);
:class:`Sampled` keeps it in memory (for the 20-arm study, which calls the
library the command calls: :func:`aacmm.calibration.gate.assess`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from aacmm.calibration.observations import Observations
from aacmm.calibration.sessions import observations_from_plan
from aacmm.core import EncoderConfig, Model, Params, counts_to_angles
from aacmm.plans import Plan
from aacmm.protocol import Sample
from aacmm.records import ParamSetRecord, SessionWriter
from aacmm.simulation.truth import Truth
from aacmm.verification.report import Report, evaluate
from calib_synth import random_poses, reach


def record(params: Params, encoders: EncoderConfig | None = None) -> ParamSetRecord:
    """A parameter set as the device reports it (its CRC)."""
    enc = encoders or EncoderConfig()
    return ParamSetRecord.from_device(ParamSetRecord(0, params, enc).to_device())


@dataclass(frozen=True)
class Sampled:
    """One session: the plan, the raw counts of its first ``n`` slots, the set in force."""

    plan: Plan
    counts: np.ndarray  # (n, 6) int64
    in_force: ParamSetRecord

    @property
    def n(self) -> int:
        return int(self.counts.shape[0])

    def angles(self) -> np.ndarray:
        return counts_to_angles(self.counts.astype(np.uint64), self.in_force.encoders)

    def points(self, params: Params | None = None) -> np.ndarray:
        """The probe points the device computes (with ``params``: another set)."""
        return Model(params or self.in_force.params).points(self.angles())

    def first(self, n: int) -> Sampled:
        """The session cut to its first ``n`` points."""
        return Sampled(self.plan, self.counts[:n], self.in_force)

    def observations(self, sigma_mm: float) -> Observations:
        obs, _, _ = observations_from_plan(
            self.plan, self.angles(), sigma_mm, labels=self.plan.slots[: self.n]
        )
        return obs

    def verify(self, params: Params | None = None) -> Report:
        """``aacmm verify`` of the session (with ``params``: as if that set were in force)."""
        return evaluate(self.plan, self.plan.slots[: self.n], self.points(params))


def sample(
    plan: Plan,
    truth: Truth,
    in_force: ParamSetRecord,
    rng: np.random.Generator,
    limit: int | None = None,
) -> Sampled:
    """The arm ``truth`` probing the plan's slots (the first ``limit``) with ``in_force``."""
    slots = plan.slots[:limit]
    targets = np.array([s.target.tip_mm for s in slots if s.target is not None], dtype=float)
    assert targets.shape[0] == len(slots), "every slot needs a nominal target"
    sigma = truth.errors.probing_sigma_um * 1e-3
    targets = targets + rng.normal(0.0, sigma, targets.shape)
    start = random_poses(rng, len(slots), (0.3, 1.4), (0.6, 1.8))
    q = reach(Model(truth.params), targets, start, rng, 0.5, tries=20)
    counts = truth.counts(q, rng)
    return Sampled(plan, np.asarray(counts, dtype=np.int64), in_force)


def write_session(
    folder: Path,
    s: Sampled,
    serial: int,
    status: str | None = None,
    firmware: str = "0.1.0",
    temp: tuple[int, ...] | None = None,
    **run_info: float,
) -> Path:
    """The session as ``aacmm capture`` writes it (device serial ``serial``); its status
    ``complete`` when every slot has its point, else ``interrupted``, unless given;
    ``temp``: every sample's link temperatures as the device sends them (0.01 degC);
    ``run_info``: more keys of its run (``temperature_c``, as ``capture --temperature``)."""
    w = SessionWriter.create(
        folder, s.plan, device={"serial_number": serial, "firmware": firmware}, port="sim"
    )
    w.begin_run("capture", serial_number=serial, param_crc32=s.in_force.crc_hex, **run_info)
    w.set_param_set(s.in_force)
    pts = s.points()
    for i in range(s.n):
        c = tuple(int(v) for v in s.counts[i])
        p = tuple(round(float(v) * 1e4) for v in pts[i])
        w.record(Sample(i, 1000 * i, c, p, 1, temp=temp), time.time())
    done = s.n == len(s.plan.slots)
    w.close(status or ("complete" if done else "interrupted"), "test")
    return folder


def figures(rep: Report) -> dict[str, float]:
    """The study's figures of a verification (mm): |E_Uni| and SPAT (max - min)/2."""
    return {
        "e_uni": abs(rep.result("e_uni").value_mm),
        "spat": rep.result("spat_range").value_mm,
    }


def rms(x: np.ndarray) -> float:
    return float(math.sqrt(np.mean(np.square(x))))


KIN_ARTEFACTS = """format = "aacmm-plan-1"
title = "{title}"

[probe]
ball_diameter_mm = 6.0

[artefacts.cone1]
type = "cone"
location_mm = [650.0, -350.0, -250.0]

[artefacts.cone2]
type = "cone"
location_mm = [900.0, 150.0, -100.0]

[artefacts.cone3]
type = "cone"
location_mm = [600.0, 400.0, 100.0]

[artefacts.bar500]
type = "ballbar"
length_mm = 500.0021
length_uncertainty_mm = 0.0010
ends = "cone"

[artefacts.bar1000]
type = "ballbar"
length_mm = 999.9968
length_uncertainty_mm = 0.0015
ends = "cone"
"""


def kinematic_plan(
    seats: int = 3, articulations: int = 25, bars: int = 2, positions: int = 10
) -> Plan:
    """A kinematic-calibration plan of ``seats`` cone seats x ``articulations`` and
    ``bars`` ball bars (500, 1000 mm) x ``positions``: the shipped plan's design, smaller."""
    from aacmm.plans import load_plan, loads_plan

    text = KIN_ARTEFACTS.format(title=f"{seats} x {articulations} seats, {bars} x {positions} bars")
    for k in range(seats):
        text += (
            f'\n[[steps]]\nid = "cone{k + 1}"\nprocedure = "cone"\nartefact = "cone{k + 1}"\n'
            f"articulations = {articulations}\n"
        )
    shipped = load_plan("kinematic-calibration")
    for name in ("bar500", "bar1000")[:bars]:
        pos = shipped.step(name).positions or ()
        rows = ", ".join(
            f"{{ centre_mm = {list(p.centre_mm)}, direction = {list(p.direction)} }}"
            for p in pos[:positions]
        )
        text += (
            f'\n[[steps]]\nid = "{name}"\nprocedure = "length"\nartefact = "{name}"\n'
            f"positions = [{rows}]\n"
        )
    return loads_plan(text, f"kin-{seats}x{articulations}-{bars}x{positions}")


# ------------------------------------------------------------------ the 20-arm study

SIGMA_MM = 0.005  # aacmm calibrate's default --sigma-um 5
STATES = ("uncalibrated", "calibrated")


@dataclass(frozen=True)
class Attempt:
    """One calibration of the study: the arm, the set in force, the data, the gate's
    verdict, and the next verification before and after (had it been written)."""

    seed: int
    state: str
    data: str
    written: bool
    refusals: tuple[str, ...]
    before: dict[str, float]
    after: dict[str, float]


@dataclass(frozen=True)
class Study:
    attempts: tuple[Attempt, ...]
    repeats: tuple[tuple[dict[str, float], dict[str, float]], ...]
    elapsed_s: float

    def tolerance(self) -> dict[str, float]:
        """The verification's own uncertainty of an after - before difference (k = 2):
        twice the RMS difference of two verifications of one arm with one parameter set
        (fresh sessions), pooled over the arms' calibrated states."""
        return {
            k: 2.0 * rms(np.array([b[k] - a[k] for a, b in self.repeats]))
            for k in ("e_uni", "spat")
        }

    def worse(self, a: Attempt) -> bool:
        tol = self.tolerance()
        return any(a.after[k] - a.before[k] > tol[k] for k in tol)

    def rows(self, state: str, data: str) -> list[Attempt]:
        return [a for a in self.attempts if a.state == state and a.data == data]


def data_sets(
    truth: Truth, in_force: ParamSetRecord, rng: np.random.Generator
) -> list[tuple[str, Sampled, str, bool]]:
    """(name, session, status, probe calibration) of the data each arm is calibrated from:
    the shipped plans, and sessions deliberately short of data."""
    from aacmm.plans import load_plan

    ver, kin, probe = (
        load_plan(n) for n in ("arm-verification", "kinematic-calibration", "probe-calibration")
    )
    v = sample(ver, truth, in_force, rng)
    return [
        ("kinematic-calibration", sample(kin, truth, in_force, rng), "complete", False),
        ("arm-verification", v, "complete", False),
        ("verification cut to 40", v.first(40), "complete", False),
        ("interrupted at 60", sample(kin, truth, in_force, rng, limit=60), "interrupted", False),
        ("one cone seat", sample(probe, truth, in_force, rng), "complete", False),
        (
            "seats only 3x25",
            sample(kinematic_plan(3, 25, 0), truth, in_force, rng),
            "complete",
            False,
        ),
        (
            "sparse 3x5 + 3 lengths",
            sample(kinematic_plan(3, 5, 1, 3), truth, in_force, rng),
            "complete",
            False,
        ),
        (
            "sparse 3x8 + 8 lengths",
            sample(kinematic_plan(3, 8, 2, 4), truth, in_force, rng),
            "complete",
            False,
        ),
        ("probe (--probe), one seat", sample(probe, truth, in_force, rng), "complete", True),
    ]


def run_study(seeds: range = range(1, 21)) -> Study:
    """Every random arm ``random_truth(seed)``, uncalibrated (Table 1 in force) and then
    calibrated (its own kinematic calibration in force): each data set calibrated,
    gated, and the next verification (a fresh arm-verification session) done with the
    set in force and with the calibrated set, written or not."""
    from aacmm.calibration import calibrate
    from aacmm.calibration.gate import SessionState, assess
    from aacmm.calibration.probe import calibrate_probe
    from aacmm.plans import load_plan
    from aacmm.simulation.truth import random_truth

    t0 = time.perf_counter()
    ver = load_plan("arm-verification")
    attempts: list[Attempt] = []
    repeats = []
    for seed in seeds:
        truth = random_truth(seed)
        rng = np.random.default_rng(1000 + seed)
        in_force = record(Params())
        for state in STATES:
            before = figures(sample(ver, truth, in_force, rng).verify())
            if state == "calibrated":
                repeats.append((before, figures(sample(ver, truth, in_force, rng).verify())))
            calibrated = None
            for name, s, status, probe in data_sets(truth, in_force, rng):
                obs = s.observations(SIGMA_MM)
                if probe:
                    res = calibrate_probe(obs, in_force.params).result
                else:
                    res = calibrate(obs, in_force.params)
                gate = assess(res, [SessionState(name, status, s.n, len(s.plan.slots))])
                after = figures(sample(ver, truth, record(res.params), rng).verify())
                refusals = tuple(r.check for r in gate.refusals)
                attempts.append(Attempt(seed, state, name, gate.passed, refusals, before, after))
                if name == "kinematic-calibration" and gate.passed:
                    calibrated = record(res.params)
            if calibrated is None:
                break  # the arm's own calibration refused: no calibrated state to study
            in_force = calibrated
    return Study(tuple(attempts), tuple(repeats), time.perf_counter() - t0)


def summary(study: Study) -> str:
    """The study's table (docs/calibration.md, "Quality gate")."""
    tol = study.tolerance()
    lines = [
        f"{len({a.seed for a in study.attempts})} arms, {len(study.attempts)} calibrations, "
        f"{study.elapsed_s:.0f} s; the verification's own uncertainty (k = 2, after - before): "
        f"E_Uni {tol['e_uni'] * 1e3:.1f} um, SPAT {tol['spat'] * 1e3:.1f} um",
        "| arm | data | written | worse | largest after - before, written (E_Uni, SPAT) | "
        "refused | had they been written: worse | E_Uni / SPAT before -> after, median "
        "(written; refused had they been written) | refused by |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    names = list(dict.fromkeys(a.data for a in study.attempts))
    for state in STATES:
        for name in names:
            rows = study.rows(state, name)
            if not rows:
                continue
            w = [a for a in rows if a.written]
            r = [a for a in rows if not a.written]

            def med(xs: list[Attempt]) -> str:
                if not xs:
                    return "-"
                out = []
                for k in ("e_uni", "spat"):
                    b = np.median([a.before[k] for a in xs]) * 1e3
                    af = np.median([a.after[k] for a in xs]) * 1e3
                    out.append(f"{b:.0f} -> {af:.0f}")
                return " / ".join(out) + " um"

            def largest(xs: list[Attempt]) -> str:
                if not xs:
                    return "-"
                return (
                    ", ".join(
                        f"{max(a.after[k] - a.before[k] for a in xs) * 1e3:+.1f}"
                        for k in ("e_uni", "spat")
                    )
                    + " um"
                )

            why: dict[str, int] = {}
            for a in r:
                for c in a.refusals:
                    why[c] = why.get(c, 0) + 1
            lines.append(
                f"| {state} | {name} | {len(w)} | {sum(study.worse(a) for a in w)} | "
                f"{largest(w)} | {len(r)} | {sum(study.worse(a) for a in r)} | "
                f"{med(w)}; {med(r)} | " + ", ".join(f"{k} {v}" for k, v in why.items()) + " |"
            )
    return "\n".join(lines)


if __name__ == "__main__":  # the figures of docs/calibration.md
    import os
    import sys

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    sys.stdout.write(summary(run_study()) + "\n")
