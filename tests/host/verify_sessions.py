"""Synthetic capture sessions for the verification tests, and an independent
recomputation of what ``aacmm verify`` reports.

A session is written with :class:`aacmm.records.SessionWriter` exactly as
``aacmm capture`` writes one: for each slot of a plan the probe-ball centre
is put on the slot's nominal target (plus noise) by the *true* arm (joint
angles by inverse kinematics, tests/host/calib_synth.py), and the raw counts
of those angles are recorded with the *stored* parameter set in force.

:func:`recompute` reads ``points.csv`` with the csv module, turns counts into
points with the numpy DH chain of tests/host/hostref.py and recomputes every
verification figure with methods of its own (scipy least squares for spheres,
SLSQP for the enclosing sphere), so the CLI's JSON can be checked against
something that shares no code with aacmm.geometry / aacmm.verification.
"""

from __future__ import annotations

import csv
import json
import math
import time
from pathlib import Path
from typing import Any

import hostref
import numpy as np
from aacmm.core import EncoderConfig, Model, Params, counts_to_angles
from aacmm.plans import Plan
from aacmm.protocol import ParamSet, Sample
from aacmm.records import ParamSetRecord, SessionWriter
from calib_synth import random_poses, reach
from scipy.optimize import least_squares, minimize

TWO32 = float(1 << 32)


def param_record(params: Params) -> ParamSetRecord:
    """The stored set (2^32 counts per revolution, no offsets) as the device reports it."""
    return ParamSetRecord.from_device(ParamSetRecord(0, params, EncoderConfig()).to_device())


def angles_to_counts(q: np.ndarray) -> np.ndarray:
    """Raw readings (n, 6) of joint angles (default encoder configuration)."""
    wrapped = np.mod(q, 2 * math.pi)
    out: np.ndarray = np.mod(np.rint(wrapped / (2 * math.pi) * TWO32), TWO32).astype(np.uint64)
    return out


def write_session(
    folder: Path,
    plan: Plan,
    rng: np.random.Generator,
    noise_mm: float = 0.0,
    stored: Params | None = None,
    truth: Params | None = None,
    upto: int | None = None,
    status: str = "complete",
) -> Path:
    """A session of ``plan`` (its first ``upto`` slots) on a true arm ``truth`` whose
    device computes with ``stored`` (both default: the paper's arm)."""
    stored = stored or Params()
    true_model = Model(truth or stored)
    slots = plan.slots[:upto]
    tips = np.array([s.target.tip_mm for s in slots if s.target is not None])
    if len(tips) != len(slots):
        raise ValueError("every slot needs a nominal target")
    tips = tips + rng.normal(0.0, noise_mm, tips.shape)
    start = random_poses(rng, len(tips), (0.3, 1.4), (0.6, 1.8))
    q = reach(true_model, tips, start, rng, 0.4, tries=20)
    counts = angles_to_counts(q)
    ps = param_record(stored)
    stored_model = Model(stored)
    w = SessionWriter.create(folder, plan, device={"serial_number": 4242, "firmware": "0.1.0"})
    w.begin_run("capture")
    w.set_param_set(ps)
    for i, c in enumerate(counts):
        p = stored_model.points(counts_to_angles(c[None], ps.encoders))[0]
        sample = Sample(i, 1000 * i, tuple(int(v) for v in c), tuple(round(v * 1e4) for v in p), 1)
        w.record(sample, time.time())
    w.close(status)
    return folder


# ---------------------------------------------------------------- independent recomputation


def session_points(folder: Path) -> tuple[list[dict[str, str]], np.ndarray]:
    """The rows of points.csv and their points from the raw counts (numpy DH chain)."""
    meta = json.loads((folder / "session.json").read_text())
    sets = {d["param_crc32_hex"]: d for d in meta["param_sets"]}
    with open(folder / "points.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    pts = []
    for r in rows:
        d = sets[r["param_crc32"]]
        ps = ParamSet(
            *(d["params"][k] for k in ("theta_offset_rad", "alpha_rad", "d_mm", "a_mm", "l_mm")),
            *(d["encoders"][k] for k in ("counts_per_rev", "zero_offset_counts", "direction")),
        )
        counts = [int(r[f"count{i}"]) for i in range(1, 7)]
        v = np.array([*ps.theta_offset_rad, *ps.alpha_rad, *ps.d_mm, *ps.a_mm, ps.l_mm])
        q = np.asarray(hostref.counts_to_angles(ps, counts), dtype=np.float64)
        pts.append(hostref.numpy_point(v, corrected(q, d.get("errmodel"))))
    return rows, np.array(pts)


def corrected(q: np.ndarray, errmodel: dict[str, Any] | None) -> np.ndarray:
    """Readings corrected by a set's encoder harmonics (its sidecar ``errmodel`` entry):
    q_j + sum_k c_jk cos(k q_j) + s_jk sin(k q_j), written out here (issue 27)."""
    if errmodel is None:
        return q
    out = q.copy()
    for j, (cs, ss) in enumerate(zip(errmodel["c_rad"], errmodel["s_rad"], strict=True)):
        for k, (c, s) in enumerate(zip(cs, ss, strict=True), start=1):
            out[j] += c * np.cos(k * q[j]) + s * np.sin(k * q[j])
    return out


def sphere_ls(p: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Centre, radius, residuals by scipy's least_squares on |p - c| - r (another solver)."""
    c0 = p.mean(axis=0)
    r0 = float(np.mean(np.linalg.norm(p - c0, axis=1)))
    # start off-centre along the mean normal: a cap's centroid lies inside the sphere
    sol = least_squares(
        lambda x: np.linalg.norm(p - x[:3], axis=1) - x[3],
        np.r_[c0, r0],
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
        method="lm",
    )
    return sol.x[:3], float(sol.x[3]), sol.fun


def enclosing_radius(p: np.ndarray) -> float:
    c0 = p.mean(axis=0)
    r0 = float(np.max(np.linalg.norm(p - c0, axis=1)))
    cons = {"type": "ineq", "fun": lambda x: x[3] ** 2 - np.sum((p - x[:3]) ** 2, axis=1)}
    res = minimize(
        lambda x: x[3],
        np.r_[c0, r0],
        constraints=[cons],
        method="SLSQP",
        options={"ftol": 1e-16, "maxiter": 1000},
    )
    return float(res.x[3])


def recompute(folder: Path, plan: Plan) -> dict[str, Any]:
    """Every figure ``aacmm verify`` reports, recomputed from the raw counts."""
    rows, pts = session_points(folder)
    ball_r = plan.probe.ball_diameter_mm / 2
    out: dict[str, Any] = {"spheres": {}, "l_dia": {}, "seats": {}, "lengths": {}}
    steps: dict[str, list[int]] = {}
    for i, row in enumerate(rows):
        steps.setdefault(row["step_id"], []).append(i)
    for st in plan.steps:
        idx = steps.get(st.id, [])
        if not idx:
            continue
        art = plan.artefacts[st.artefact] if st.artefact else None
        p = pts[idx]
        if st.procedure == "sphere":
            _, radius, res = sphere_ls(p)
            out["spheres"][st.id] = {
                "size_error": 2 * (radius - ball_r) - art.diameter_mm,  # type: ignore[union-attr]
                "form": float(np.ptp(res)),
            }
        elif st.procedure == "articulation" and art is not None and art.type == "sphere":
            groups: dict[str, list[int]] = {}
            for k in idx:
                groups.setdefault(rows[k]["articulation_index"], []).append(k)
            centres = np.array([sphere_ls(pts[g])[0] for g in groups.values()])
            out["l_dia"][st.id] = 2 * enclosing_radius(centres)
        elif st.procedure in ("cone", "articulation"):
            dev = np.linalg.norm(p - p.mean(axis=0), axis=1)
            out["seats"][st.id] = {
                "two_sigma": 2 * math.sqrt(float(np.sum(dev**2)) / (len(p) - 1)),
                "half_range": (np.max(p, axis=0) - np.min(p, axis=0)) / 2,
            }
        elif st.procedure == "length":
            ends: dict[tuple[str, str], list[int]] = {}
            for k in idx:
                ends.setdefault((rows[k]["position_index"], rows[k]["end"]), []).append(k)
            errs = []
            for pos in sorted({k[0] for k in ends}, key=int):
                a, b = (pts[ends[(pos, e)]] for e in ("A", "B"))
                ca = a.mean(axis=0) if len(a) < 4 else sphere_ls(a)[0]
                cb = b.mean(axis=0) if len(b) < 4 else sphere_ls(b)[0]
                errs.append(float(np.linalg.norm(cb - ca)) - art.length_mm)  # type: ignore[union-attr]
            out["lengths"][st.id] = errs
    return out


def worst_length_error(rep: dict[str, Any]) -> float:
    """The E_Uni a report must show: the error with the largest |E| / MPE_E(L) among the
    lengths of its steps (each with the MPE the plan gives at that length)."""
    pos = [p for st in rep["steps"].values() if st["kind"] == "length" for p in st["positions"]]
    best = max(pos, key=lambda p: abs(p["error_mm"]) / (p["mpe_mm"] or 1.0))
    return float(best["error_mm"])
