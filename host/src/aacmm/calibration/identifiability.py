"""Which parameters (and combinations) the data can identify.

The SVD of the column-scaled, whitened, nuisance-projected Jacobian decides it
(:func:`analyse`). Each column is divided by the parameter's whole effect on
the probe point (the norm of its unprojected, whitened point-Jacobian column),
so a singular value is the fraction of a direction's effect on the tip that
survives in the residuals: near 1 for a well-observed direction, 0 for one the
nuisance unknowns absorb completely (rotating the arm about axis 1 moves every
tip point, but no seat, length or sphere notices).

Rank is judged with a tolerance scaled to the residuals. A symmetry of the
data (that rotation about axis 1, say) leaves the residuals unchanged only
where they are zero; elsewhere it turns the residual vectors, which gives it a
spurious singular value of about ||r|| / ||p|| (residuals over the tip's lever
from the base: ~1e-3 with the nominal parameters' 1.5 mm open cones, ~1e-6
after calibration). The tolerance is ``kappa`` times that, with a floor of
1e-10 for rounding; identifiable directions of a usable data set sit far above
(~0.1 for 3 cones and 30 lengths on the paper's arm).

Null-space directions are named by comparing them with the symmetries the
model is known to have: rotation about and shift along axis 1 (theta1 offset,
d1), the split of the tip vector between theta6 offset, alpha6, d6, a6 and l
(only the tip's position in the flange frame reaches the probe point: 3
combinations of 5), and global scale (every length multiplied by one factor).
Anything else is reported by its largest parameter components.

Any :class:`~aacmm.arm.Arm` (issue 26) gets the same candidates derived from
its shape: theta1 and d1; for a modified first joint also alpha1 and a1 (its
Rx(alpha1) Tx(a1) come before the first rotation: a rotation about and a
shift along the base x axis); the tip's split between the last joint's
theta offset, the parameters applied after its rotation and the tip
(:func:`~aacmm.calibration.parameters.tip_in_last_frame`: the null space of
that 3 x k map, e.g. the tip's component along the last axis against d_N);
``parallel``: d of two consecutive joints against each other, the position
of the common normal along two parallel axes (exact where the axes are
parallel: Hayati's beta replaces the second d, which the solve then holds);
and scale, every length (d, a, tip). What is left of the null space is
tested against the model itself: a direction that moves no probe point beyond
a rigid motion of the whole arm at any of 64 random poses (every joint over a
full turn) is ``geometry``, a degeneracy of the model that no plan can
observe (desk4's stylus at right angles to its last link makes alpha4 act as
d2 does); only the rest is ``other``, missing from the data.

Observability indices (Borm and Menq; Driels and Pathre; Nahvi and Hollerbach
1996) are computed over the identifiable singular values.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from aacmm.arm import Arm
from aacmm.calibration.parameters import (
    AnyParams,
    CalibParams,
    arm_part,
    n_joints,
    param_names,
    tip_columns,
    tip_in_last_frame,
)
from aacmm.calibration.problem import Evaluation
from aacmm.core import PARAM_NAMES, FloatArray, Model, Params
from aacmm.errmodel import points_jacobians

#: Parameters the 'fix' strategy prefers to hold when they are unobservable
#: (the convention of published AACMM calibrations, and the tip's angles).
PREFERRED_HELD: tuple[str, ...] = ("theta1", "d1", "theta6", "alpha6")
TIP_PARAMS: tuple[str, ...] = ("theta6", "alpha6", "d6", "a6", "l")
DEFAULT_KAPPA = 10.0
RANK_FLOOR = 1e-10
_IN_NULL = 0.02  # a candidate symmetry lies in the null space if <2 % of it sticks out
_COMPONENT_MIN = 0.1
_HARMONIC_HELD = 0.3  # with harmonics: a preferred parameter's least null-space leverage
_GEOMETRY_POSES = 64  # random poses that tell a geometry degeneracy from missing data
_GEOMETRY_SEED = 26


@dataclass(frozen=True)
class NullDirection:
    """One unobservable direction, named.

    ``kind``: ``theta1``, ``d1``, ``tip``, ``scale`` or ``other`` (any arm
    also ``alpha1``, ``a1``: a modified first joint's base motions, and
    ``parallel``: two parallel axes' common normal; ``geometry``: a
    combination that moves no probe point at any pose, a degeneracy of the
    model's geometry found numerically);
    ``components``: (parameter name, weight) with |weight| >= 0.1 in scaled
    units (the direction has unit norm there), largest first; ``vector``
    (P,): the direction in parameter units (rad, mm); ``meaning``: what it
    does to the arm; ``remedy``: which data would make it observable.
    """

    kind: str
    components: tuple[tuple[str, float], ...]
    vector: FloatArray
    meaning: str
    remedy: str

    def describe(self) -> str:
        comps = ", ".join(f"{n} {w:+.2f}" for n, w in self.components)
        return f"{comps}: {self.meaning}; {self.remedy}"


@dataclass(frozen=True)
class Identifiability:
    """The identifiability of the parameters in ``names`` from one data set.

    ``singular_values``: descending, of the column-scaled Jacobian;
    ``tolerance``: the rank threshold used; ``rank``: how many exceed it;
    ``scale`` (len(names),): RMS effect of each parameter on the tip point (mm
    per rad or mm per mm), the column scaling; ``basis`` (len(names), rank)
    and ``null_basis`` (len(names), n - rank): orthonormal identifiable and
    unobservable directions in scaled coordinates; ``null``: the named
    unobservable directions; ``held``: parameters the 'fix' strategy holds at
    their start values so that the rest are identifiable; ``rows``: residual
    rows; ``residual_ratio``: ||r|| / ||p|| (whitened), the scale of the
    tolerance.
    """

    names: tuple[str, ...]
    columns: tuple[int, ...]
    scale: FloatArray
    singular_values: FloatArray
    tolerance: float
    rank: int
    basis: FloatArray
    null_basis: FloatArray
    null: tuple[NullDirection, ...]
    held: tuple[str, ...]
    rows: int
    residual_ratio: float

    @property
    def n(self) -> int:
        return len(self.names)

    @property
    def identifiable_values(self) -> FloatArray:
        return self.singular_values[: self.rank]

    @property
    def condition_number(self) -> float:
        """s_max / s_min over the identifiable singular values (inf if rank 0)."""
        s = self.identifiable_values
        return float(s[0] / s[-1]) if s.size else math.inf

    @property
    def inverse_condition(self) -> float:
        """s_min / s_max (Driels and Pathre)."""
        s = self.identifiable_values
        return float(s[-1] / s[0]) if s.size else 0.0

    @property
    def min_singular_value(self) -> float:
        s = self.identifiable_values
        return float(s[-1]) if s.size else 0.0

    @property
    def o1(self) -> float:
        """(product of the identifiable singular values)^(1/L) / sqrt(m) (Borm and Menq)."""
        s = self.identifiable_values
        if not s.size:
            return 0.0
        return float(np.exp(np.mean(np.log(s))) / math.sqrt(max(self.rows, 1)))

    @property
    def noise_amplification(self) -> float:
        """s_min^2 / s_max (Nahvi and Hollerbach 1996)."""
        s = self.identifiable_values
        return float(s[-1] ** 2 / s[0]) if s.size else 0.0

    @property
    def gap(self) -> float:
        """s_rank / s_(rank+1): how cleanly the spectrum splits (inf if full rank)."""
        s = self.singular_values
        if self.rank == 0 or self.rank >= s.size:
            return math.inf
        return float(s[self.rank - 1] / max(s[self.rank], 1e-300))


def preferred_held(p: AnyParams) -> tuple[str, ...]:
    """The parameters the 'fix' strategy tries first to hold (:data:`PREFERRED_HELD`
    for the paper's arm): the base's (theta1, d1, and alpha1, a1 for a modified
    first joint), then the last joint's tip parameters but the tip itself; with
    encoder harmonics (a :class:`CalibParams`) then the link CTEs (rather than
    the lengths they are confounded with at one temperature), then the
    harmonics, highest order first, rather than a theta offset they are
    confounded with (a joint over a limited range)."""
    if isinstance(p, CalibParams):
        names = p.errors.param_names
        ctes = tuple(n for n in names if n.startswith("cte"))
        order = sorted((n for n in names if "_" in n), key=lambda n: -int(n.split("_")[1]))
        return (*preferred_held(p.arm), *ctes, *order)
    params = p
    if isinstance(params, Params):
        return PREFERRED_HELD
    base = ("theta1", "d1", "alpha1", "a1") if params.joints[0].convention == "modified" else ()
    tip = tuple(n for n in tip_columns(params) if n not in ("l", "tx", "ty", "tz"))
    return (*(base or ("theta1", "d1")), *tip)


def _unit(p: int, k: int) -> FloatArray:
    e = np.zeros(p)
    e[k] = 1.0
    return e


def _arm_symmetries(arm: Arm) -> list[tuple[str, list[FloatArray]]]:
    """The named candidates of a general arm (module doc), parameter units, P each."""
    v = arm.to_vector()
    names = arm.param_names
    p = v.size
    k = {n: i for i, n in enumerate(names)}
    out: list[tuple[str, list[FloatArray]]] = [
        ("theta1", [_unit(p, k["theta1"])]),
        ("d1", [_unit(p, k["d1"])]),
    ]
    if arm.joints[0].convention == "modified":
        out += [("alpha1", [_unit(p, k["alpha1"])]), ("a1", [_unit(p, k["a1"])])]
    _, g = tip_in_last_frame(arm)
    _, sv, vt = np.linalg.svd(g)
    rank = int(np.sum(sv > 1e-9 * max(float(sv[0]), 1e-300)))
    tip = []
    for row in vt[rank:]:
        e = np.zeros(p)
        e[[k[n] for n in tip_columns(arm)]] = row
        tip.append(e)
    out.append(("tip", tip))
    parallel = []
    for j in range(2, arm.n_joints + 1):
        e = np.zeros(p)
        e[k[f"d{j - 1}"]], e[k[f"d{j}"]] = 1.0, -1.0
        parallel.append(e)
    out.append(("parallel", parallel))
    scale = np.where(np.array(arm.param_units) == "mm", v, 0.0)
    out.append(("scale", [scale]))
    return out


def _symmetries(params: AnyParams) -> list[tuple[str, list[FloatArray]]]:
    """Known exact symmetries of point data at ``params`` (parameter units, P each;
    P + E for a :class:`CalibParams`: the arm's, the harmonics not involved)."""
    if isinstance(params, CalibParams):
        pad = params.errors.n_cols
        return [
            (kind, [np.concatenate([v, np.zeros(pad)]) for v in vecs])
            for kind, vecs in _symmetries(params.arm)
        ]
    if isinstance(params, Arm):
        return _arm_symmetries(params)
    v = params.to_vector()
    k = {n: i for i, n in enumerate(PARAM_NAMES)}
    out: list[tuple[str, list[FloatArray]]] = []
    for name in ("theta1", "d1"):
        e = np.zeros(25)
        e[k[name]] = 1.0
        out.append((name, [e]))
    # tip vector in the flange frame: Rz(theta6) (a6, -l sin alpha6, d6 + l cos alpha6)
    th, al, d6, a6, ll = (v[k[n]] for n in TIP_PARAMS)
    ct, st, ca, sa = math.cos(th), math.sin(th), math.cos(al), math.sin(al)
    u = np.array([a6, -ll * sa, d6 + ll * ca])
    rz = np.array([[ct, -st, 0.0], [st, ct, 0.0], [0.0, 0.0, 1.0]])
    drz = np.array([[-st, -ct, 0.0], [ct, -st, 0.0], [0.0, 0.0, 0.0]])
    g = np.column_stack(
        [
            drz @ u,
            rz @ np.array([0.0, -ll * ca, -ll * sa]),
            rz @ np.array([0.0, 0.0, 1.0]),
            rz @ np.array([1.0, 0.0, 0.0]),
            rz @ np.array([0.0, -sa, ca]),
        ]
    )
    _, _, vt = np.linalg.svd(g)
    tip = []
    for row in vt[3:]:
        e = np.zeros(25)
        e[[k[n] for n in TIP_PARAMS]] = row
        tip.append(e)
    out.append(("tip", tip))
    scale = np.zeros(25)
    scale[12:] = v[12:]
    out.append(("scale", [scale]))
    return out


_MEANING = {
    "theta1": (
        "rotation of the whole arm about joint axis 1 (z0): no seat, length, sphere or plane "
        "notices it",
        "observable only from reference points in the arm's base frame (a known base datum)",
    ),
    "d1": (
        "shift of the whole arm along joint axis 1 (z0)",
        "observable only from reference points in the arm's base frame (a known base datum)",
    ),
    "tip": (
        "splits the tip vector between theta6 offset, alpha6, d6, a6 and l without moving the "
        "probe point: only the tip's position in the flange frame (3 combinations) is observable",
        "no probing data can observe it (held by convention)",
    ),
    "scale": (
        "global scale: every length (d, a, l) multiplied by one factor; seats and planes close "
        "at any scale",
        "add a calibrated length (ball bar, gauge), a calibrated sphere, or reference points",
    ),
    "geometry": (
        "moves no probe point at any pose of the arm beyond a motion of the whole arm: a "
        "degeneracy of this model's geometry, not of the data",
        "no probing data can observe it (held at the model's values); a model without it "
        "drops one of its parameters",
    ),
    "thermal": (
        "a link's coefficient of thermal expansion against its lengths: at one link "
        "temperature a CTE only rescales its link's lengths (d, a; the tip for the last link)",
        "calibrate from sessions at link temperatures at least 5 degC apart (aacmm capture "
        "--temperature)",
    ),
    "other": (
        "not a symmetry of the model: the poses do not excite it",
        "add articulations that move these joints more (wider joint ranges, more seats or "
        "lengths at other places in the workspace)",
    ),
}


def _meaning(kind: str, p: AnyParams) -> tuple[str, str]:
    """What a named direction does and what would observe it (for a general arm,
    the tip's parameters by name)."""
    params = arm_part(p)
    if isinstance(params, Params) or kind not in ("tip", "alpha1", "a1", "parallel"):
        return _MEANING[kind]
    if kind == "tip":
        cols = tip_columns(params)
        return (
            f"splits the tip between {', '.join(cols)} without moving the probe point (e.g. "
            f"the tip's component along axis {params.n_joints} against d{params.n_joints}): "
            "only the tip's position in the last joint's frame (3 combinations) is observable",
            "no probing data can observe it (held by convention)",
        )
    if kind == "parallel":
        return (
            "moves the common normal of two parallel axes along them (d of the one joint "
            "against d of the next): a free choice of the model where the axes are parallel",
            "declare a Hayati beta on the second joint (its d is then held)",
        )
    axis = (
        "rotation of the whole arm about the base x axis (x0)"
        if kind == "alpha1"
        else ("shift of the whole arm along the base x axis (x0)")
    )
    return (
        f"{axis}: a modified first joint's {kind} comes before its rotation",
        "observable only from reference points in the arm's base frame (a known base datum)",
    )


def _components(vec_scaled: FloatArray, names: Sequence[str]) -> tuple[tuple[str, float], ...]:
    order = np.argsort(-np.abs(vec_scaled))
    big = vec_scaled[order[0]]
    sign = 1.0 if big >= 0 else -1.0
    return tuple(
        (names[i], float(sign * vec_scaled[i]))
        for i in order
        if abs(vec_scaled[i]) >= _COMPONENT_MIN
    )


def _scaled_orthonormal(
    vecs: list[FloatArray], cols: Sequence[int], scale: FloatArray
) -> list[FloatArray]:
    """One subspace's directions made orthonormal in the scaled coordinates of
    ``cols`` (returned in parameter units), so that none looks like a combination
    of the others once the columns are scaled (the tip's split of a general arm)."""
    if not vecs:
        return vecs
    s = np.column_stack([v[list(cols)] * scale for v in vecs])
    q, r = np.linalg.qr(s)
    keep = np.abs(np.diag(r)) > 1e-12 * max(float(np.abs(r).max()), 1e-300)
    out = []
    for j in np.flatnonzero(keep):
        e = np.zeros(vecs[0].size)
        e[list(cols)] = q[:, j] / scale
        out.append(e)
    return out


def _name_null(
    null: FloatArray,
    scale: FloatArray,
    columns: Sequence[int],
    params: AnyParams,
    tol: float = 0.0,
) -> tuple[NullDirection, ...]:
    """Named directions spanning the null space (scaled coords, columns = ``columns``).

    A known symmetry is reported as itself (pure theta1, every length for
    scale, ...) when it lies in the null space and is independent of those
    already named; of what is left, the directions no probing data can see at
    all (:func:`_geometry_null`, relative effect at most ``tol``) are
    'geometry', the rest orthonormal 'other' directions.
    """
    all_names = param_names(params)
    names = [all_names[c] for c in columns]
    cols = list(columns)
    k = null.shape[1]
    found: list[tuple[str, FloatArray]] = []
    accepted = np.zeros((len(cols), 0))
    for kind, vecs in _symmetries(params):
        if isinstance(arm_part(params), Arm) and kind == "tip":
            vecs = _scaled_orthonormal(vecs, cols, scale)
        for v in vecs:
            if accepted.shape[1] == k:
                break
            s = v[cols] * scale
            nrm = np.linalg.norm(s)
            if nrm < 1e-12 * max(1.0, float(np.linalg.norm(v[cols]))):
                continue  # the symmetry does not involve these parameters
            s = s / nrm
            if np.linalg.norm(s - null @ (null.T @ s)) > _IN_NULL:
                continue
            if accepted.shape[1]:
                q, _ = np.linalg.qr(accepted)
                if np.linalg.norm(s - q @ (q.T @ s)) < 0.1:
                    continue  # a combination of directions already named
            found.append((kind, s))
            accepted = np.column_stack([accepted, s])
    if accepted.shape[1] < k:
        # the rest of the null space, orthogonal to the named directions
        q, _ = np.linalg.qr(accepted) if accepted.shape[1] else (np.zeros((len(cols), 0)), None)
        rest = null - q @ (q.T @ null)
        u = np.linalg.svd(rest, full_matrices=False)[0][:, : k - accepted.shape[1]]
        geometry = _geometry_null(u, scale, cols, params, tol)
        found += [("geometry", d) for d in geometry]
        cte = np.array([n.startswith("cte") for n in names], dtype=bool)
        found += [
            ("thermal" if float(np.linalg.norm(d[cte])) >= 0.5 else "other", d)
            for d in _remainder(u, geometry)
        ]
    out = []
    for kind, s in found:
        vec = np.zeros(len(all_names))
        vec[cols] = s / scale
        meaning, remedy = _meaning(kind, params)
        out.append(NullDirection(kind, _components(s, names), vec, meaning, remedy))
    return tuple(out)


def _point_jacobians(params: AnyParams, theta_rad: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The point Jacobian (3n, P[+E]) at ``theta_rad`` (n, N), and the same with
    what a rigid motion of the whole arm can do removed (what distances, seats
    and spheres cannot tell from a motion of the base)."""
    model = Model(arm_part(params))
    if isinstance(params, CalibParams):
        temps = None
        if params.errors.cte_columns:  # every pose at its own link temperatures
            rng = np.random.default_rng(_GEOMETRY_SEED + 1)
            temps = np.asarray(params.errors.tref_c) + rng.uniform(
                -20.0, 20.0, (theta_rad.shape[0], params.errors.joints)
            )
        pts, jac = points_jacobians(model, params.errors, theta_rad, temps)
    else:
        pts, jac = model.points_jacobians(theta_rad)
    n = pts.shape[0]
    rigid = np.zeros((n, 3, 6))
    rigid[:, :, :3] = np.eye(3)
    for k in range(3):  # rotation about base axis k: e_k x p
        e = np.zeros(3)
        e[k] = 1.0
        rigid[:, :, 3 + k] = np.cross(e, pts)
    q, _ = np.linalg.qr(rigid.reshape(3 * n, 6))
    a = np.asarray(jac, dtype=np.float64).reshape(3 * n, -1)
    return a, a - q @ (q.T @ a)


def _geometry_null(
    rest: FloatArray, scale: FloatArray, cols: Sequence[int], params: AnyParams, tol: float
) -> list[FloatArray]:
    """The directions of ``rest`` (scaled coordinates of ``cols``, orthonormal
    columns) that move no probe point beyond a rigid motion of the whole arm at
    any pose: over :data:`_GEOMETRY_POSES` random poses (every joint uniform in
    [-pi, pi), fixed seed) their effect, as a fraction of the parameters' whole
    effect there (unit columns, as :func:`analyse` scales the data's), is at
    most ``max(tol, RANK_FLOOR)``. Such a direction is a degeneracy of the
    model's geometry (desk4's stylus at right angles to its last link: alpha4
    against the d of a parallel hinge), not a shortcoming of the data: no plan
    can observe it, and holding it changes no measurement. Returned in the same
    scaled coordinates, unit norm."""
    if rest.shape[1] == 0:
        return []
    rng = np.random.default_rng(_GEOMETRY_SEED)
    theta = rng.uniform(-math.pi, math.pi, (_GEOMETRY_POSES, n_joints(params)))
    raw, free = _point_jacobians(params, theta)
    whole = np.linalg.norm(raw[:, list(cols)], axis=0)
    if np.any(whole <= 0):
        return []
    b = free[:, list(cols)] / whole
    # rest in parameter units, then in the workspace's normalised coordinates
    t, _ = np.linalg.qr((rest / scale[:, None]) * whole[:, None])
    _, sv, vt = np.linalg.svd(b @ t, full_matrices=True)
    sv_full = np.zeros(t.shape[1])
    sv_full[: sv.size] = sv
    out = []
    for j in np.flatnonzero(sv_full <= max(tol, RANK_FLOOR)):
        d = (t @ vt[j]) / whole * scale
        out.append(d / np.linalg.norm(d))
    return out


def _remainder(u: FloatArray, named: Sequence[FloatArray]) -> list[FloatArray]:
    """Orthonormal directions of span(``u``) orthogonal to ``named``."""
    k = u.shape[1] - len(named)
    if k <= 0:
        return []
    if named:
        q, _ = np.linalg.qr(np.column_stack(named))
        u = u - q @ (q.T @ u)
    left = np.linalg.svd(u, full_matrices=False)[0]
    return [left[:, j] for j in range(k)]


def _held(
    null: FloatArray, names: Sequence[str], preferred: Sequence[str] = PREFERRED_HELD
) -> tuple[str, ...]:
    """Parameters to hold so that the rest are identifiable (``null``: scaled basis)."""
    k = null.shape[1]
    if k == 0:
        return ()
    lev = np.linalg.norm(null, axis=1)
    order = [names.index(n) for n in preferred if n in names]
    order += [i for i in np.argsort(-lev, kind="stable") if i not in order]
    chosen: list[int] = []
    for i in order:
        if len(chosen) == k:
            break
        trial = [*chosen, i]
        smin = np.linalg.svd(null[trial], compute_uv=False)[-1]
        if smin > 0.1 * max(lev[i], 1e-300) and smin > 1e-6:
            chosen = trial
    if len(chosen) < k:  # fall back: pivoted selection by leverage alone
        chosen = [int(i) for i in np.argsort(-lev, kind="stable")[:k]]
    return tuple(names[i] for i in sorted(chosen))


def analyse(
    ev: Evaluation,
    columns: Sequence[int] | None = None,
    kappa: float = DEFAULT_KAPPA,
) -> Identifiability:
    """Identifiability of the parameters ``columns`` (default all P: 25 for the
    paper's arm) at ``ev``.

    Raises ValueError for an empty or bad column list.
    """
    all_names = param_names(ev.params)
    p = len(all_names)
    cols = tuple(range(p)) if columns is None else tuple(int(c) for c in columns)
    if not cols or min(cols) < 0 or max(cols) >= p or len(set(cols)) != len(cols):
        raise ValueError(f"columns must be distinct parameter indices 0..{p - 1}")
    names = tuple(all_names[c] for c in cols)
    raw = np.sqrt(ev.raw_norm2[list(cols)])
    if np.any(raw <= 0):
        dead = [n for n, r in zip(names, raw, strict=True) if r <= 0]
        raise ValueError(f"no probe point depends on {', '.join(dead)}")
    a = ev.jac[:, list(cols)] / raw
    m = a.shape[0]
    if m > 4 * a.shape[1]:
        a = np.asarray(np.linalg.qr(a, mode="r"))  # same singular values, small SVD
    _, s, vt = np.linalg.svd(a, full_matrices=True)
    s_full = np.zeros(len(cols))
    s_full[: s.size] = s
    v = vt.T
    # ||r|| over the tip's whitened lever from the base origin
    sig = ev.pose_sigma
    w = np.where(sig > 0, 1.0 / np.where(sig > 0, sig, 1.0) ** 2, 0.0)
    lever = float(np.sqrt(np.sum(w * np.einsum("na,na->n", ev.points, ev.points))))
    ratio = float(np.linalg.norm(ev.r) / lever) if lever > 0 else 0.0
    smax = float(s_full[0]) if s_full.size else 0.0
    tol = max(RANK_FLOOR * smax, kappa * ratio)
    rank = int(np.sum(s_full > tol))
    basis, null = v[:, :rank], v[:, rank:]
    scale = raw / math.sqrt(float(w.sum()))
    named = _name_null(null, scale, cols, ev.params, tol)
    preferred = preferred_held(ev.params)
    if isinstance(ev.params, CalibParams) and ev.params.errors.n_cols and null.shape[1]:
        # with harmonics a preferred parameter is held only where it is mostly in the
        # null space itself (else one barely in it, chosen first, blocks the others)
        lev = dict(zip(names, np.linalg.norm(null, axis=1), strict=True))
        preferred = tuple(n for n in preferred if lev.get(n, 0.0) >= _HARMONIC_HELD)
    return Identifiability(
        names,
        cols,
        scale,
        s_full,
        tol,
        rank,
        basis,
        null,
        named,
        _held(null, list(names), preferred),
        m,
        ratio,
    )
