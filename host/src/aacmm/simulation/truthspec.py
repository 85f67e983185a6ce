"""``aacmm sim --truth SPEC``: the truth a specification names.

:func:`parse_truth` reads it for the paper's arm (``nominal``,
``random:SEED`` of an encoder grade, or a truth file), :func:`parse_model_truth`
for an arm model
(:mod:`aacmm.models`): ``nominal``, ``random:SEED``
(:func:`aacmm.simulation.truth.model_truth`, of an encoder grade) or a truth
file, which :func:`check_truth_model` refuses when its arm is not of the
model's shape (:func:`arm_shape`: joint count, conventions, betas, tip kind).
docs/simulator.md, "A true arm".
"""

from __future__ import annotations

from typing import Any

from aacmm.arm import Arm
from aacmm.core import Params
from aacmm.models import ArmModel
from aacmm.simulation.encgrade import DEFAULT_GRADE
from aacmm.simulation.truth import (
    ErrorSources,
    Truth,
    TruthError,
    load_truth,
    model_truth,
    nominal_truth,
    random_truth,
)


def parse_truth(spec: str, cpr: int = 1 << 32, grade: str = DEFAULT_GRADE) -> Truth:
    """``--truth SPEC``: ``nominal``, ``random:SEED`` (its encoders of ``grade``)
    or a truth file path.

    Raises:
        TruthError: a bad seed or a bad file.
        EncoderGradeError: an unknown grade.
    """
    if spec == "nominal":
        return nominal_truth(cpr=cpr)
    if spec.startswith("random:"):
        text = spec[len("random:") :]
        if not text.isdigit():
            raise TruthError(f"--truth {spec}: the seed must be a non-negative integer")
        return random_truth(int(text), cpr=cpr, grade=grade)
    return load_truth(spec)


def arm_shape(params: Params | Arm) -> tuple[int, tuple[str, ...], tuple[int, ...], str]:
    """What a truth's arm and a model must share: N, the conventions, the joints
    (0-based) with a beta, the tip kind (the paper's Params: six standard, none, z)."""
    arm = params.to_arm() if isinstance(params, Params) else params
    return (
        arm.n_joints,
        tuple(j.convention for j in arm.joints),
        arm.beta_joints,
        arm.tip,
    )


def check_truth_model(truth: Truth[Any], model: ArmModel, src: str = "truth") -> None:
    """Refuse a truth whose arm is not of ``model``'s shape (:func:`arm_shape`).

    Raises:
        TruthError: one line naming both (joints and parameters, or the first difference).
    """
    got, want = arm_shape(truth.params), arm_shape(model.arm)
    if got == want:
        return
    p = truth.params.to_arm() if isinstance(truth.params, Params) else truth.params
    if got[0] != want[0] or p.n_params != model.n_params:
        what = f"an arm of {got[0]} joints and {p.n_params} parameters"
    elif got[1] != want[1]:
        what = "an arm of other joint conventions"
    elif got[2] != want[2]:
        what = f"an arm with betas on joints {[j + 1 for j in got[2]]}"
    else:
        what = f"an arm with a tip of kind {got[3]!r}"
    raise TruthError(
        f"{src}: {what}, not of the model {model.name} ({model.n_joints} joints, "
        f"{model.n_params} parameters)"
    )


def parse_model_truth(spec: str, model: ArmModel, grade: str = DEFAULT_GRADE) -> Truth[Any]:
    """``--truth SPEC`` for an arm model: ``nominal`` (its nominal arm and encoders,
    no error source), ``random:SEED`` (:func:`~aacmm.simulation.truth.model_truth`,
    its encoders of ``grade``) or a truth file of the model's shape
    (:func:`check_truth_model`).

    Raises:
        TruthError: a bad seed, a bad file, or a truth of another shape.
        EncoderGradeError: an unknown grade.
    """
    if spec == "nominal":
        n = model.n_joints
        return Truth[Any](
            params=model.arm,
            encoders=model.encoder_config(),
            errors=ErrorSources.none(n),
            origin={"kind": "nominal", "model": model.name},
        )
    if spec.startswith("random:"):
        text = spec[len("random:") :]
        if not text.isdigit():
            raise TruthError(f"--truth {spec}: the seed must be a non-negative integer")
        return model_truth(int(text), model, grade=grade)
    truth = load_truth(spec)
    check_truth_model(truth, model, spec)
    return truth
