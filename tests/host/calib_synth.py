"""Synthetic calibration data for the tests: a known truth arm, exact joint angles.

Independent of :mod:`aacmm.calibration`: the joint angles that put the true
arm's tip on a target point are found here by damped Newton steps on the joint
columns of the core's Jacobian (dp/dq_i = dp/dtheta_i, the theta offset adds to
the reading), vectorised over all poses. Probing noise displaces the target
before the inverse kinematics, so the angles are exact for the noisy tip.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from aacmm.core import Model, Params

FloatArray = np.ndarray


def perturbed_truth(rng: np.random.Generator, mm: float = 0.5, deg: float = 0.05) -> Params:
    """The paper's arm with every parameter off by a uniform draw in +-mm / +-deg."""
    v = Params().to_vector()
    d = np.empty(25)
    d[:12] = rng.uniform(-math.radians(deg), math.radians(deg), 12)
    d[12:] = rng.uniform(-mm, mm, 13)
    return Params.from_vector(v + d)


def solve_ik(
    model: Model, targets: FloatArray, q0: FloatArray, iters: int = 60
) -> tuple[FloatArray, FloatArray]:
    """Joint angles (n, 6) reaching ``targets`` (n, 3) from ``q0``; and the final error (n,)."""
    q = np.array(q0, dtype=np.float64, copy=True)
    mu = 1e2
    for it in range(iters):
        p, j = model.points_jacobians(q)
        err = targets - p
        jq = j[:, :, :6]
        a = jq @ jq.transpose(0, 2, 1)
        damp = mu if it < iters // 2 else 0.0
        a = a + damp * np.eye(3)
        step = np.einsum("nai,na->ni", jq, np.linalg.solve(a, err[..., None])[..., 0])
        # bound the step so far starts do not jump across the workspace
        norm = np.linalg.norm(step, axis=1, keepdims=True)
        q += step * np.minimum(1.0, 0.5 / np.maximum(norm, 1e-300))
        mu *= 0.5
    p = model.points(q)
    return q, np.linalg.norm(targets - p, axis=1)


def reach(
    model: Model,
    targets: FloatArray,
    q_start: FloatArray,
    rng: np.random.Generator,
    spread_rad: float,
    tries: int = 8,
) -> FloatArray:
    """Angles (n, 6) putting the tip exactly on each target, each from a random start.

    Starts are ``q_start`` (n, 6) plus normal noise of ``spread_rad``; poses
    that do not converge to 1e-11 mm are retried from fresh starts.
    """
    n = targets.shape[0]
    out = np.full((n, 6), np.nan)
    todo = np.arange(n)
    for _ in range(tries):
        q0 = q_start[todo] + rng.normal(0.0, spread_rad, (todo.size, 6))
        q, err = solve_ik(model, targets[todo], q0)
        ok = err < 1e-11
        out[todo[ok]] = q[ok]
        todo = todo[~ok]
        if todo.size == 0:
            return out
    raise RuntimeError(f"inverse kinematics failed for {todo.size} targets")


@dataclass
class Synthetic:
    """Cone articulations and ball-bar positions measured on one truth arm."""

    truth: Params
    cone_q: list[FloatArray]  # per cone: (k, 6) joint readings
    cone_centres: FloatArray  # (n_cones, 3), true centres
    length_qa: FloatArray  # (n_len, 6)
    length_qb: FloatArray
    lengths_mm: FloatArray  # (n_len,) calibrated lengths


def random_poses(
    rng: np.random.Generator, n: int, j2: tuple[float, float], j4: tuple[float, float]
) -> FloatArray:
    """``n`` poses with joints 2 and 4 in the given ranges (rad), the others all around."""
    q = rng.uniform(-math.pi, math.pi, (n, 6))
    q[:, 1] = rng.uniform(*j2, n)
    q[:, 3] = rng.uniform(*j4, n)
    return q


def cone_poses(
    model: Model,
    rng: np.random.Generator,
    n_cones: int,
    per_cone: int,
    noise_mm: float = 0.0,
) -> tuple[list[FloatArray], FloatArray]:
    """Articulations of the true arm in ``n_cones`` seats, tip displaced by noise."""
    seeds = random_poses(rng, n_cones, (0.3, 1.4), (0.6, 1.8))
    centres = model.points(seeds)
    targets = np.repeat(centres, per_cone, axis=0)
    targets = targets + rng.normal(0.0, noise_mm, targets.shape)
    start = np.repeat(seeds, per_cone, axis=0)
    start[:, 3:] = rng.uniform(-math.pi, math.pi, (start.shape[0], 3))  # wrist all around
    q = reach(model, targets, start, rng, 0.4)
    qs = list(q.reshape(n_cones, per_cone, 6))
    return qs, centres


def bar_poses(
    model: Model,
    rng: np.random.Generator,
    n: int,
    lo_mm: float = 500.0,
    hi_mm: float = 1000.0,
    noise_mm: float = 0.0,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``n`` ball-bar positions: joint readings at ends A and B and the bar lengths."""
    qa_list: list[FloatArray] = []
    qb_list: list[FloatArray] = []
    lens: list[FloatArray] = []
    while sum(x.size for x in lens) < n:
        m = 2 * n
        qa = random_poses(rng, m, (0.2, 1.5), (0.5, 1.9))
        a = model.points(qa)
        u = rng.normal(size=(m, 3))
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        length = rng.uniform(lo_mm, hi_mm, m)
        b = a + length[:, None] * u
        ta = a + rng.normal(0.0, noise_mm, (m, 3))
        tb = b + rng.normal(0.0, noise_mm, (m, 3))
        qa_n, ea = solve_ik(model, ta, qa)
        qb_n, eb = solve_ik(model, tb, qa + rng.normal(0.0, 0.3, (m, 6)))
        ok = (ea < 1e-11) & (eb < 1e-11)
        qa_list.append(qa_n[ok])
        qb_list.append(qb_n[ok])
        lens.append(length[ok])
    return (
        np.concatenate(qa_list)[:n],
        np.concatenate(qb_list)[:n],
        np.concatenate(lens)[:n],
    )


def synthetic(
    seed: int,
    n_cones: int = 3,
    per_cone: int = 25,
    n_lengths: int = 30,
    noise_mm: float = 0.0,
    truth: Params | None = None,
) -> Synthetic:
    """A seeded data set on a perturbed truth (or the given one)."""
    rng = np.random.default_rng(seed)
    t = truth or perturbed_truth(rng)
    model = Model(t)
    qs, centres = cone_poses(model, rng, n_cones, per_cone, noise_mm)
    qa, qb, lens = (
        bar_poses(model, rng, n_lengths, noise_mm=noise_mm)
        if n_lengths
        else (
            np.empty((0, 6)),
            np.empty((0, 6)),
            np.empty(0),
        )
    )
    return Synthetic(t, qs, centres, qa, qb, lens)


def ball_bar_poses(
    model: Model,
    rng: np.random.Generator,
    n: int,
    length_mm: float,
    radius_mm: float,
    per_end: int = 5,
    noise_mm: float = 0.0,
) -> tuple[list[FloatArray], list[FloatArray]]:
    """``n`` positions of a bar with balls at its ends: per end, ``per_end`` tip centres on
    the ball (radius ``radius_mm`` = ball + probe radius) around the bar's outward axis."""
    qa, qb, _ = bar_poses(model, rng, n, length_mm, length_mm)
    a, b = model.points(qa), model.points(qb)
    u = (b - a) / length_mm
    ends_a: list[FloatArray] = []
    ends_b: list[FloatArray] = []
    for k in range(n):
        for sign, centre, q, out in ((-1.0, a[k], qa[k], ends_a), (1.0, b[k], qb[k], ends_b)):
            axis = sign * u[k]  # pointing out of the bar
            # the plans' pattern: one point on the axis, the others on a ring 60 deg from it
            t1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
            t1 /= np.linalg.norm(t1)
            t2 = np.cross(axis, t1)
            az = 2 * math.pi * np.arange(per_end - 1) / (per_end - 1)
            ring = np.cos(math.pi / 3) * axis + np.sin(math.pi / 3) * (
                np.cos(az)[:, None] * t1 + np.sin(az)[:, None] * t2
            )
            d = np.vstack([axis, ring])
            targets = centre + radius_mm * d + rng.normal(0.0, noise_mm, (per_end, 3))
            out.append(reach(model, targets, np.tile(q, (per_end, 1)), rng, 0.1))
    return ends_a, ends_b


def plan_session(
    folder: object,
    plan_name: str,
    truth: Params,
    seed: int,
    noise_mm: float = 0.0,
    in_force: object = None,
    limit: int | None = None,
    readings: object = None,
) -> None:
    """A capture session of a shipped plan, measured by the arm ``truth``.

    Every slot's nominal target (plus probing noise) is reached by inverse
    kinematics on the truth from a random articulation; the counts are the
    exact angles rounded to 2^32 counts per revolution. The device computed
    its points with ``in_force`` (a ParamSetRecord; default Table 1).
    ``limit``: record only the first points (an interrupted session).
    ``readings``: a function of the exact angles (n, 6) giving the encoders'
    readings (an encoder angle error; default: the angles themselves).
    """
    from pathlib import Path

    from aacmm.core import EncoderConfig
    from aacmm.plans import load_plan
    from aacmm.protocol import Sample
    from aacmm.records import ParamSetRecord, SessionWriter

    plan = load_plan(plan_name)
    rng = np.random.default_rng(seed)
    ps = in_force or ParamSetRecord.from_device(
        ParamSetRecord(0, Params(), EncoderConfig()).to_device()
    )
    assert isinstance(ps, ParamSetRecord)
    slots = plan.slots[:limit] if limit is not None else plan.slots
    targets = np.array([s.target.tip_mm for s in slots if s.target is not None], dtype=float)
    assert targets.shape[0] == len(slots), "every slot needs a nominal target"
    targets = targets + rng.normal(0.0, noise_mm, targets.shape)
    model = Model(truth)
    start = random_poses(rng, len(slots), (0.3, 1.4), (0.6, 1.8))
    q = reach(model, targets, start, rng, 0.5, tries=20)
    if callable(readings):
        q = readings(q)
    two32 = float(1 << 32)
    counts = np.mod(np.rint(q / (2 * math.pi) * two32), two32).astype(np.uint64)
    w = SessionWriter.create(Path(str(folder)), plan, device={"serial_number": 1}, port="sim")
    w.begin_run("capture")
    w.set_param_set(ps)
    dev = Model(ps.params)
    from aacmm.core import counts_to_angles

    pts = dev.points(counts_to_angles(counts, ps.encoders))
    for i in range(len(slots)):
        c = tuple(int(v) for v in counts[i])
        w.record(Sample(i, 1000 * i, c, tuple(round(float(v) * 1e4) for v in pts[i]), 1), 0.0)
    w.close("complete" if limit is None else "interrupted", "test")
