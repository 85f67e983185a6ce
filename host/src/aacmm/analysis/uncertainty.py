"""Probe-point uncertainty from structural-parameter uncertainties.

Two methods, side by side:

* **Monte Carlo** (JCGM 101, GUM Supplement 1): draw every parameter from its
  distribution (normal, uniform, triangular, arcsine), build one model per
  trial with the firmware's C core and compute the probe point at each pose;
  the spread of the points is the uncertainty, the 2.5 % and 97.5 % quantiles
  give the probabilistically symmetric 95 % coverage interval.
* **Linear propagation** (GUM, law of propagation of uncertainty):
  Sigma_p = J Sigma_q J^T with the 3x25 Jacobian at the nominal parameters;
  the parameters are independent, so u^2(p_r) = sum_k J_rk^2 u_k^2, and the
  95 % interval is +-1.96 u (normal output assumed).

Their agreement is judged as in JCGM 101 section 8 (the endpoints of the two
95 % intervals differ by at most the numerical tolerance delta for ``ndig``
significant digits of u) and by the ratio of the standard uncertainties. The
budget ranks each parameter's share of the variance, sum_r J_rk^2 u_k^2.

Input: :func:`load_spec` reads a TOML file (format in docs/montecarlo.md and
:func:`parse_spec`). Entry point: :func:`propagate`; reports:
:func:`format_report`, :func:`to_json`.

Errors: ValueError (:class:`SpecError` for the file) for unknown parameter
names, negative or non-finite uncertainties, unknown distributions or units,
bad poses; KinematicsError (a ValueError) if a perturbed arm is invalid.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from aacmm.core import (
    AXES,
    JAC_COLS,
    JOINTS,
    PARAM_GROUPS,
    PARAM_NAMES,
    PARAM_UNITS,
    FloatArray,
    Model,
    Params,
    perturbed_points,
)
from aacmm.errors import AacmmError
from aacmm.fileio import InputFileError, load_toml, loads_toml

ANGLE_UNITS: dict[str, float] = {
    "rad": 1.0,
    "mrad": 1e-3,
    "urad": 1e-6,
    "deg": math.pi / 180.0,
    "arcmin": math.pi / 10800.0,
    "arcsec": math.pi / 648000.0,
}
LENGTH_UNITS: dict[str, float] = {"mm": 1.0, "um": 1e-3}
#: Distribution -> standard uncertainty of a tolerance (half-width) a, as u = a * factor.
TOLERANCE_FACTOR: dict[str, float] = {
    "uniform": 1.0 / math.sqrt(3.0),
    "triangular": 1.0 / math.sqrt(6.0),
    "arcsine": 1.0 / math.sqrt(2.0),
    "normal": 0.5,  # tolerance taken as an expanded uncertainty with k = 2 unless k is given
}
DISTRIBUTIONS: tuple[str, ...] = ("normal", "uniform", "triangular", "arcsine")
#: 95 % coverage factor of a normal distribution.
K95 = 1.959963984540054
DEFAULT_TRIALS = 100_000
DEFAULT_WORKSPACE = 100
_POSE_BLOCK = 16  # poses per block at most ...
_BLOCK_VALUES = 2_000_000  # ... and trials x poses per block at most (memory ~ 100 MB)


class SpecError(AacmmError, ValueError):
    """The parameter-uncertainty file is unreadable or invalid."""


@dataclass(frozen=True)
class ParamUncertainty:
    """Standard uncertainty ``u`` (rad or mm) of one parameter and its distribution."""

    name: str
    u: float
    distribution: str = "normal"

    def __post_init__(self) -> None:
        if self.name not in PARAM_NAMES:
            raise ValueError(
                f"unknown parameter name {self.name!r} "
                f"(expected theta1..6, alpha1..6, d1..6, a1..6 or l)"
            )
        if not math.isfinite(self.u) or self.u < 0:
            raise ValueError(f"{self.name}: uncertainty must be finite and >= 0, got {self.u}")
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(
                f"{self.name}: unknown distribution {self.distribution!r} "
                f"(one of {', '.join(DISTRIBUTIONS)})"
            )

    def sample(self, rng: np.random.Generator, m: int) -> FloatArray:
        """``m`` zero-mean draws with standard deviation ``u``."""
        u = self.u
        if u == 0.0:
            return np.zeros(m)
        if self.distribution == "normal":
            return u * rng.standard_normal(m)
        if self.distribution == "uniform":
            a = u * math.sqrt(3.0)
            return rng.uniform(-a, a, m)
        if self.distribution == "triangular":
            a = u * math.sqrt(6.0)
            return rng.triangular(-a, 0.0, a, m)
        a = u * math.sqrt(2.0)  # arcsine on [-a, a]
        return a * np.sin(2.0 * math.pi * rng.random(m))


@dataclass(frozen=True)
class UncertaintySpec:
    """Nominal arm, one :class:`ParamUncertainty` per parameter (25), and poses (k, 6) rad.

    ``covariance`` (25, 25; rad, mm), optional: correlated normal parameters
    (a calibration's result, :meth:`from_covariance`) instead of independent
    ones; the items then carry the standard uncertainties sqrt(diag).
    """

    params: Params
    items: tuple[ParamUncertainty, ...]
    poses_rad: FloatArray = field(default_factory=lambda: np.empty((0, JOINTS)))
    covariance: FloatArray | None = None

    def __post_init__(self) -> None:
        if tuple(i.name for i in self.items) != PARAM_NAMES:
            raise ValueError("items must list the 25 parameters in PARAM_NAMES order")
        p = np.asarray(self.poses_rad, dtype=np.float64).reshape(-1, JOINTS)
        object.__setattr__(self, "poses_rad", p)
        if self.covariance is not None:
            c = np.asarray(self.covariance, dtype=np.float64)
            if c.shape != (JAC_COLS, JAC_COLS) or not np.all(np.isfinite(c)):
                raise ValueError("covariance must be a finite 25 x 25 matrix")
            if not np.allclose(c, c.T, rtol=1e-9, atol=1e-300):
                raise ValueError("covariance must be symmetric")
            if np.linalg.eigvalsh(c)[0] < -1e-9 * max(float(np.abs(c).max()), 1e-300):
                raise ValueError("covariance must be positive semi-definite")
            object.__setattr__(self, "covariance", c)

    @classmethod
    def from_covariance(
        cls, covariance: FloatArray, params: Params, poses_rad: FloatArray | None = None
    ) -> UncertaintySpec:
        """Spec of correlated normal parameters with covariance (25, 25) about ``params``."""
        u = np.sqrt(np.clip(np.diag(np.asarray(covariance, dtype=np.float64)), 0.0, None))
        return cls(
            params,
            tuple(ParamUncertainty(n, float(u[k])) for k, n in enumerate(PARAM_NAMES)),
            np.empty((0, JOINTS)) if poses_rad is None else poses_rad,
            covariance,
        )

    def covariance_matrix(self) -> FloatArray:
        """The (25, 25) covariance: the given one, or diag(u^2) for independent parameters."""
        if self.covariance is not None:
            return self.covariance
        return np.diag(self.u_vector() ** 2)

    @classmethod
    def from_u(
        cls, u: Mapping[str, float], params: Params | None = None, distribution: str = "normal"
    ) -> UncertaintySpec:
        """Spec from {name: u}, names as :data:`PARAM_NAMES` or groups (theta, alpha, d, a)."""
        vals = {n: 0.0 for n in PARAM_NAMES}
        for k, v in u.items():
            for n in _expand(k):
                vals[n] = float(v)
        return cls(
            params or Params(),
            tuple(ParamUncertainty(n, vals[n], distribution) for n in PARAM_NAMES),
        )

    def u_vector(self) -> FloatArray:
        """Standard uncertainties (25,) in Jacobian column order (rad, mm)."""
        return np.array([i.u for i in self.items], dtype=np.float64)


def _expand(name: str) -> tuple[str, ...]:
    if name in PARAM_NAMES:
        return (name,)
    if name in PARAM_GROUPS[:4]:
        return tuple(f"{name}{i}" for i in range(1, JOINTS + 1))
    raise ValueError(
        f"unknown parameter name {name!r} (expected theta1..6, alpha1..6, d1..6, "
        f"a1..6, l, or a group theta, alpha, d, a)"
    )


_TOP_KEYS = {"angle_unit", "length_unit", "pose_unit", "nominal", "parameters", "poses"}
_ENTRY_KEYS = {"u", "tolerance", "distribution", "k"}


def parse_spec(doc: Mapping[str, Any]) -> UncertaintySpec:
    """Build a spec from a parsed TOML document.

    Keys: ``angle_unit`` (rad, mrad, urad, deg, arcmin, arcsec; default rad)
    and ``length_unit`` (mm, um; default mm) for the uncertainties;
    ``pose_unit`` (rad or deg; default deg) for ``poses``, a list of
    six-angle lists; ``[nominal]`` with :class:`aacmm.core.Params` fields
    (default: paper Table 1); ``[parameters]`` with one table per parameter
    or group: ``{u = ..., distribution = ...}`` (standard uncertainty) or
    ``{tolerance = ..., distribution = ..., k = ...}`` (half-width;
    u = a/sqrt(3) uniform, a/sqrt(6) triangular, a/sqrt(2) arcsine, a/k
    normal with k = 2 by default). A joint entry (``d3``) overrides its group
    (``d``) whatever the order.

    Raises SpecError for anything else.
    """
    try:
        return _parse(doc)
    except SpecError:
        raise
    except (ValueError, TypeError, KeyError) as e:
        raise SpecError(str(e)) from e


def _parse(doc: Mapping[str, Any]) -> UncertaintySpec:
    unknown = set(doc) - _TOP_KEYS
    if unknown:
        raise SpecError(
            f"unknown key(s) {', '.join(sorted(unknown))} (allowed: {', '.join(sorted(_TOP_KEYS))})"
        )
    au = str(doc.get("angle_unit", "rad"))
    lu = str(doc.get("length_unit", "mm"))
    pu = str(doc.get("pose_unit", "deg"))
    if au not in ANGLE_UNITS:
        raise SpecError(f"unknown angle_unit {au!r} (one of {', '.join(ANGLE_UNITS)})")
    if lu not in LENGTH_UNITS:
        raise SpecError(f"unknown length_unit {lu!r} (one of {', '.join(LENGTH_UNITS)})")
    if pu not in ("rad", "deg"):
        raise SpecError(f"unknown pose_unit {pu!r} (rad or deg)")
    nominal = Params(**doc.get("nominal", {}))
    nominal.validate()
    entries = doc.get("parameters", {})
    if not isinstance(entries, Mapping) or not entries:
        raise SpecError("no [parameters] table: give at least one parameter uncertainty")
    # groups first, then single parameters, so a joint entry overrides its group
    ordered = sorted(entries.items(), key=lambda kv: kv[0] in PARAM_NAMES)
    items: dict[str, ParamUncertainty] = {n: ParamUncertainty(n, 0.0) for n in PARAM_NAMES}
    for key, entry in ordered:
        names = _expand(str(key))
        if not isinstance(entry, Mapping):
            raise SpecError(f"{key}: expected a table like {{ u = 1.0 }}")
        bad = set(entry) - _ENTRY_KEYS
        if bad:
            raise SpecError(
                f"{key}: unknown key(s) {', '.join(sorted(bad))} "
                f"(allowed: {', '.join(sorted(_ENTRY_KEYS))})"
            )
        dist = str(entry.get("distribution", "normal" if "u" in entry else "uniform"))
        if dist not in DISTRIBUTIONS:
            raise SpecError(
                f"{key}: unknown distribution {dist!r} (one of {', '.join(DISTRIBUTIONS)})"
            )
        if ("u" in entry) == ("tolerance" in entry):
            raise SpecError(
                f"{key}: give exactly one of u (standard uncertainty) or tolerance (half-width)"
            )
        raw = float(entry["u"] if "u" in entry else entry["tolerance"])
        if not math.isfinite(raw) or raw < 0:
            raise SpecError(f"{key}: uncertainty must be finite and >= 0, got {raw}")
        if "tolerance" in entry:
            if dist == "normal":
                k = float(entry.get("k", 2.0))
                if not math.isfinite(k) or k <= 0:
                    raise SpecError(f"{key}: coverage factor k must be > 0, got {k}")
                raw /= k
            else:
                if "k" in entry:
                    raise SpecError(f"{key}: k applies only to a normal tolerance")
                raw *= TOLERANCE_FACTOR[dist]
        elif "k" in entry:
            raise SpecError(f"{key}: k applies only to a tolerance")
        for n in names:
            scale = (
                ANGLE_UNITS[au] if PARAM_UNITS[PARAM_NAMES.index(n)] == "rad" else LENGTH_UNITS[lu]
            )
            items[n] = ParamUncertainty(n, raw * scale, dist)
    poses = (
        np.asarray(doc.get("poses", []), dtype=np.float64).reshape(-1, JOINTS)
        if doc.get("poses")
        else np.empty((0, JOINTS))
    )
    if pu == "deg":
        poses = np.radians(poses)
    if poses.size and (not np.all(np.isfinite(poses)) or np.max(np.abs(poses)) > 1024.0):
        raise SpecError("poses must be finite joint angles")
    return UncertaintySpec(nominal, tuple(items[n] for n in PARAM_NAMES), poses)


#: The name :func:`load_spec` takes for the packaged example spec.
EXAMPLE_SPEC = "example"


def load_spec(path: str | Path) -> UncertaintySpec:
    """Read and parse a parameter-uncertainty TOML file (see :func:`parse_spec`).

    ``"example"`` (:data:`EXAMPLE_SPEC`) is the packaged example
    (``aacmm/data/example_uncertainty.toml``), as ``aacmm uncertainty example``.

    Raises SpecError if the file cannot be read, is not TOML, or is invalid.
    """
    p = Path(path)
    try:  # bounded nesting: a hostile file is one clear error, not a RecursionError
        if isinstance(path, str) and path == EXAMPLE_SPEC:
            src = resources.files("aacmm").joinpath("data", "example_uncertainty.toml")
            doc = loads_toml(src.read_text(encoding="utf-8"), str(p))
        else:
            doc = load_toml(p)
    except InputFileError as e:
        raise SpecError(str(e)) from None
    try:
        return parse_spec(doc)
    except SpecError as e:
        raise SpecError(f"{p}: {e}") from e


# --------------------------------------------------------------------------
# Propagation
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class PoseResult:
    """Uncertainty of the probe point at one pose (mm; deviations from the nominal point).

    ``u_lin``/``u_mc``: standard uncertainty per axis (3,); ``bias_mc``: MC
    mean minus nominal point; ``ci_lin``/``ci_mc`` (3, 2): 95 % coverage
    intervals of the deviation; ``u3_*``: sqrt(u_x^2 + u_y^2 + u_z^2);
    ``r95_mc``: 95 % quantile of the distance to the nominal point;
    ``contrib`` (25,): variance contributions sum_r J_rk^2 u_k^2 (mm^2);
    ``valid``: JCGM 101 section 8 agreement at tolerance ``delta`` (3,).
    """

    theta_rad: FloatArray
    point_mm: FloatArray
    u_lin: FloatArray
    u_mc: FloatArray
    bias_mc: FloatArray
    ci_lin: FloatArray
    ci_mc: FloatArray
    u3_lin: float
    u3_mc: float
    r95_mc: float
    contrib: FloatArray
    delta: FloatArray
    valid: bool


@dataclass(frozen=True)
class BudgetEntry:
    """One parameter's place in the budget (averaged over the analysed poses).

    ``u``: its standard uncertainty (rad or mm); ``sensitivity``: RMS over
    poses of ||J[:, k]|| (mm per rad or mm per mm); ``contribution_mm``:
    sqrt of its mean variance contribution; ``share``: fraction of the total.
    With correlated parameters a contribution (J Sigma J^T split by parameter)
    can be negative: its sign is kept on ``contribution_mm`` and ``share``.
    """

    name: str
    unit: str
    u: float
    sensitivity: float
    contribution_mm: float
    share: float


@dataclass(frozen=True)
class UncertaintyResult:
    """Result of :func:`propagate` over ``poses`` (given poses, then workspace poses)."""

    spec: UncertaintySpec
    trials: int
    seed: int
    ndig: int
    poses: tuple[PoseResult, ...]
    n_given: int
    budget: tuple[BudgetEntry, ...]
    group_shares: dict[str, float]
    elapsed_s: float

    @property
    def given(self) -> tuple[PoseResult, ...]:
        """Results at the poses given explicitly."""
        return self.poses[: self.n_given]

    @property
    def workspace(self) -> tuple[PoseResult, ...]:
        """Results at the random workspace poses."""
        return self.poses[self.n_given :]

    def ratio_range(self) -> tuple[float, float]:
        """Min and max of u_mc / u_lin over all poses and axes (u_lin > 0)."""
        r = np.concatenate([p.u_mc[p.u_lin > 0] / p.u_lin[p.u_lin > 0] for p in self.poses])
        return float(r.min()), float(r.max())

    def valid_fraction(self) -> float:
        """Fraction of poses where the JCGM 101 section 8 check passes."""
        return float(np.mean([p.valid for p in self.poses]))


def _delta(u: FloatArray, ndig: int) -> FloatArray:
    out = np.zeros_like(u)
    nz = u > 0
    out[nz] = 0.5 * 10.0 ** (np.floor(np.log10(u[nz])) - ndig + 1)
    return out


def draw_deltas(spec: UncertaintySpec, trials: int, seed: int) -> FloatArray:
    """Parameter deviations (trials, 25) drawn from the spec's distributions."""
    rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed)))
    if spec.covariance is not None:  # correlated normal: x = L z with L L^T = covariance
        lam, vec = np.linalg.eigh(spec.covariance)
        root = vec * np.sqrt(np.clip(lam, 0.0, None))
        return np.asarray(rng.standard_normal((trials, JAC_COLS)) @ root.T)
    out = np.zeros((trials, JAC_COLS))
    for k, item in enumerate(spec.items):
        if item.u > 0:
            out[:, k] = item.sample(rng, trials)
    return out


def propagate(
    spec: UncertaintySpec,
    trials: int = DEFAULT_TRIALS,
    workspace: int = DEFAULT_WORKSPACE,
    seed: int = 0,
    ndig: int = 1,
    threads: int | None = None,
    workspace_seed: int | None = None,
) -> UncertaintyResult:
    """Propagate the parameter uncertainties to the probe point, both ways.

    At the spec's poses and at ``workspace`` random poses (all joints uniform
    in [-pi, pi)), with ``trials`` Monte Carlo draws (the same draws for every
    pose). ``ndig`` sets the JCGM 101 section 8 tolerance. ``threads``
    splits the trials (default: all cores).

    Raises ValueError for trials < 2, workspace < 0, no pose at all, ndig < 1,
    a bad seed, or threads < 1; KinematicsError if a drawn arm is invalid
    (an uncertainty far too large for the parameter limits).
    """
    for name, v, lo in (
        ("trials", trials, 2),
        ("workspace", workspace, 0),
        ("ndig", ndig, 1),
        ("seed", seed, 0),
    ):
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise ValueError(f"{name} must be an integer >= {lo}, got {v!r}")
    nt = max(1, os.cpu_count() or 1) if threads is None else threads
    if isinstance(nt, bool) or not isinstance(nt, int) or nt < 1:
        raise ValueError(f"threads must be a positive integer, got {threads!r}")
    ws_seed = seed + 1 if workspace_seed is None else workspace_seed
    ws = np.random.default_rng(ws_seed).uniform(-math.pi, math.pi, (workspace, JOINTS))
    poses = np.concatenate([spec.poses_rad, ws])
    if poses.shape[0] == 0:
        raise ValueError("no poses: give poses in the spec or a workspace size > 0")
    t0 = time.perf_counter()
    u = spec.u_vector()
    model = Model(spec.params)
    p_nom, jac = model.points_jacobians(poses)
    # J Sigma J^T split by parameter: J_ak (Sigma J^T)_ka, which is J_ak^2 u_k^2 for
    # independent parameters and sums to the variance with correlations too
    split = jac * (jac @ spec.covariance_matrix())  # (n, 3, 25)
    contrib_all = split.sum(axis=1)  # (n, 25): sum over axes
    var_lin = split.sum(axis=2)  # (n, 3)
    deltas = draw_deltas(spec, trials, seed)
    parts = np.array_split(np.arange(trials), nt)
    results: list[PoseResult] = []

    def run(args: tuple[FloatArray, FloatArray]) -> FloatArray:
        d, th = args
        return perturbed_points(spec.params, d, th)

    with ThreadPoolExecutor(max_workers=nt) as ex:
        pb = max(1, min(_POSE_BLOCK, _BLOCK_VALUES // trials))
        for b in range(0, poses.shape[0], pb):
            th = poses[b : b + pb]
            pts = np.concatenate(list(ex.map(run, [(deltas[idx], th) for idx in parts])))
            # deviations as (k, 3, trials): every statistic runs along the
            # contiguous last axis (quantiles across a strided axis are slow)
            dev = np.ascontiguousarray(pts.transpose(1, 2, 0))
            dev -= p_nom[b : b + pb][:, :, None]
            u_mc = dev.std(axis=2, ddof=1)
            bias = dev.mean(axis=2)
            q = np.quantile(dev, [0.025, 0.975], axis=2)  # (2, k, 3)
            r95 = np.quantile(np.sqrt(np.einsum("kat,kat->kt", dev, dev)), 0.95, axis=1)
            for j in range(th.shape[0]):
                i = b + j
                ul = np.sqrt(var_lin[i])
                ci_l = np.stack([-K95 * ul, K95 * ul], axis=1)
                ci_m = q[:, j, :].T.copy()
                delta = _delta(ul, ndig)
                ok = bool(np.all(np.abs(ci_l - ci_m) <= delta[:, None]))
                results.append(
                    PoseResult(
                        poses[i].copy(),
                        p_nom[i].copy(),
                        ul,
                        u_mc[j].copy(),
                        bias[j].copy(),
                        ci_l,
                        ci_m,
                        float(np.sqrt(var_lin[i].sum())),
                        float(np.sqrt((u_mc[j] ** 2).sum())),
                        float(r95[j]),
                        contrib_all[i].copy(),
                        delta,
                        ok,
                    )
                )
    mean_contrib = contrib_all.mean(axis=0)
    total = float(mean_contrib.sum())
    sens = np.sqrt((jac**2).sum(axis=1).mean(axis=0))  # RMS column norm (25,)
    budget = sorted(
        (
            BudgetEntry(
                n,
                PARAM_UNITS[k],
                float(u[k]),
                float(sens[k]),
                float(math.copysign(math.sqrt(abs(mean_contrib[k])), mean_contrib[k])),
                float(mean_contrib[k] / total) if total > 0 else 0.0,
            )
            for k, n in enumerate(PARAM_NAMES)
        ),
        key=lambda e: -e.share,
    )
    groups = {g: 0.0 for g in PARAM_GROUPS}
    for e in budget:
        groups[e.name.rstrip("0123456789")] += e.share
    return UncertaintyResult(
        spec,
        trials,
        seed,
        ndig,
        tuple(results),
        spec.poses_rad.shape[0],
        tuple(budget),
        groups,
        time.perf_counter() - t0,
    )


# --------------------------------------------------------------------------
# Reports
# --------------------------------------------------------------------------


def _fmt_unit(e: BudgetEntry) -> str:
    if e.unit == "rad":
        return f"{e.u / ANGLE_UNITS['arcsec']:.3g} arcsec"
    return f"{e.u * 1e3:.3g} um"


def format_report(res: UncertaintyResult, top: int = 10, pose_rows: int = 8) -> str:
    """Terminal report: per-pose table (given poses), workspace summary, budget."""
    um = 1e3
    lines = [
        f"Probe-point uncertainty: Monte Carlo (JCGM 101, {res.trials} trials) vs "
        f"linear J Sigma J^T (GUM); values in um; 95 % intervals of the deviation",
        f"agreement: JCGM 101 sec. 8 check with {res.ndig} significant digit(s) of u_lin",
    ]
    shown = list(res.given) or list(res.workspace[:pose_rows])
    title = "given poses" if res.given else f"first {len(shown)} workspace poses"
    lines += [
        "",
        f"{title}:",
        f"{'pose (deg)':>34} {'ax':>2} {'u_lin':>8} {'u_mc':>8} {'ratio':>6} "
        f"{'bias_mc':>8} {'95% lin':>19} {'95% mc':>19} ok",
    ]
    for p in shown:
        pose = ",".join(f"{math.degrees(t):.0f}" for t in p.theta_rad)
        for r, ax in enumerate(AXES):
            ratio = p.u_mc[r] / p.u_lin[r] if p.u_lin[r] > 0 else float("nan")
            lines.append(
                f"{pose if r == 0 else '':>34} {ax:>2} {p.u_lin[r] * um:8.3f} "
                f"{p.u_mc[r] * um:8.3f} {ratio:6.3f} {p.bias_mc[r] * um:+8.3f} "
                f"[{p.ci_lin[r, 0] * um:+8.3f},{p.ci_lin[r, 1] * um:+8.3f}] "
                f"[{p.ci_mc[r, 0] * um:+8.3f},{p.ci_mc[r, 1] * um:+8.3f}] "
                + ("yes" if r == 0 and p.valid else ("NO" if r == 0 else ""))
            )
        lines.append(
            f"{'':>34} 3D u_lin {p.u3_lin * um:.3f}, u_mc {p.u3_mc * um:.3f}, "
            f"95 % of MC points within {p.r95_mc * um:.3f} of nominal"
        )
    ws = res.workspace
    if ws:
        ul = np.array([p.u_lin for p in ws])
        umc = np.array([p.u_mc for p in ws])
        lines += [
            "",
            f"workspace ({len(ws)} random poses, joints uniform in [-180, 180) deg):",
            "  RMS u per axis (x, y, z), linear: "
            + ", ".join(f"{v * um:.3f}" for v in np.sqrt((ul**2).mean(axis=0)))
            + "; Monte Carlo: "
            + ", ".join(f"{v * um:.3f}" for v in np.sqrt((umc**2).mean(axis=0))),
            f"  3D u: median {np.median([p.u3_mc for p in ws]) * um:.3f}, "
            f"max {max(p.u3_mc for p in ws) * um:.3f}; 95 % radius: median "
            f"{np.median([p.r95_mc for p in ws]) * um:.3f}, "
            f"max {max(p.r95_mc for p in ws) * um:.3f}",
        ]
    lo, hi = res.ratio_range()
    lines.append(
        f"agreement over all {len(res.poses)} poses: u_mc/u_lin in [{lo:.4f}, {hi:.4f}]"
        f", JCGM 101 sec. 8 check passed at {100 * res.valid_fraction():.0f} % of poses"
    )
    lines += [
        "",
        f"budget (mean over the {len(res.poses)} poses; share of the 3D variance):",
        f"  {'param':<8} {'u':>14} {'sens (mm/unit)':>15} {'contrib um':>11} {'share':>8}",
    ]
    for e in res.budget[:top]:
        lines.append(
            f"  {e.name:<8} {_fmt_unit(e):>14} {e.sensitivity:15.3f} "
            f"{e.contribution_mm * um:11.3f} {100 * e.share:7.2f}%"
        )
    g = res.group_shares
    ang = g["theta"] + g["alpha"]
    lines += [
        "  groups: " + ", ".join(f"{k} {100 * v:.2f}%" for k, v in g.items()),
        f"  => angles (alpha, theta): {100 * ang:.1f} % of the variance; "
        f"lengths (d, a, l): {100 * (1 - ang):.1f} %"
        + (" -- alpha and theta dominate, as the paper concludes" if ang > 0.5 else ""),
        f"compute: {res.elapsed_s:.2f} s",
    ]
    return "\n".join(lines)


def to_json(res: UncertaintyResult) -> dict[str, Any]:
    """A JSON-ready dict (mm and rad)."""

    def pose(p: PoseResult) -> dict[str, Any]:
        return {
            "theta_rad": p.theta_rad.tolist(),
            "point_mm": p.point_mm.tolist(),
            "u_lin_mm": p.u_lin.tolist(),
            "u_mc_mm": p.u_mc.tolist(),
            "bias_mc_mm": p.bias_mc.tolist(),
            "ci95_lin_mm": p.ci_lin.tolist(),
            "ci95_mc_mm": p.ci_mc.tolist(),
            "u3_lin_mm": p.u3_lin,
            "u3_mc_mm": p.u3_mc,
            "r95_mc_mm": p.r95_mc,
            "jcgm101_delta_mm": p.delta.tolist(),
            "agree": p.valid,
        }

    lo, hi = res.ratio_range()
    return {
        "trials": res.trials,
        "seed": res.seed,
        "ndig": res.ndig,
        "uncertainties": {
            i.name: {"u": i.u, "unit": PARAM_UNITS[k], "distribution": i.distribution}
            for k, i in enumerate(res.spec.items)
        },
        "given_poses": [pose(p) for p in res.given],
        "workspace_poses": [pose(p) for p in res.workspace],
        "agreement": {"ratio_min": lo, "ratio_max": hi, "valid_fraction": res.valid_fraction()},
        "budget": [
            {
                "name": e.name,
                "unit": e.unit,
                "u": e.u,
                "sensitivity": e.sensitivity,
                "contribution_mm": e.contribution_mm,
                "share": e.share,
            }
            for e in res.budget
        ],
        "group_shares": res.group_shares,
        "elapsed_s": res.elapsed_s,
    }


def pose_list(values: Sequence[Sequence[float]], unit: str = "deg") -> FloatArray:
    """Poses (k, 6) in rad from lists of six angles in ``unit`` (deg or rad).

    Raises ValueError unless every pose has six finite angles.
    """
    a = np.asarray(values, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != JOINTS or not np.all(np.isfinite(a)):
        raise ValueError(f"each pose needs {JOINTS} finite joint angles")
    return np.radians(a) if unit == "deg" else a
