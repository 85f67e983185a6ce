"""What a perfect arm with isotropic probing noise should report: the predicted
distributions of the verification figures, derived here from the noise model
and the plan's nominal geometry (not from aacmm.verification).

Probing noise: the probe-ball centre sits N(0, sigma^2) per axis away from its
target, independently at every point (docs/simulator.md, "Truth"). For a sphere
fit only the radial component matters to first order, so the residuals are
``(I - H) e`` and the radius error ``((J^T J)^-1 J^T e)[3]`` with
``J = [n_i, 1]`` (n_i the nominal probing directions, H its hat matrix): linear
algebra of the design, sampled by Monte Carlo for the range statistics.
Single-point articulation: sum |p_i - mean|^2 / sigma^2 is chi-square with
3 (n - 1) degrees of freedom. A length between two seats: error
u.(e_B - e_A), normal with variance 2 sigma^2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from aacmm.plans import Plan
from aacmm.verification import smallest_enclosing_sphere
from scipy import stats

DRAWS = 4000
#: two-sided tail probability of the acceptance band
TAIL = 0.001


@dataclass
class Band:
    """The central (1 - TAIL) interval of a predicted distribution."""

    lo: float
    hi: float
    what: str

    def check(self, value: float) -> None:
        assert self.lo <= value <= self.hi, (
            f"{self.what}: {value:.6f} mm outside the predicted [{self.lo:.6f}, {self.hi:.6f}] mm"
        )


def _band(samples: np.ndarray, what: str) -> Band:
    lo, hi = np.quantile(samples, [TAIL / 2, 1 - TAIL / 2])
    return Band(float(lo), float(hi), what)


def _directions(plan: Plan, step_id: str) -> np.ndarray:
    slots = plan.step_slots(step_id)
    out = []
    for s in slots:
        assert s.target is not None
        d = np.subtract(s.target.tip_mm, s.target.feature_mm)
        out.append(d / np.linalg.norm(d))
    return np.array(out)


def _sphere_linear(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of (J^T J)^-1 J^T for the radius, and I - H, for directions n (k, 3)."""
    j = np.c_[n, np.ones(len(n))]
    pinv = np.linalg.pinv(j)
    return pinv, np.eye(len(n)) - j @ pinv


def sphere_bands(
    plan: Plan, step_id: str, sigma: float, rng: np.random.Generator
) -> tuple[Band, Band]:
    """Predicted bands of D - D_cal (size error) and of the form of one sphere step."""
    n = _directions(plan, step_id)
    pinv, resid = _sphere_linear(n)
    e = rng.normal(scale=sigma, size=(DRAWS, len(n)))  # radial components
    size = 2.0 * (e @ pinv[3])
    form = np.ptp(e @ resid.T, axis=1)
    return _band(size, f"{step_id} size error"), _band(form, f"{step_id} form")


def location_band(
    plan: Plan, step_id: str, sigma: float, rng: np.random.Generator, fixed: bool = False
) -> Band:
    """Predicted band of L_Dia: the centres of the articulations' 5-point fits scatter
    as (J^T J)^-1 J^T of their radial noise (J = [n, 1], or [n] with the radius held:
    ``fixed``); the smallest sphere around them."""
    slots = plan.step_slots(step_id)
    n = _directions(plan, step_id)
    groups: dict[int, list[int]] = {}
    for k, s in enumerate(slots):
        assert s.articulation_index is not None
        groups.setdefault(s.articulation_index, []).append(k)
    maps = [np.linalg.pinv(n[g]) if fixed else _sphere_linear(n[g])[0][:3] for g in groups.values()]
    out = np.empty(DRAWS)
    for t in range(DRAWS):
        centres = np.array([-(m @ rng.normal(scale=sigma, size=m.shape[1])) for m in maps])
        out[t] = 2.0 * smallest_enclosing_sphere(centres)[1]
    return _band(out, f"{step_id} L_Dia")


def seat_bands(n_points: int, sigma: float, rng: np.random.Generator) -> tuple[Band, Band]:
    """Predicted bands of 2 sigma (chi-square, exact) and of max (max-min)/2 per axis."""
    dof = 3 * (n_points - 1)
    lo, hi = stats.chi2.ppf([TAIL / 2, 1 - TAIL / 2], dof)
    two = Band(
        2 * sigma * float(np.sqrt(lo / (n_points - 1))),
        2 * sigma * float(np.sqrt(hi / (n_points - 1))),
        "seat 2 sigma",
    )
    p = rng.normal(scale=sigma, size=(DRAWS, n_points, 3))
    half = np.max(np.ptp(p, axis=1) / 2, axis=1)
    return two, _band(half, "seat (max-min)/2")


def length_bands(n_lengths: int, sigma: float, rng: np.random.Generator) -> tuple[Band, Band]:
    """Seat-ended lengths: bands of the largest |error| and of the rms error."""
    e = rng.normal(scale=sigma * np.sqrt(2.0), size=(DRAWS, n_lengths))
    worst = np.max(np.abs(e), axis=1)
    lo, hi = stats.chi2.ppf([TAIL / 2, 1 - TAIL / 2], n_lengths)
    rms = Band(
        sigma * np.sqrt(2.0 * lo / n_lengths),
        sigma * np.sqrt(2.0 * hi / n_lengths),
        "rms length error",
    )
    return _band(worst, "largest |length error|"), rms
