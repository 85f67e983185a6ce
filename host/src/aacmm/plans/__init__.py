"""Measurement plans: which artefacts to probe, how, and in what order.

A plan is a TOML file (schema ``aacmm-plan-1``, documented in docs/plans.md):
a probe, named artefacts (cone seats, reference spheres, ball bars and
gauges, planes, parts) with their calibrated values, stated uncertainties
and nominal locations, an ordered list of steps (procedures ``cone``,
``sphere``, ``length``, ``articulation``, ``plane``, ``points``), and the
MPEs a verification compares with.

Main names:

* :func:`load_plan` -- a file path or the name of a shipped plan
  (:func:`shipped_plans`), validated; :func:`loads_plan` from text.
* :class:`Plan` -- the artefacts, the steps and :attr:`Plan.slots`, every
  point the plan asks for in order, with its labels (step, position, end A/B,
  articulation, point) and its nominal target.
* :class:`PlanError` -- ``FILE:LINE: FIELD: problem``, one line.

This is a pure library: no printing, no argparse.
"""

from __future__ import annotations

from dataclasses import replace
from importlib import resources
from pathlib import Path

from aacmm.plans._load import PlanError, loads_plan, read_plan_file
from aacmm.plans._slots import PRESET_ISO
from aacmm.plans.model import (
    ARTEFACT_TYPES,
    PLAN_FORMAT,
    PROCEDURE_ARTEFACTS,
    PROCEDURES,
    Artefact,
    ConeSeat,
    EUniMpe,
    LengthPosition,
    LengthStandard,
    Mpe,
    Part,
    Plan,
    Plane,
    PointLabel,
    Probe,
    Slot,
    Sphere,
    Step,
    Target,
    Verification,
)

__all__ = [
    "ARTEFACT_TYPES",
    "PLAN_FORMAT",
    "PRESET_ISO",
    "PROCEDURES",
    "PROCEDURE_ARTEFACTS",
    "Artefact",
    "ConeSeat",
    "EUniMpe",
    "LengthPosition",
    "LengthStandard",
    "Mpe",
    "Part",
    "Plan",
    "PlanError",
    "Plane",
    "PointLabel",
    "Probe",
    "Slot",
    "Sphere",
    "Step",
    "Target",
    "Verification",
    "load_plan",
    "loads_plan",
    "shipped_plan_path",
    "shipped_plans",
]


def shipped_plans() -> tuple[str, ...]:
    """Names of the example plans shipped with aacmm (``iso10360-12``, ...)."""
    folder = resources.files("aacmm") / "data" / "plans"
    return tuple(sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml")))


def shipped_plan_path(name: str) -> Path:
    """The file of a shipped plan (``name`` with or without ``.toml``). Raises KeyError."""
    stem = name[:-5] if name.endswith(".toml") else name
    if stem not in shipped_plans():
        raise KeyError(name)
    return Path(str(resources.files("aacmm") / "data" / "plans" / f"{stem}.toml"))


def load_plan(spec: str | Path) -> Plan:
    """Load a plan from a file, or a shipped plan by name.

    A path that exists is read; otherwise a bare name (no directory part)
    such as ``iso10360-12`` or ``iso10360-12.toml`` names a shipped plan.

    Raises:
        PlanError: no such file or shipped plan, or an invalid plan.
    """
    path = Path(spec)
    if path.exists() or len(path.parts) != 1:
        return read_plan_file(path)
    try:
        path = shipped_plan_path(str(spec))
    except KeyError:
        names = ", ".join(shipped_plans())
        raise PlanError(
            str(spec), None, "", f"no such file, nor a shipped plan (shipped: {names})"
        ) from None
    return replace(read_plan_file(path), name=path.stem)  # named as the user names it
