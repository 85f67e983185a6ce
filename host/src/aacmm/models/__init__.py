"""Arm models: which serial arm the tools compute with (issue 26).

A model is a TOML file (schema ``aacmm-model-1``, documented in
docs/models.md): N revolute joints (4 to 7), each in standard or modified
Denavit-Hartenberg convention with its theta offset, alpha, d, a and an
optional Hayati beta, its joint limits and its encoder; the probe tip in the
last frame; the model's name, description and source, and which of its
figures are assumed rather than published. Models ship with aacmm
(:func:`shipped_models`; ``gao2013``, the paper's arm, is
:data:`DEFAULT_MODEL`); a user's file is read by path.

API:

* :func:`load_model` -- a shipped model by name, or a file by path (a path
  that exists, or any argument with a directory part or a ``.toml``
  suffix), validated; :func:`loads_model` from text.
* :func:`dumps_model` -- a model as ``aacmm-model-1`` TOML text (angles in
  radians, numbers exact) that :func:`loads_model` reads back to an equal
  model: for a model made in code (a calibrated or a random arm).
* :func:`shipped_models` -- the names of the shipped models, sorted;
  :func:`shipped_model_path` the file of one.
* :class:`ArmModel` -- frozen: ``name``, ``description``, ``source``,
  ``notes``, ``arm`` (an :class:`aacmm.arm.Arm`, for
  :class:`aacmm.core.Model`), ``joint_limits_rad`` (N pairs (lowest,
  highest), ``(-inf, inf)`` for none), ``encoders`` (N :class:`Encoder`),
  ``assumed`` (figure names: parameter names as
  :attr:`aacmm.arm.Arm.param_names`, ``convention<j>``, ``limits<j>``,
  ``encoder<j>``), ``calibration_plan`` and ``verification_plan`` (the
  plans that fit the arm: its ``[plans]`` table, default
  :data:`DEFAULT_CALIBRATION_PLAN` and :data:`DEFAULT_VERIFICATION_PLAN`),
  ``file``; :attr:`ArmModel.n_joints`, :attr:`ArmModel.n_params`,
  :attr:`ArmModel.reach_mm`, :meth:`ArmModel.encoder_config` (an
  :class:`aacmm.core.EncoderConfig`), :meth:`ArmModel.within_limits`,
  :meth:`ArmModel.sampling_ranges_rad` (the ranges random poses are drawn in),
  :meth:`ArmModel.to_dict` (JSON-ready).
* :class:`aacmm.errors.ModelError` (here as :class:`ModelError`) -- every
  problem, one line ``FILE:LINE: FIELD: problem``; an :class:`AacmmError`
  and a :class:`ValueError` (exit status 2 in the CLI).

``load_model("gao2013").arm == aacmm.arm.Arm.paper()``, exactly.

This is a pure library: no printing, no argparse.
"""

from __future__ import annotations

from dataclasses import replace
from importlib import resources
from pathlib import Path

from aacmm.errors import ModelError
from aacmm.models._dump import dumps_model
from aacmm.models._load import MAX_MODEL_BYTES, loads_model, read_model_file
from aacmm.models.model import (
    COUNTS_PER_REV_MAX,
    COUNTS_PER_REV_MIN,
    DEFAULT_CALIBRATION_PLAN,
    DEFAULT_MODEL,
    DEFAULT_VERIFICATION_PLAN,
    ENCODER_INTERFACES,
    MODEL_FORMAT,
    ArmModel,
    Encoder,
)

__all__ = [
    "COUNTS_PER_REV_MAX",
    "COUNTS_PER_REV_MIN",
    "DEFAULT_CALIBRATION_PLAN",
    "DEFAULT_MODEL",
    "DEFAULT_VERIFICATION_PLAN",
    "ENCODER_INTERFACES",
    "MAX_MODEL_BYTES",
    "MODEL_FORMAT",
    "ArmModel",
    "Encoder",
    "ModelError",
    "dumps_model",
    "load_model",
    "loads_model",
    "shipped_model_path",
    "shipped_models",
]


def _folder() -> Path:
    return Path(str(resources.files("aacmm") / "data" / "models"))


def shipped_models() -> tuple[str, ...]:
    """Names of the models shipped with aacmm, sorted (``gao2013``, ...)."""
    return tuple(sorted(p.name[:-5] for p in _folder().iterdir() if p.name.endswith(".toml")))


def shipped_model_path(name: str) -> Path:
    """The file of a shipped model (``name`` with or without ``.toml``).

    Raises:
        ModelError: no shipped model of that name.
    """
    stem = name.removesuffix(".toml")
    if stem not in shipped_models():
        raise ModelError(
            name, None, "", f"no such shipped model (shipped: {', '.join(shipped_models())})"
        )
    return _folder() / f"{stem}.toml"


def load_model(spec: str | Path = DEFAULT_MODEL) -> ArmModel:
    """Load a shipped model by name (default: :data:`DEFAULT_MODEL`), or a model file.

    ``spec`` is read as a file if it exists, has a directory part or ends in
    ``.toml``; otherwise it names a shipped model.

    Raises:
        ModelError: no such file or shipped model, or an invalid model.
    """
    path = Path(spec)
    if path.exists() or len(path.parts) != 1 or path.suffix == ".toml":
        if not path.exists():
            raise ModelError(str(spec), None, "", "no such file")
        return read_model_file(path)
    if str(spec) not in shipped_models():
        raise ModelError(
            str(spec),
            None,
            "",
            f"no such file, nor a shipped model (shipped: {', '.join(shipped_models())})",
        )
    model = read_model_file(shipped_model_path(str(spec)))
    if model.name != path.stem:
        raise ModelError(
            str(spec), None, "name", f"a shipped model is named as its file, not {model.name!r}"
        )
    return replace(model, file=None)
