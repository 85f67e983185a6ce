"""Calibration observations from capture sessions (:mod:`aacmm.records`).

Each plan step becomes a constraint (docs/calibration.md, "From sessions"):

* ``cone`` and ``articulation`` on a cone seat -- a point constraint
  (:class:`Cone`), or reference points when the seat's location is a
  calibrated reference (``location_reference = true``);
* ``sphere`` and ``articulation`` on a sphere -- a :class:`Sphere` of the
  tip-centre radius D/2 + r (r: the probe ball's radius), its diameter's
  standard uncertainty as the radius prior;
* ``length`` on a ball bar or gauge -- a :class:`LengthSet` with the
  calibrated length and its standard uncertainty (common to all positions);
  cone ends are one point each; sphere ends are the fitted ball centres;
* ``plane`` -- a :class:`Plane`;
* ``points`` -- not used (free points constrain nothing).

Joint angles come from the counts with each row's own encoder configuration;
the start of the fit is the kinematic parameter set in force: the paper's
:class:`~aacmm.core.Params` for a set of its shape, any other arm's
:class:`~aacmm.arm.Arm` (issue 26), as the session's sidecar records it.
Every session of one calibration (and every validation session) must be of
one arm shape (joints, conventions, betas, tip: the same parameter names)
and taken with one encoder configuration, and the calibration sessions with
one parameter set: the counts of another configuration mean other angles,
and a fit must start from the set its data were taken with. Anything else is
refused with one line naming the session.

Errors: :class:`SessionDataError` (a ValueError: exit status 2 in the CLI).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from aacmm.calibration.observations import (
    Cone,
    Constraint,
    LengthSet,
    ObservationError,
    Observations,
    Plane,
    ReferencePoints,
    Sphere,
    combine,
)
from aacmm.calibration.parameters import ArmParams
from aacmm.core import EncoderConfig, FloatArray
from aacmm.plans import model as pm
from aacmm.records import ParamSetRecord, RecordError, Session, read_session
from aacmm.records.measured import per_point_temperatures, stated_temperatures

DEFAULT_SIGMA_MM = 0.005
IntArray = npt.NDArray[np.intp]


class SessionDataError(ObservationError):
    """A session cannot be calibrated from (empty, too few points, another parameter set)."""


@dataclass(frozen=True)
class SessionSource:
    """Where observations came from: one session and what it contributed."""

    path: str
    plan: str
    plan_sha256: str
    status: str
    points: int
    param_set: ParamSetRecord
    used_steps: tuple[str, ...]
    unused_steps: tuple[str, ...]
    plan_points: int = 0
    serial_number: int | None = None
    firmware: str | None = None


@dataclass(frozen=True)
class SessionData:
    """Observations from one or more sessions, their start parameters and provenance."""

    observations: Observations
    start: ArmParams
    param_set: ParamSetRecord
    sources: tuple[SessionSource, ...]
    #: with ``load_sessions(temperatures=True)``: the sessions with a point whose
    #: capture run states no link temperature (then no observation carries one)
    unstated_temperature: tuple[str, ...] = ()
    #: with ``load_sessions(temperatures=True)``: where the device's link temperatures
    #: and the stated ones differ by more than 1 degC (:func:`link_temperature_warning`)
    temperature_warnings: tuple[str, ...] = ()

    @property
    def encoders(self) -> EncoderConfig:
        return self.param_set.encoders

    @property
    def serial_number(self) -> int | None:
        """The device serial number the sessions were taken on (None: not recorded)."""
        return self.sources[0].serial_number if self.sources else None

    @property
    def firmware(self) -> str | None:
        return self.sources[0].firmware if self.sources else None


def _std(art: pm.Artefact, expanded: float | None) -> float:
    u = art.standard_uncertainty(expanded)
    return 0.0 if u is None else float(u)


def _step_constraints(
    plan: pm.Plan,
    labels: Sequence[pm.PointLabel],
    step: pm.Step,
    rows: IntArray,
    base_known: bool,
    where: str,
) -> list[Constraint]:
    """The constraints of one step (``rows``: indices into ``labels``, the pose table)."""
    art = plan.artefact_of(step)
    name = f"{step.id}"
    where = f"{where}: step '{step.id}' ({step.procedure})"
    r_probe = plan.probe.ball_radius_mm
    if step.procedure in ("cone", "articulation") and isinstance(art, pm.ConeSeat):
        if rows.size < 2 and not (art.location_reference and base_known):
            raise SessionDataError(
                f"{where} has {rows.size} point: a seat needs at least 2 articulations"
            )
        if art.location_reference and art.location_mm is not None:
            xyz = np.tile(np.asarray(art.location_mm, dtype=np.float64), (rows.size, 1))
            u = _std(art, art.location_uncertainty_mm)
            return [ReferencePoints(name, rows, xyz, u, base_known)]
        return [Cone(name, rows)]
    if step.procedure in ("sphere", "articulation") and isinstance(art, pm.Sphere):
        radius = art.radius_mm + r_probe
        u_r = _std(art, art.diameter_uncertainty_mm) / 2.0
        sph = Sphere(name, rows, radius, u_r)
        if rows.size < sph.min_poses:
            raise SessionDataError(
                f"{where} has {rows.size} points: a sphere needs at least {sph.min_poses}"
            )
        return [sph]
    if step.procedure == "length" and isinstance(art, pm.LengthStandard):
        ends_a, ends_b = [], []
        by_pos: dict[int, dict[str, list[int]]] = {}
        for r in rows.tolist():
            lab = labels[r]
            if lab.position_index is None or lab.end not in ("A", "B"):
                raise SessionDataError(f"{where}: row {r + 1} has no length position/end label")
            by_pos.setdefault(lab.position_index, {"A": [], "B": []})[lab.end].append(r)
        for k in sorted(by_pos):
            a, b = by_pos[k]["A"], by_pos[k]["B"]
            if a and b:
                ends_a.append(np.array(a, dtype=np.intp))
                ends_b.append(np.array(b, dtype=np.intp))
        if not ends_a:
            raise SessionDataError(f"{where}: no position has both ends probed")
        end_radius = None
        if art.ends == "sphere":
            end_radius = (art.end_diameter_mm or 0.0) / 2.0 + r_probe
        return [
            LengthSet(
                name,
                art.length_mm,
                tuple(ends_a),
                tuple(ends_b),
                _std(art, art.length_uncertainty_mm),
                end_radius,
            )
        ]
    if step.procedure == "plane" and isinstance(art, pm.Plane):
        if rows.size < Plane.MIN_POSES:
            raise SessionDataError(f"{where} has {rows.size} points: a plane needs at least 4")
        return [Plane(name, rows)]
    return []


def observations_from_plan(
    plan: pm.Plan,
    theta_rad: npt.ArrayLike,
    sigma_mm: float = DEFAULT_SIGMA_MM,
    base_known: bool = False,
    labels: Sequence[pm.PointLabel] | None = None,
    where: str = "",
) -> tuple[Observations, list[str], list[str]]:
    """Observations of a plan's points: the mapping of the module doc, step by step.

    ``theta_rad`` (n, N): joint readings of the points, row i labelled by
    ``labels[i]`` (default: the plan's first n slots, in order -- a design
    whose poses come from a simulated operator, or a session's rows). Returns
    the observations and the ids of the steps used and not used (free points).

    Raises SessionDataError (no point, too few points in a step, no step that
    constrains anything), ObservationError (bad joint readings).
    """
    theta = np.asarray(theta_rad, dtype=np.float64)
    n = theta.shape[0] if theta.ndim == 2 else 0
    where = where or f"plan {plan.title}"
    if n == 0:
        raise SessionDataError(f"{where}: no points")
    labs: Sequence[pm.PointLabel] = labels if labels is not None else plan.slots[:n]
    if len(labs) != n:
        raise SessionDataError(f"{where}: {n} poses for {len(labs)} labelled points")
    step_of = np.array([lab.step_index for lab in labs], dtype=np.intp)
    cons: list[Constraint] = []
    used: list[str] = []
    unused: list[str] = []
    for step in plan.steps:
        rows = np.flatnonzero(step_of == step.index).astype(np.intp)
        if rows.size == 0:
            continue
        got = _step_constraints(plan, labs, step, rows, base_known, where)
        (used if got else unused).append(step.id)
        cons += got
    if not cons:
        raise SessionDataError(
            f"{where}: no step gives a calibration constraint (seats, spheres, lengths or planes)"
        )
    obs = Observations(
        theta,
        np.full(n, float(sigma_mm)),
        tuple(cons),
        step_of,
        np.array([lab.point_index for lab in labs], dtype=np.intp),
        tuple(s.id for s in plan.steps),
    )
    return obs, used, unused


def session_observations(
    session: Session,
    sigma_mm: float = DEFAULT_SIGMA_MM,
    base_known: bool = False,
    temperatures: bool = False,
) -> tuple[Observations, list[str], list[str]]:
    """The observations of one session, and the step ids used and not used.

    ``temperatures``: the observations carry each point's link temperatures,
    the device's readings else the one its capture run states
    (:func:`stated_link_temperatures`).

    Raises SessionDataError (empty session, too few points in a step, with
    ``temperatures`` a point whose run states none), RecordError (a reading
    beyond the encoder's resolution).
    """
    if len(session) == 0:
        raise SessionDataError(f"{session.path}: the session has no points")
    obs, used, unused = observations_from_plan(
        session.plan,
        session.angles_rad(),
        sigma_mm,
        base_known,
        session.points,
        str(session.path),
    )
    if temperatures:
        t = stated_link_temperatures(session)
        if t is None:
            raise SessionDataError(
                f"{session.path}: a capture run states no link temperature "
                "(aacmm capture --temperature)"
            )
        obs = dataclasses.replace(obs, temp_c=t)
    return obs, used, unused


def stated_link_temperatures(session: Session) -> FloatArray | None:
    """Per point the temperature of each link (n, N), degC: the device's reading of
    the link where the point has one, else the one its capture run states
    (:func:`aacmm.records.measured.stated_temperatures`), else (a sensor that did not
    answer, nothing stated) the mean of the point's other links; None unless every
    point has one (:func:`link_temperature_warning` says when readings and
    statements disagree)."""
    temps, _, _ = per_point_temperatures(
        stated_temperatures(session), session.device_temp_c, session.joints
    )
    if not len(temps) or not np.isfinite(temps).any(axis=1).all():
        return None
    with np.errstate(invalid="ignore"):
        mean = np.nanmean(temps, axis=1, keepdims=True)
    return np.asarray(np.where(np.isfinite(temps), temps, mean), dtype=np.float64)


def link_temperature_warning(session: Session) -> str | None:
    """A warning when the device's link temperatures and the ones the capture runs
    state differ by more than 1 degC (the readings are used)."""
    _, _, warning = per_point_temperatures(
        stated_temperatures(session), session.device_temp_c, session.joints
    )
    return None if warning is None else f"{session.path}: {warning}"


def _shape(ps: ParamSetRecord) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """What makes two sets the same arm shape: the parameter names and the conventions."""
    a = ps.arm
    return a.param_names, tuple(j.convention for j in a.joints)


def _shape_text(ps: ParamSetRecord) -> str:
    a = ps.arm
    return f"an arm of {a.n_joints} joints and {a.n_params} parameters"


def _same_shape(ref: ParamSetRecord, ref_path: str, ps: ParamSetRecord, path: str) -> None:
    """One arm shape for every session (the parameters the fit estimates)."""
    if _shape(ps) != _shape(ref):
        raise SessionDataError(
            f"{path}: taken with {_shape_text(ps)} (parameter set {ps.crc_hex}), {ref_path} "
            f"with {_shape_text(ref)} ({ref.crc_hex}): a calibration takes the sessions of "
            "one arm"
        )


def _same_set(ref: ParamSetRecord, ref_path: str, ps: ParamSetRecord, path: str) -> None:
    _same_shape(ref, ref_path, ps, path)
    if ps.encoders != ref.encoders:
        raise SessionDataError(
            f"{path}: taken with another encoder configuration than {ref_path} "
            f"(parameter set {ps.crc_hex} vs {ref.crc_hex}): its counts mean other angles"
        )
    if ps.model != ref.model or ps.errors != ref.errors:
        raise SessionDataError(
            f"{path}: taken with parameter set {ps.crc_hex}, {ref_path} with {ref.crc_hex}: "
            "calibrate sessions taken with one parameter set (the start of the fit)"
        )


def _session_set(session: Session) -> ParamSetRecord:
    """The one parameter set of a session (kinematics and encoders), or an error."""
    crcs = np.unique(session.param_crc32)
    first = session.param_set_of(0)
    for c in crcs.tolist():
        ps = session.param_sets[int(c)]
        if ps.encoders != first.encoders:
            raise SessionDataError(
                f"{session.path}: the encoder configuration changes within the session "
                f"({first.crc_hex} -> {ps.crc_hex}): analyse the parts separately"
            )
    try:
        session.single_params("calibration")
    except RecordError as e:
        raise SessionDataError(str(e)) from None
    return first


def _device_identity(s: Session) -> tuple[int | None, str | None]:
    """The session's device serial number and firmware version (None where not recorded,
    or not a plausible value: the sidecar is input like any other)."""
    dev = s.device or {}
    serial = dev.get("serial_number")
    fw = dev.get("firmware")
    ok_serial = isinstance(serial, int) and not isinstance(serial, bool) and serial >= 0
    ok_fw = isinstance(fw, str) and 0 < len(fw) <= 64 and fw.isprintable()
    return (serial if ok_serial else None), (fw if ok_fw else None)


def _same_arm(ref: SessionSource, src: SessionSource) -> None:
    if (
        ref.serial_number is not None
        and src.serial_number is not None
        and ref.serial_number != src.serial_number
    ):
        raise SessionDataError(
            f"{src.path}: taken on the arm with serial number {src.serial_number}, {ref.path} on "
            f"serial {ref.serial_number}: a calibration takes the sessions of one arm"
        )


def _plan_name(s: Session) -> str:
    """The plan's name as the session records it (a shipped plan's name, or the file's stem)."""
    meta = s.meta.get("plan")
    name = meta.get("name") if isinstance(meta, dict) else None
    return Path(name).stem if isinstance(name, str) and name else s.plan.title


def load_sessions(
    paths: Sequence[str | Path],
    sigma_mm: float = DEFAULT_SIGMA_MM,
    base_known: bool = False,
    like: ParamSetRecord | None = None,
    any_params: bool = False,
    arm: Sequence[SessionSource] | None = None,
    temperatures: bool = False,
) -> SessionData:
    """Read sessions and turn them into one set of observations.

    ``like``: the encoder configuration (and, unless ``any_params``, the
    kinematic set) the sessions must have been taken with; default: the
    first session's. ``any_params``: accept other kinematic sets (held-out
    validation data taken after a calibration). Every session must come from
    one arm (the device serial number its sidecar records), the arm of the
    sessions ``arm`` too when given (the calibration's, for held-out data).
    ``temperatures``: the observations carry the link temperatures of every
    point (:func:`stated_link_temperatures`) when every session reads or states
    them for each of its points; otherwise none does, and
    :attr:`SessionData.unstated_temperature` names the sessions that do not.

    Raises SessionDataError, RecordError (unreadable or damaged session).
    """
    if not paths:
        raise SessionDataError("no session given")
    if not (sigma_mm > 0 and np.isfinite(sigma_mm)):
        raise ValueError(f"the probing uncertainty must be > 0, got {sigma_mm}")
    parts: list[Observations] = []
    sources: list[SessionSource] = []
    temps: list[FloatArray | None] = []
    unstated: list[str] = []
    warnings: list[str] = []
    ref = like
    ref_path = "the calibration sessions"
    for p in paths:
        s = read_session(p)
        if len(s) == 0:
            raise SessionDataError(f"{s.path}: the session has no points")
        ps = _session_set(s)
        if ref is None:
            ref, ref_path = ps, str(s.path)
        elif any_params:
            _same_shape(ref, ref_path, ps, str(s.path))
            if ps.encoders != ref.encoders:
                _same_set(ref, ref_path, ps, str(s.path))
        else:
            _same_set(ref, ref_path, ps, str(s.path))
        obs, used, unused = session_observations(s, sigma_mm, base_known)
        if temperatures:
            t = stated_link_temperatures(s)
            if t is None:
                unstated.append(str(s.path))
            temps.append(t)
            warning = link_temperature_warning(s)
            if warning is not None:
                warnings.append(warning)
        parts.append(obs)
        serial, firmware = _device_identity(s)
        src = SessionSource(
            str(s.path),
            _plan_name(s),
            s.plan.sha256,
            s.status,
            len(s),
            ps,
            tuple(used),
            tuple(unused),
            len(s.plan.slots),
            serial,
            firmware,
        )
        for other in (*(arm or ()), *sources):
            _same_arm(other, src)
        sources.append(src)
    assert ref is not None
    if temperatures and not unstated:
        parts = [dataclasses.replace(o, temp_c=t) for o, t in zip(parts, temps, strict=True)]
    obs = parts[0] if len(parts) == 1 else combine(parts)
    return SessionData(obs, ref.model, ref, tuple(sources), tuple(unstated), tuple(warnings))
