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
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass
from typing import Any

from aacmm.core import JOINTS, EncoderConfig, Params
from aacmm.protocol import ParamSet, param_set_crc32
from aacmm.records.files import RecordError, crc_hex

KIN_KEYS: tuple[str, ...] = ("theta_offset_rad", "alpha_rad", "d_mm", "a_mm", "l_mm")
ENC_KEYS: tuple[str, ...] = ("counts_per_rev", "zero_offset_counts", "direction")


@dataclass(frozen=True)
class ParamSetRecord:
    """One parameter set in force: its CRC (as the device reports it), the
    kinematic parameters (:class:`aacmm.core.Params`) and the encoder
    configuration (:class:`aacmm.core.EncoderConfig`)."""

    crc32: int
    params: Params
    encoders: EncoderConfig

    @property
    def crc_hex(self) -> str:
        return crc_hex(self.crc32)

    @classmethod
    def from_device(cls, ps: ParamSet) -> ParamSetRecord:
        """From a device's GET_PARAMS answer (CRC computed as the device does).

        Raises:
            RecordError: the device's arm model is not of the paper's shape (six
                standard joints, tip l): logs and sessions do not hold other models yet.
        """
        if not ps.is_paper_shape:
            raise RecordError(
                f"the device's arm model has {ps.joints} joints and {ps.n_params} parameters: "
                "logs and sessions hold the paper's six-joint arm only so far"
            )
        params, encoders = ps.to_core()
        return cls(param_set_crc32(ps), params, encoders)

    def to_device(self) -> ParamSet:
        p, e = self.params, self.encoders
        return ParamSet(
            p.theta_offset_rad,
            p.alpha_rad,
            p.d_mm,
            p.a_mm,
            p.l_mm,
            e.counts_per_rev,
            e.zero_offset_counts,
            e.direction,
        )

    def params_json(self) -> dict[str, Any]:
        p = self.params
        return {
            "theta_offset_rad": list(p.theta_offset_rad),
            "alpha_rad": list(p.alpha_rad),
            "d_mm": list(p.d_mm),
            "a_mm": list(p.a_mm),
            "l_mm": p.l_mm,
        }

    def encoders_json(self) -> dict[str, Any]:
        e = self.encoders
        return {
            "counts_per_rev": list(e.counts_per_rev),
            "zero_offset_counts": list(e.zero_offset_counts),
            "direction": list(e.direction),
        }

    def to_json(self) -> dict[str, Any]:
        """``{"param_crc32", "param_crc32_hex", "params", "encoders"}``."""
        return {
            "param_crc32": self.crc32,
            "param_crc32_hex": self.crc_hex,
            "params": self.params_json(),
            "encoders": self.encoders_json(),
        }

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
        fl = {k: _floats(kin, k, where) for k in KIN_KEYS}
        it = {k: _ints(enc, k, where) for k in ENC_KEYS}
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
            actual = param_set_crc32(ps)
        except ValueError as exc:
            raise RecordError(f"{where}: bad parameter set: {exc}") from None
        if actual != crc:
            if param_set_crc32_v1(ps) == crc:  # written with protocol version 1
                params, encoders = ps.to_core()
                return cls(crc, params, encoders)
            raise RecordError(
                f"{where}: the parameter set does not match its CRC "
                f"({crc_hex(actual)}, recorded {crc_hex(crc)}): edited or damaged"
            )
        return cls.from_device(ps)


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


def _floats(d: dict[str, Any], key: str, where: str) -> tuple[float, ...]:
    v = d.get(key)
    vals = [v] if key == "l_mm" else v
    n = 1 if key == "l_mm" else JOINTS
    if not isinstance(vals, list) or len(vals) != n:
        raise RecordError(f"{where}: params.{key} must be {n} number(s)")
    out = []
    for x in vals:
        if isinstance(x, bool) or not isinstance(x, int | float) or not math.isfinite(x):
            raise RecordError(f"{where}: params.{key} must hold finite numbers")
        out.append(float(x))
    return tuple(out)


def _ints(d: dict[str, Any], key: str, where: str) -> tuple[int, ...]:
    v = d.get(key)
    if not isinstance(v, list) or len(v) != JOINTS:
        raise RecordError(f"{where}: encoders.{key} must be {JOINTS} integers")
    if any(isinstance(x, bool) or not isinstance(x, int) for x in v):
        raise RecordError(f"{where}: encoders.{key} must hold integers")
    return tuple(int(x) for x in v)
