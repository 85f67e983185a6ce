"""What a page shows, as JSON-ready data: the scene (format ``aacmm-view-1``).

One structure for every source, so the page has one renderer:

* ``points``: every probed point (``xyz`` mm, ``step``, ``label``, ``residual_mm``
  to its step's fitted feature, :mod:`aacmm.view.features`);
* ``steps``: each step's feature and residual statistics;
* ``trail``: a path of tip positions (a log's samples);
* ``arm``: one posture to draw (the last point's), links and joints;
* ``verification``: per test value, MPE, limit and verdict (PASS/FAIL);
* ``calibration``: residuals per step before and after, the before/after table;
* ``notes``: what could not be shown and why.

Builders: :func:`session_scene` (a capture session, verified when its plan
has MPEs), :func:`points_scene` (plan, labels, points), :func:`log_scene`,
:func:`verification_part`, :func:`calibration_scene`. Pure: files are read
through :mod:`aacmm.records`, nothing is written.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aacmm.view.arm import ArmPose, FloatArray, arm_pose
from aacmm.view.features import Labelled, point_residuals, step_features

FORMAT = "aacmm-view-1"
#: At most this many samples of a log go into its trail (evenly decimated).
LOG_TRAIL_MAX = 20000


def _xyz(a: Any) -> list[float]:
    # round() of Python floats (tolist) is several times faster than of numpy scalars
    return [round(x, 5) for x in np.asarray(a, dtype=np.float64).reshape(-1).tolist()]


def _rows(a: FloatArray) -> list[list[float]]:
    return [[round(x, 5) for x in row] for row in a.tolist()]


def arm_dict(pose: ArmPose) -> dict[str, Any]:
    """An :class:`ArmPose` as the page draws it."""
    return {
        "path": _rows(pose.path_mm),
        "joints": _rows(pose.joints_mm),
        "axes": _rows(pose.axes),
        "tip": _xyz(pose.tip_mm),
    }


def empty_scene(kind: str, title: str, subtitle: str = "") -> dict[str, Any]:
    return {
        "format": FORMAT,
        "kind": kind,
        "title": title,
        "subtitle": subtitle,
        "points": [],
        "steps": [],
        "trail": [],
        "arm": None,
        "verification": None,
        "calibration": None,
        "notes": [],
    }


def points_scene(
    plan: Any,
    labels: Sequence[Labelled],
    points_mm: npt.ArrayLike,
    title: str,
    kind: str = "session",
    subtitle: str = "",
) -> dict[str, Any]:
    """Points of a plan's steps with their fitted features and residuals."""
    p = np.asarray(points_mm, dtype=np.float64).reshape(-1, 3)
    feats = step_features(plan, labels, p)
    res = point_residuals(feats, len(p))
    scene = empty_scene(kind, title, subtitle)
    slots = plan.slots
    for i, lab in enumerate(labels):
        slot = getattr(lab, "slot", None)
        text = slots[slot].text if isinstance(slot, int) and 0 <= slot < len(slots) else ""
        scene["points"].append(
            {
                "i": i,
                "slot": slot,
                "step": plan.steps[lab.step_index].id,
                "label": text,
                "xyz": _xyz(p[i]),
                "residual_mm": None if res[i] is None else float(res[i]),  # type: ignore[arg-type]
            }
        )
    scene["steps"] = [f.to_dict() for f in feats]
    for f in feats:
        if f.note:
            scene["notes"].append(f"step {f.step_id}: {f.note}")
    return scene


def verification_part(rep: Any) -> dict[str, Any]:
    """The results of an :class:`aacmm.verification.report.Report`: per test vs MPE."""
    return {
        "verdict": rep.verdict,
        "decision_rule": rep.decision_rule,
        "results": [
            {
                "key": r.key,
                "name": r.name,
                "value_mm": r.value_mm,
                "mpe_mm": r.decision.mpe,
                "u_mm": r.decision.u,
                "limit_mm": r.decision.limit,
                "verdict": r.decision.verdict,
                "where": r.where,
            }
            for r in rep.results
        ],
    }


def plan_name(session: Any) -> str:
    """The plan's name as the session recorded it (a shipped plan's name, or its file)."""
    d = session.meta.get("plan")
    name = d.get("name") if isinstance(d, dict) else None
    return str(name) if name else str(session.plan.title)


def arm_at(point: Any) -> dict[str, Any]:
    """The arm drawn at a captured point (its counts through its own parameter set)."""
    from aacmm.core import counts_to_angles

    ps = point.param_set
    theta = counts_to_angles(np.array([point.counts], dtype=np.int64), ps.encoders)[0]
    return arm_dict(arm_pose(ps.model, theta))


def verification_scene(
    plan: Any, labels: Sequence[Any], points_mm: npt.ArrayLike, rep: Any, title: str
) -> dict[str, Any]:
    """A verified session (``aacmm verify --report``): points, fits, results vs MPE."""
    n = len(labels)
    scene = points_scene(
        plan, labels, points_mm, title, "verification", f"{n} points, verdict {rep.verdict}"
    )
    if n:
        scene["arm"] = arm_at(labels[-1])
    scene["verification"] = verification_part(rep)
    return scene


def session_scene(folder: str | Path, verify: bool = True) -> dict[str, Any]:
    """A capture session: its points (recomputed from the counts), fits, arm, verdict.

    Verification runs when the plan has an MPE and every step it judges has
    its points (an incomplete session: the complete steps only). Raises
    :class:`aacmm.records.RecordError` for a missing or damaged session.
    """
    from aacmm.records import read_session

    s = read_session(folder)
    n = len(s.points)
    title = f"session {Path(folder).name}: {s.plan.title}"
    sub = f"plan {plan_name(s)}, {n} of {len(s.plan.slots)} points, {s.status}"
    if n == 0:
        scene = empty_scene("session", title, sub)
        scene["notes"].append("the session has no points yet")
        return scene
    pts = s.points_mm()
    scene = points_scene(s.plan, s.points, pts, title, "session", sub)
    scene["arm"] = arm_at(s.points[-1])
    if verify and s.plan.mpe is not None:
        from aacmm.geometry import GeometryError
        from aacmm.verification.report import evaluate

        try:
            rep = evaluate(s.plan, s.points, pts, meta={}, name=s.plan.name)
        except (GeometryError, ValueError) as exc:
            scene["notes"].append(f"not verified: {exc}")
        else:
            scene["verification"] = verification_part(rep)
    return scene


def log_scene(path: str | Path) -> dict[str, Any]:
    """A log: its samples' tip path (decimated to :data:`LOG_TRAIL_MAX`) and button presses.

    Raises :class:`aacmm.records.RecordError` for a file that is not a log.
    """
    from aacmm.records.logs import read_log, read_triggers

    log = read_log(path)
    n = len(log)
    scene = empty_scene("log", f"log {Path(path).name}", f"{n} samples")
    if n:
        pts = log.points_mm()
        step = max(1, math.ceil(n / LOG_TRAIL_MAX))
        scene["trail"] = [_xyz(q) for q in pts[::step]]
        theta = log.angles_rad()[-1]
        scene["arm"] = arm_dict(arm_pose(log.param_set_of(n - 1).model, theta))
        if step > 1:
            scene["notes"].append(f"trail: every {step}th of {n} samples")
    try:
        trig = [t for t in read_triggers(log) if t.pressed]
    except Exception as exc:  # a log without a trigger file, or a damaged one
        trig = []
        if not isinstance(exc, FileNotFoundError):
            scene["notes"].append(f"button presses not read: {exc}")
    for k, t in enumerate(trig):
        if not t.sample.status & 1:
            continue
        scene["points"].append(
            {
                "i": k,
                "slot": None,
                "step": f"button {t.button}",
                "label": f"press {k + 1}",
                "xyz": _xyz(t.sample.point_mm),
                "residual_mm": None,
            }
        )
    return scene


def calibration_scene(res: Any, cmp_: Any = None, title: str = "calibration") -> dict[str, Any]:
    """A :class:`aacmm.calibration.results.CalibrationResult`: the calibration data's
    points with the calibrated parameters, coloured by their residual after; per
    step, every unit's residual before and after (mm)."""
    from aacmm.calibration.parameters import arm_part, error_model
    from aacmm.calibration.report import unit_residuals
    from aacmm.core import Model
    from aacmm.errmodel import points as em_points

    obs = res.observations
    pr = res.problem
    model, em = Model(arm_part(res.params)), error_model(res.params)
    pts = model.points(obs.theta_rad) if em is None else em_points(model, em, obs.theta_rad)
    before = unit_residuals(pr, res.before)
    after = unit_residuals(pr, res.after)
    per_pose: list[float | None] = [None] * len(pts)
    for u in range(pr.n_units):
        v = after.signed_mm[u] if math.isfinite(after.signed_mm[u]) else after.size_mm[u]
        for pose in pr.unit(u).poses:
            per_pose[int(pose)] = float(v)
    names = obs.step_names
    scene = empty_scene("calibration", title, f"{len(pts)} poses, {pr.n_units} residual units")
    for i in range(len(pts)):
        st = int(obs.step[i])
        scene["points"].append(
            {
                "i": i,
                "slot": None,
                "step": names[st] if 0 <= st < len(names) else f"step {st + 1}",
                "label": obs.label(i),
                "xyz": _xyz(pts[i]),
                "residual_mm": per_pose[i],
            }
        )
    steps = []
    for st in np.unique(after.step):
        sel = np.flatnonzero(after.step == st)
        signed = bool(np.all(np.isfinite(after.signed_mm[sel])))
        b = before.signed_mm[sel] if signed else before.size_mm[sel]
        a = after.signed_mm[sel] if signed else after.size_mm[sel]
        steps.append(
            {
                "step": int(st),
                "name": names[st] if 0 <= st < len(names) else f"step {int(st) + 1}",
                "kinds": sorted({str(k) for k in after.kind[sel]}),
                "signed": signed,
                "before_mm": [float(x) for x in b],
                "after_mm": [float(x) for x in a],
                "rms_before_mm": float(np.sqrt(np.mean(b**2))),
                "rms_after_mm": float(np.sqrt(np.mean(a**2))),
            }
        )
    part: dict[str, Any] = {"steps": steps, "chi_square": res.chi_square.describe()}
    if cmp_ is not None:
        part["before_after"] = [
            {"figure": n, "before": b, "after": a, "factor": f if math.isfinite(f) else None}
            for n, b, a, f in cmp_.rows()
        ]
    scene["calibration"] = part
    return scene
