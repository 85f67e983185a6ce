"""The parameter set in force: a device parameter set with its CRC, as recorded
in logs and sessions, and as :mod:`aacmm.core` needs it.

Every recorded row names the set it was taken with by CRC (the
``param_crc32`` column, ``0x`` + 8 hex digits); the sidecar lists each set
(``param_sets``) with its kinematic parameters and encoder configuration.
A set read back from a file is checked against its CRC, so a sidecar edited
by hand (or damaged) is refused instead of silently used. Files written with
protocol version 1 carry that version's CRC (over its 278-byte six-joint
layout); they still read: the set is accepted when it matches either CRC and
keeps the CRC it was recorded with (its rows name it so).

A set of any arm (issue 26: 4 to 7 joints, standard or modified DH, betas,
a tip vector) is recorded as well. A set of the paper's shape (six standard
joints, no beta, tip l) keeps today's form exactly (``params`` with the five
kinematic keys, six values each); any other holds in ``params`` the keys of
a parameter file (:mod:`aacmm.records.paramfile`): N values per per-joint
list, ``convention``, ``beta_joints`` and ``beta_rad``, and ``tip_mm`` for a
tip vector (instead of ``l_mm``), so ``aacmm params set run.csv.json`` reads
it (docs/cli.md, "Logs of any arm").

A set with encoder angle harmonics (issue 27, ``aacmm params set`` of a file
with an ``[errmodel]`` table) adds ``errmodel`` beside ``params``: the
parameter file's table, exactly the wire's values, so the entry's CRC is the
device's; :meth:`ParamSetRecord.points` (and every recomputed point) applies
it. A set with the thermal block (issue 27: link CTEs and reference
temperatures, a device that reads its link temperatures) records them there
too (``cte_per_k``, ``tref_c``): its points are recomputed at each row's link
temperatures, the device's readings the row carries
(:meth:`aacmm.records.Recorded.points_mm`).
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass
from typing import Any

from aacmm.arm import Arm
from aacmm.core import EncoderConfig, FloatArray, Model, Params
from aacmm.errmodel import ErrorModel
from aacmm.errmodel import points as errmodel_points
from aacmm.protocol import ParamSet, param_set_crc32
from aacmm.protocol.errwire import error_model, with_error_model
from aacmm.records.files import RecordError, crc_hex

KIN_KEYS: tuple[str, ...] = ("theta_offset_rad", "alpha_rad", "d_mm", "a_mm", "l_mm")
#: Keys of ``params`` an arm of another shape than the paper's adds (all optional; a
#: parameter file's, :data:`aacmm.records.paramfile.SHAPE_KEYS`: ``tip_mm`` replaces
#: ``l_mm`` for a tip vector).
SHAPE_KEYS: tuple[str, ...] = ("convention", "beta_joints", "beta_rad", "tip_mm")
ENC_KEYS: tuple[str, ...] = ("counts_per_rev", "zero_offset_counts", "direction")


@dataclass(frozen=True)
class ParamSetRecord:
    """One parameter set in force: its CRC (as the device reports it), the
    kinematic model and the encoder configuration (:class:`aacmm.core.EncoderConfig`).

    ``model`` is an arm of the paper's shape in its 25-parameter form
    (:class:`aacmm.core.Params`) or any other arm (:class:`aacmm.arm.Arm`);
    either goes to ``aacmm.core.Model`` as it is. :attr:`arm` is the model as
    an :class:`~aacmm.arm.Arm` in both cases, :attr:`joints` its N (the count
    columns of the rows taken with it); :attr:`params` the 25-parameter form,
    for consumers of the paper's arm only.
    """

    crc32: int
    model: Params | Arm
    encoders: EncoderConfig
    errors: ErrorModel | None = None

    def __post_init__(self) -> None:
        if isinstance(self.model, Arm) and self.model.is_paper_shape:
            object.__setattr__(self, "model", Params.from_arm(self.model))  # one form per set
        if self.errors is not None and not any(self.errors.harmonics) and not self.thermal:
            object.__setattr__(self, "errors", None)  # one form: no error terms, no error model

    @property
    def thermal(self) -> bool:
        """The set has the thermal block: its points depend on the link temperatures."""
        from aacmm.records.paramfile import has_thermal

        return self.errors is not None and has_thermal(self.errors)

    def points(self, theta: Any, temp_c: Any = None) -> FloatArray:
        """Probe points (n, 3) of joint readings ``theta`` (n, N) in double precision,
        as the device computes them with this set: its arm and its error model, at the
        link temperatures ``temp_c`` (degC, (N,) or (n, N); None: the reference ones,
        where a thermal block scales nothing)."""
        if self.errors is None:
            return Model(self.model).points(theta)
        return errmodel_points(Model(self.model), self.errors, theta, temp_c)

    def errmodel_text(self) -> str:
        """The set's error model in words (:func:`errmodel_text`)."""
        ks = self.errors.harmonics if self.errors is not None else ()
        return errmodel_text(tuple(len(h) for h in ks), self.thermal)

    def errmodel_json(self) -> dict[str, Any] | None:
        """The set's ``errmodel`` entry (a parameter file's ``[errmodel]`` table), or None."""
        from aacmm.records.paramfile import errmodel_dict

        return None if self.errors is None else errmodel_dict(self.errors)

    @property
    def crc_hex(self) -> str:
        return crc_hex(self.crc32)

    @property
    def arm(self) -> Arm:
        """The kinematic model as an :class:`aacmm.arm.Arm` (any shape)."""
        return self.model if isinstance(self.model, Arm) else self.model.to_arm()

    @property
    def joints(self) -> int:
        """N: the arm's joints (and the count columns of its rows)."""
        return self.arm.n_joints

    @property
    def is_paper_shape(self) -> bool:
        return isinstance(self.model, Params)

    @property
    def params(self) -> Params:
        """The 25-parameter form (:meth:`paper_params`).

        Raises:
            RecordError: the set is an arm of another shape than the paper's.
        """
        return self.paper_params("this command")

    def paper_params(self, what: str) -> Params:
        """The 25-parameter form, for consumers that handle only the paper's shape.

        Raises:
            RecordError: the set is an arm of another shape (``what`` names the consumer).
        """
        if isinstance(self.model, Params):
            return self.model
        a = self.model
        raise RecordError(
            f"parameter set {self.crc_hex} is an arm of {a.n_joints} joints and {a.n_params} "
            f"parameters; {what} handles the paper's six-joint arm only so far"
        )

    def describe(self) -> str:
        """``6 joints, 25 parameters`` (for messages)."""
        return f"{self.arm.n_joints} joints, {self.arm.n_params} parameters"

    @classmethod
    def from_device(cls, ps: ParamSet) -> ParamSetRecord:
        """From a device's GET_PARAMS answer (CRC computed as the device does).

        Any arm model (4 to 7 joints) with its encoder harmonics and its thermal
        block (issue 27: :attr:`errors`, exactly the wire's values).
        """
        crc = param_set_crc32(ps)
        errors = error_model(ps) if ps.harm_cos or ps.cte else None
        if ps.is_paper_shape:
            params, encoders = ps.to_core()
            return cls(crc, params, encoders, errors)
        arm, encoders = ps.to_arm()
        return cls(crc, arm, encoders, errors)

    def to_device(self) -> ParamSet:
        if isinstance(self.model, Params):
            ps = ParamSet.from_core(self.model, self.encoders)
        else:
            ps = ParamSet.from_arm(self.model, self.encoders)
        return ps if self.errors is None else with_error_model(ps, self.errors)

    def params_json(self) -> dict[str, Any]:
        """``params`` of a sidecar entry: the paper's five keys, or for an arm of
        another shape the parameter file's keys (:func:`aacmm.records.paramfile.param_set_dict`)."""
        from aacmm.records.paramfile import param_set_dict

        d = param_set_dict(self.to_device())
        return {k: v for k, v in d.items() if k in KIN_KEYS + SHAPE_KEYS}

    def encoders_json(self) -> dict[str, Any]:
        e = self.encoders
        return {
            "counts_per_rev": list(e.counts_per_rev),
            "zero_offset_counts": list(e.zero_offset_counts),
            "direction": list(e.direction),
        }

    def to_json(self) -> dict[str, Any]:
        """``{"param_crc32", "param_crc32_hex", "params", "encoders"}`` and, for a set
        with encoder harmonics, ``errmodel`` (a parameter file's ``[errmodel]`` table)."""
        out = {
            "param_crc32": self.crc32,
            "param_crc32_hex": self.crc_hex,
            "params": self.params_json(),
            "encoders": self.encoders_json(),
        }
        em = self.errmodel_json()
        if em is not None:
            out["errmodel"] = em
        return out

    @classmethod
    def from_json(cls, d: Any, where: str) -> ParamSetRecord:
        """Inverse of :meth:`to_json`, checked against the CRC.

        Raises:
            RecordError: a missing or bad value, or a set that does not match its CRC.
        """
        if not isinstance(d, dict):
            raise RecordError(f"{where}: a parameter set must be an object")
        crc = d.get("param_crc32")
        if isinstance(crc, bool) or not isinstance(crc, int) or not 0 <= crc <= 0xFFFFFFFF:
            raise RecordError(f"{where}: param_crc32 must be an unsigned 32-bit integer")
        kin, enc = d.get("params"), d.get("encoders")
        if not isinstance(kin, dict) or not isinstance(enc, dict):
            raise RecordError(f"{where}: needs the objects params and encoders")
        ps = param_set_from_json(kin, enc, where)
        if d.get("errmodel") is not None:
            ps = _with_errmodel_json(ps, d["errmodel"], where)
        actual = param_set_crc32(ps)
        if actual != crc:
            if param_set_crc32_v1(ps) == crc:  # written with protocol version 1
                params, encoders = ps.to_core()
                return cls(crc, params, encoders)
            raise RecordError(
                f"{where}: the parameter set does not match its CRC "
                f"({crc_hex(actual)}, recorded {crc_hex(crc)}): edited or damaged"
            )
        return cls.from_device(ps)


def errmodel_text(harmonics: tuple[int, ...], thermal: bool = False) -> str:
    """An error model in words: ``encoder harmonics K per joint 2,2,2,2,2,0`` (and
    ``, thermal expansion``), or ``none (DH only)``; ``harmonics``: K per joint."""
    parts = []
    if any(harmonics):
        parts.append("encoder harmonics K per joint " + ",".join(map(str, harmonics)))
    if thermal:
        parts.append("thermal expansion")
    return ", ".join(parts) or "none (DH only)"


def _with_errmodel_json(ps: ParamSet, value: Any, where: str) -> ParamSet:
    """``ps`` with a sidecar entry's ``errmodel`` (the wire's units, as the device held it).

    Raises:
        RecordError: a bad table, or values the wire cannot carry.
    """
    from aacmm.records.paramfile import ParamFileError, errmodel_from_mapping

    try:
        em = errmodel_from_mapping(value, ps.joints, where)
    except ParamFileError as exc:
        raise RecordError(str(exc)) from None
    try:
        return with_error_model(ps, em)
    except ValueError as exc:
        raise RecordError(f"{where}: errmodel: {exc}") from None


def param_set_crc32_v1(ps: ParamSet) -> int | None:
    """The CRC a protocol version 1 device reported for ``ps`` (CRC-32 over the
    version 1 layout: 25 f64, u64 cpr[6], u32 zero[6], i8 direction[6]), or None
    for a set that is not of the paper's shape (version 1 had no other)."""
    if not ps.is_paper_shape:
        return None
    return zlib.crc32(
        struct.pack(
            "<25d6Q6I6b",
            *ps.theta_offset_rad,
            *ps.alpha_rad,
            *ps.d_mm,
            *ps.a_mm,
            ps.l_mm,
            *ps.counts_per_rev,
            *ps.zero_offset_counts,
            *ps.direction,
        )
    )


def param_set_from_json(kin: dict[str, Any], enc: dict[str, Any], where: str) -> ParamSet:
    """The device set of a sidecar entry's ``params`` and ``encoders`` objects (N
    from ``theta_offset_rad``; every per-joint list must hold N values), checked
    as a device checks it. An arm of another shape than the paper's is read as a
    parameter file reads it (:func:`aacmm.records.paramfile.param_set_from_mapping`).

    Raises:
        RecordError: a missing, unknown or bad value (naming ``where`` and the key).
    """
    th = kin.get("theta_offset_rad")
    if isinstance(th, list) and len(th) == 6 and not any(k in kin for k in SHAPE_KEYS):
        return _paper_set(kin, enc, where)
    from aacmm.records.paramfile import param_set_from_mapping

    ps = param_set_from_mapping({"params": kin, "encoders": enc}, where)
    try:
        ps.to_arm()  # the arm's own checks (beta on joint 1, ranges)
    except ValueError as exc:
        raise RecordError(f"{where}: bad parameter set: {exc}") from None
    return ps


def _paper_set(kin: dict[str, Any], enc: dict[str, Any], where: str) -> ParamSet:
    """A six-joint set of the paper's shape, read as before."""
    for k in kin:
        if k not in KIN_KEYS:
            raise RecordError(f"{where}: unknown key params.{k}")
    fl = {k: _floats(kin, k, where, 1 if k == "l_mm" else 6) for k in KIN_KEYS}
    it = {k: _ints(enc, k, where, 6) for k in ENC_KEYS}
    ps = ParamSet(
        fl["theta_offset_rad"],
        fl["alpha_rad"],
        fl["d_mm"],
        fl["a_mm"],
        fl["l_mm"][0],
        it["counts_per_rev"],
        it["zero_offset_counts"],
        it["direction"],
    )
    try:
        param_set_crc32(ps)  # the codec's checks (ranges, encoders)
    except ValueError as exc:
        raise RecordError(f"{where}: bad parameter set: {exc}") from None
    return ps


def _floats(d: dict[str, Any], key: str, where: str, n: int) -> tuple[float, ...]:
    v = d.get(key)
    vals = [v] if key in ("l_mm", "x") else v
    if not isinstance(vals, list) or len(vals) != n:
        raise RecordError(f"{where}: params.{key} must be {n} number(s)")
    out = []
    for x in vals:
        if isinstance(x, bool) or not isinstance(x, int | float) or not math.isfinite(x):
            raise RecordError(f"{where}: params.{key} must hold finite numbers")
        out.append(float(x))
    return tuple(out)


def _ints(d: dict[str, Any], key: str, where: str, n: int) -> tuple[int, ...]:
    v = d.get(key)
    if not isinstance(v, list) or len(v) != n:
        raise RecordError(f"{where}: encoders.{key} must be {n} integers (one per joint)")
    if any(isinstance(x, bool) or not isinstance(x, int) for x in v):
        raise RecordError(f"{where}: encoders.{key} must hold integers")
    return tuple(int(x) for x in v)
