"""Writing a model as TOML (schema ``aacmm-model-1``) that loads back to the same model."""

from __future__ import annotations

import math

from aacmm.models.model import (
    DEFAULT_CALIBRATION_PLAN,
    DEFAULT_VERIFICATION_PLAN,
    MODEL_FORMAT,
    ArmModel,
)


def _string(s: str) -> str:
    """A TOML basic string: quote, backslash and control characters escaped."""
    out = []
    for ch in s:
        if ch in ('"', "\\"):
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _num(x: float) -> str:
    """A float as TOML, exactly (repr round-trips; inf as TOML's inf)."""
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(float(x))


def _list(xs: list[str]) -> str:
    return "[" + ", ".join(xs) + "]"


def dumps_model(model: ArmModel) -> str:
    """The model as an ``aacmm-model-1`` TOML text.

    Angles are written in radians (``_rad`` fields) and every number with
    ``repr``, so :func:`aacmm.models.loads_model` gives back an equal model
    (text fields as the loader keeps them: without leading and trailing blanks;
    ``file`` is not part of the text). Every joint carries its own encoder
    table and its assumed figures; a ``[plans]`` table is written when the
    model's plans are not the default ones.
    """
    lines = [
        f"format = {_string(MODEL_FORMAT)}",
        f"name = {_string(model.name)}",
        f"description = {_string(model.description)}",
        f"source = {_string(model.source)}",
    ]
    if model.notes:
        lines.append(f"notes = {_string(model.notes)}")
    arm = model.arm
    tip_assumed = any(t in model.assumed for t in ("l", "tx", "ty", "tz"))
    lines += [
        "",
        "[tip]",
        f"kind = {_string(arm.tip)}",
        f"vector_mm = {_list([_num(t) for t in arm.tip_mm])}",
    ]
    if tip_assumed:
        lines.append('assumed = ["vector_mm"]')
    if (model.calibration_plan, model.verification_plan) != (
        DEFAULT_CALIBRATION_PLAN,
        DEFAULT_VERIFICATION_PLAN,
    ):
        lines += [
            "",
            "[plans]",
            f"calibration = {_string(model.calibration_plan)}",
            f"verification = {_string(model.verification_plan)}",
        ]
    figures = (
        ("convention", "convention"),
        ("theta", "theta_offset"),
        ("alpha", "alpha"),
        ("d", "d_mm"),
        ("a", "a_mm"),
        ("beta", "beta"),
        ("limits", "limits"),
        ("encoder", "encoder"),
    )
    for i, (j, (lo, hi), e) in enumerate(
        zip(arm.joints, model.joint_limits_rad, model.encoders, strict=True)
    ):
        k = i + 1
        lines += [
            "",
            "[[joints]]",
            f"convention = {_string(j.convention)}",
            f"theta_offset_rad = {_num(j.theta_offset_rad)}",
            f"alpha_rad = {_num(j.alpha_rad)}",
            f"d_mm = {_num(j.d_mm)}",
            f"a_mm = {_num(j.a_mm)}",
        ]
        if j.beta_rad is not None:
            lines.append(f"beta_rad = {_num(j.beta_rad)}")
        lines.append(f"limits_rad = {_list([_num(lo), _num(hi)])}")
        marked = [field for fig, field in figures if f"{fig}{k}" in model.assumed]
        if marked:
            lines.append(f"assumed = {_list([_string(m) for m in marked])}")
        lines += [
            "[joints.encoder]",
            f"counts_per_rev = {e.counts_per_rev}",
            f"zero_offset_counts = {e.zero_offset_counts}",
            f"direction = {e.direction}",
            f"interface = {_string(e.interface)}",
        ]
    return "\n".join(lines) + "\n"
