"""The truth file's reader: a :class:`~aacmm.simulation.truth.Truth` from its
TOML content (docs/simulator.md, "The truth file"); :meth:`Truth.to_mapping
<aacmm.simulation.truth.Truth.to_mapping>` writes it and
:func:`aacmm.simulation.truth.load_truth` reads a file through
:func:`truth_from_mapping`. A missing table means no such error; a bad or
unknown key raises :class:`~aacmm.simulation.truth.TruthError` naming the
file and the key.
"""

from __future__ import annotations

import math
from typing import Any

from aacmm.arm import Arm
from aacmm.core import JOINTS, EncoderConfig, Params
from aacmm.simulation.thermal import ThermalProfile
from aacmm.simulation.truth import FORMAT, TABLES, ErrorSources, Truth, TruthError


def _six(
    name: str, values: Any, src: str, lo: float = -math.inf, n: int = JOINTS
) -> tuple[float, ...]:
    if not isinstance(values, list) or len(values) != n:
        raise TruthError(f"{src}: {name} must be a list of {n} numbers")
    out = []
    for i, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise TruthError(f"{src}: {name}[{i}] must be a finite number, got {v!r}")
        if v < lo:
            raise TruthError(f"{src}: {name}[{i}]={v} must be >= {lo:g}")
        out.append(float(v))
    return tuple(out)


def truth_from_mapping(data: Any, src: str = "truth") -> Truth[Any]:
    """A :class:`Truth` from a truth file's content.

    Raises:
        TruthError: a missing, unknown or bad key (the message names ``src`` and the key).
    """
    from aacmm.records.paramfile import ParamFileError, param_set_from_mapping

    if not isinstance(data, dict):
        raise TruthError(f"{src}: expected a table")
    fmt = data.get("format", FORMAT)
    if fmt != FORMAT:
        raise TruthError(f"{src}: format is {fmt!r}, expected {FORMAT!r}")
    for key, value in data.items():
        if key in TABLES and not isinstance(value, dict):
            raise TruthError(f"{src}: {key} must be a table")
    plain = {k: v for k, v in data.items() if k not in TABLES and k != "format"}
    try:
        ps = param_set_from_mapping(plain, src)
    except ParamFileError as exc:
        raise TruthError(str(exc)) from None
    noise = dict(data.get("encoder_noise", {}))
    ecc = dict(data.get("eccentricity", {}))
    harm = dict(data.get("harmonics", {}))
    thermal = dict(data.get("thermal", {}))
    probing = dict(data.get("probing", {}))
    for table, got, allowed in (
        ("encoder_noise", noise, {"sigma_counts"}),
        ("eccentricity", ecc, {"amplitude_arcsec", "phase_rad"}),
        ("harmonics", harm, {"order", "amplitude_arcsec", "phase_rad"}),
        ("thermal", thermal, {"material", "cte_per_k", "tref_c"}),
        ("probing", probing, {"sigma_um"}),
    ):
        for k in got:
            if k not in allowed:
                raise TruthError(f"{src}: unknown key {table}.{k}")
    n = ps.joints
    zeros = [0.0] * n
    sigma_um = probing.get("sigma_um", 0.0)
    if isinstance(sigma_um, bool) or not isinstance(sigma_um, (int, float)):
        raise TruthError(f"{src}: probing.sigma_um must be a number")
    if not (math.isfinite(sigma_um) and sigma_um >= 0):
        raise TruthError(f"{src}: probing.sigma_um must be a finite number >= 0")
    errors = ErrorSources(
        encoder_noise_counts=_six(
            "encoder_noise.sigma_counts", noise.get("sigma_counts", zeros), src, 0.0, n
        ),
        eccentricity_arcsec=_six(
            "eccentricity.amplitude_arcsec", ecc.get("amplitude_arcsec", zeros), src, 0.0, n
        ),
        eccentricity_phase_rad=_six(
            "eccentricity.phase_rad", ecc.get("phase_rad", zeros), src, -math.inf, n
        ),
        probing_sigma_um=float(sigma_um),
        **_harmonics_table(harm, n, src),
    )
    origin = data.get("origin", {})
    arm = dict(data.get("arm", {}))
    for k in arm:
        if k != "serial_number":
            raise TruthError(f"{src}: unknown key arm.{k}")
    serial = arm.get("serial_number")
    if serial is not None and (
        isinstance(serial, bool) or not isinstance(serial, int) or not 0 <= serial <= 0xFFFFFFFF
    ):
        raise TruthError(f"{src}: arm.serial_number must be an integer 0..2^32-1")
    params: Params | Arm
    if ps.is_paper_shape:
        params = Params(ps.theta_offset_rad, ps.alpha_rad, ps.d_mm, ps.a_mm, ps.l_mm)
    else:
        try:
            params = ps.to_arm()[0]
        except ValueError as exc:
            raise TruthError(f"{src}: {exc}") from None
    return Truth[Any](
        params=params,
        encoders=EncoderConfig(ps.counts_per_rev, ps.zero_offset_counts, ps.direction),
        errors=errors,
        origin=dict(origin) if isinstance(origin, dict) else {},
        serial_number=serial,
        thermal=_thermal_table(thermal, n, src),
    )


def _thermal_table(table: dict[str, Any], n: int, src: str) -> ThermalProfile | None:
    """The ``[thermal]`` table (None if absent): N materials, CTEs (1/K), tref (degC)."""
    if not table:
        return None
    material = table.get("material")
    if not (
        isinstance(material, list)
        and len(material) == n
        and all(isinstance(m, str) and m for m in material)
    ):
        raise TruthError(f"{src}: thermal.material must be a list of {n} names")
    cte = _six("thermal.cte_per_k", table.get("cte_per_k"), src, -math.inf, n)
    tref = _six("thermal.tref_c", table.get("tref_c"), src, -math.inf, n)
    try:
        return ThermalProfile(tuple(material), cte, tref)
    except ValueError as exc:
        raise TruthError(f"{src}: thermal: {exc}") from None


def _harmonics_table(harm: dict[str, Any], n: int, src: str) -> dict[str, Any]:
    """The ``[harmonics]`` table's fields of :class:`ErrorSources` (none if absent)."""
    if not harm:
        return {}
    orders = harm.get("order")
    if (
        not isinstance(orders, list)
        or not 1 <= len(orders) <= 3
        or any(isinstance(k, bool) or not isinstance(k, int) or not 2 <= k <= 4 for k in orders)
        or orders != sorted(set(orders))
    ):
        raise TruthError(
            f"{src}: harmonics.order must be increasing orders of 2..4, got {orders!r}"
        )
    rows: dict[str, tuple[tuple[float, ...], ...]] = {}
    for key, lo in (("amplitude_arcsec", 0.0), ("phase_rad", -math.inf)):
        value = harm.get(key)
        if not isinstance(value, list) or len(value) != len(orders):
            raise TruthError(
                f"{src}: harmonics.{key} must be {len(orders)} lists (one per order) of {n} numbers"
            )
        rows[key] = tuple(
            _six(f"harmonics.{key}[{j}]", row, src, lo, n) for j, row in enumerate(value)
        )
    return {
        "harmonic_orders": tuple(orders),
        "harmonic_arcsec": rows["amplitude_arcsec"],
        "harmonic_phase_rad": rows["phase_rad"],
    }
