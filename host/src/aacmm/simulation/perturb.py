"""The perturbation of a random simulated truth (``--truth random:SEED``,
docs/simulator.md): :class:`RandomSizes`, the documented :data:`RANDOM_SIZES`,
and :func:`perturbed` (a nominal arm's every structural parameter off by a
uniform draw). :func:`aacmm.simulation.truth.random_truth` uses them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np

from aacmm.arm import Arm
from aacmm.core import Params


@dataclass(frozen=True)
class RandomSizes:
    """Perturbation sizes of :func:`random_truth` (uniform on +-size unless stated;
    the encoders' harmonics are an encoder grade's, :mod:`aacmm.simulation.encgrade`)."""

    length_mm: float = 0.5  #: d, a (each joint) and l (an arm: each tip component)
    angle_deg: float = 0.05  #: alpha and theta offset of each joint (an arm: each beta too)
    encoder_noise_arcsec: float = 0.3  #: sigma of the encoder noise (same on every joint)
    probing_sigma_um: float = 2.0  #: probing noise sigma per axis


#: The documented sizes of ``--truth random:SEED`` (docs/simulator.md).
RANDOM_SIZES: Final = RandomSizes()


def perturbed(
    nominal: Params | Arm, rng: np.random.Generator, sizes: RandomSizes = RANDOM_SIZES
) -> Params | Arm:
    """Every structural parameter of ``nominal`` off by a uniform draw: angles
    (theta offsets, alphas) by +-angle_deg, lengths (d, a, tip) by +-length_mm;
    an arm's declared betas by +-angle_deg, drawn last (so an arm of the
    paper's shape draws what its Params form draws)."""
    ang = math.radians(sizes.angle_deg)
    if isinstance(nominal, Params):
        delta = np.concatenate(
            [
                rng.uniform(-ang, ang, 12),  # theta offsets, alpha
                rng.uniform(-sizes.length_mm, sizes.length_mm, 13),  # d, a, l
            ]
        )
        return Params.from_vector(nominal.to_vector() + delta)
    n, b = nominal.n_joints, len(nominal.beta_joints)
    lengths = nominal.n_params - 2 * n - b
    angles = rng.uniform(-ang, ang, 2 * n)
    mm = rng.uniform(-sizes.length_mm, sizes.length_mm, lengths)
    betas = rng.uniform(-ang, ang, b)
    # column order: thetas, alphas, ds, as, betas, tip
    delta = np.concatenate([angles, mm[: 2 * n], betas, mm[2 * n :]])
    return nominal.with_vector(nominal.to_vector() + delta)
