"""Residuals and their Jacobian with every nuisance unknown eliminated.

:class:`Problem` compiles an :class:`~aacmm.calibration.observations.Observations`
once; :meth:`Problem.evaluate` then gives, for one parameter set, the whitened
residual vector and its Jacobian with respect to the arm's P parameters (25 for
the paper's arm; any :class:`~aacmm.arm.Arm` as well; a
:class:`~aacmm.calibration.parameters.CalibParams` adds its E encoder-harmonic
columns, from :func:`aacmm.errmodel.points_jacobians`, and with link CTE
columns their N), the probe points and Jacobians coming from the C core in one
batch call (analytic, no finite differences; one per link temperature when the
observations state temperatures: an error model is evaluated at the pose's
temperature, the arm alone has no thermal model).

Nuisance unknowns (a seat's centre, a sphere's centre and radius, a plane, a
registration, the true value of an uncertain length) are eliminated by
variable projection: for the current arm parameters each is set to its exact
least-squares value, and the Jacobian rows are projected onto the orthogonal
complement of the nuisance columns, ``(I - Q Q^T) J``. The projected Jacobian's
normal matrix is the Schur complement of the full problem's, so rank,
singular values and covariance are those of the joint problem (Golub and
Pereyra 1973; Kaufman 1975 for the step). For a seat (linear in its centre)
the projection is exact: the points are centred on their weighted mean.

Each residual row carries its standard uncertainty (to undo the whitening), its
leverage with respect to the nuisance unknowns (``h``, for normalised residuals
and the degrees of freedom), and a *unit*: the rows tested together for an
outlier (a cone point's 3 rows, a length position's row, ...).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aacmm.calibration.features import (
    BlockResult,
    CalibrationError,
    ballbar_block,
    ballbar_order,
    ballbar_rows,
    plane_block,
    reference_block,
    reference_sigma,
    sphere_block,
    sphere_rows,
)
from aacmm.calibration.observations import (
    Cone,
    LengthSet,
    Observations,
    Plane,
    ReferencePoints,
    Sphere,
)
from aacmm.calibration.parameters import AnyParams, arm_part, error_model, n_joints
from aacmm.core import JAC_COLS, FloatArray, KinematicsError, Model
from aacmm.errmodel import ErrorModel
from aacmm.errmodel import points as em_points
from aacmm.errmodel import points_jacobians as em_points_jacobians

__all__ = ["CalibrationError", "Evaluation", "Problem", "Residuals", "Unit"]

KIND_CONE = "cone"
KIND_LENGTH = "length"
KIND_REFERENCE = "reference"
KIND_SPHERE = "sphere"
KIND_PLANE = "plane"
KIND_BALL_END = "ball end"
IntArray = npt.NDArray[np.intp]


@dataclass(frozen=True)
class Unit:
    """Rows tested together for an outlier: one probed point or one length position."""

    constraint: int
    kind: str
    poses: tuple[int, ...]
    position: int = -1  # length position within its set, else -1


@dataclass
class Residuals:
    """The whitened residuals (m,) at one parameter set, with the tip points (n, 3)."""

    params: AnyParams
    r: FloatArray
    points: FloatArray
    nuisance: dict[int, dict[str, FloatArray]] = field(default_factory=dict)

    @property
    def chi2(self) -> float:
        return float(self.r @ self.r)


@dataclass
class Evaluation(Residuals):
    """Residuals and projected Jacobian (m, P) at one parameter set (P = 25 for the paper's arm;
    P + E for a :class:`~aacmm.calibration.parameters.CalibParams`).

    ``sigma`` (m,): standard uncertainty of each row (residual in mm = r * sigma);
    ``h`` (m,): leverage of the row on the nuisance unknowns; ``unit`` (m,):
    index of the row's unit (:meth:`Problem.unit`; -1 for prior rows);
    ``point_jac`` (n, 3, P): tip Jacobians of every pose;
    ``raw_norm2`` (P,): sum over the poses used of ||dp/dq_k||^2 / sigma^2;
    ``pose_sigma`` (n,): probing uncertainty of each pose a constraint uses (0
    for unused poses); ``nuisance``: fitted nuisance values of references,
    spheres and planes by constraint index.
    """

    jac: FloatArray = field(default_factory=lambda: np.zeros((0, JAC_COLS)))
    sigma: FloatArray = field(default_factory=lambda: np.zeros(0))
    h: FloatArray = field(default_factory=lambda: np.zeros(0))
    unit: IntArray = field(default_factory=lambda: np.zeros(0, np.intp))
    point_jac: FloatArray = field(default_factory=lambda: np.zeros((0, 3, JAC_COLS)))
    raw_norm2: FloatArray = field(default_factory=lambda: np.zeros(JAC_COLS))
    pose_sigma: FloatArray = field(default_factory=lambda: np.zeros(0))


def _end_means(ends: list[IntArray], positions: int, poses: int) -> sp.csr_matrix:
    """(positions, poses): row k averages the poses of end ``ends[k]``."""
    rows = np.repeat(np.arange(positions, dtype=np.intp), [e.size for e in ends])
    cols = np.concatenate(ends) if ends else np.zeros(0, dtype=np.intp)
    vals = np.concatenate([np.full(e.size, 1.0 / e.size) for e in ends]) if ends else np.zeros(0)
    return sp.csr_matrix((vals, (rows, cols)), shape=(positions, poses))


@dataclass(frozen=True)
class _Other:
    """A reference, sphere or plane constraint and where its rows go."""

    ci: int
    c: ReferencePoints | Sphere | Plane | LengthSet
    rows: slice
    sigma: FloatArray  # per point


@dataclass
class _Layout:
    """The residual rows and outlier units laid out so far, in row order.

    Per row: its standard uncertainty, its unit, its static leverage; per
    unit: its constraint, kind, first pose and length position. Filled by the
    ``_lay_out_*`` steps of :class:`Problem`, read once by :meth:`finish`.
    """

    rows: int = 0
    units: int = 0
    nuisance: int = 0
    row_sigma: list[FloatArray] = field(default_factory=list)
    row_unit: list[IntArray] = field(default_factory=list)
    row_leverage: list[FloatArray] = field(default_factory=list)
    unit_constraint: list[IntArray] = field(default_factory=list)
    unit_kind: list[str] = field(default_factory=list)
    unit_kind_count: list[int] = field(default_factory=list)
    unit_pose: list[IntArray] = field(default_factory=list)
    unit_position: list[IntArray] = field(default_factory=list)

    def add_rows(
        self, count: int, sigma: FloatArray, unit: npt.ArrayLike, leverage: FloatArray
    ) -> slice:
        """Reserve ``count`` rows with their uncertainties, units and leverages."""
        rows = slice(self.rows, self.rows + count)
        self.rows += count
        self.row_sigma.append(sigma)
        self.row_unit.append(np.asarray(unit, dtype=np.intp))
        self.row_leverage.append(leverage)
        return rows

    def add_units(
        self, kind: str, constraint: IntArray, pose: IntArray, position: npt.ArrayLike
    ) -> None:
        """Append ``constraint.size`` units of one kind (first pose, length position each)."""
        count = int(constraint.size)
        self.unit_constraint.append(constraint.astype(np.intp))
        self.unit_kind.append(kind)
        self.unit_kind_count.append(count)
        self.unit_pose.append(pose.astype(np.intp))
        self.unit_position.append(np.asarray(position, dtype=np.intp))
        self.units += count


class Problem:
    """The compiled observations: index tables built once, evaluated per parameter set.

    Rows are laid out once: every seat point's 3 rows, then the calibrated
    lengths (exact ones first, then each uncertain length set followed by its
    prior row), then each reference, sphere and plane block.

    Raises ObservationError (from :meth:`Observations.validate`) for bad data.
    """

    def __init__(self, obs: Observations) -> None:
        obs.validate()
        self.obs = obs
        self._index_used_poses()
        layout = _Layout()
        self._lay_out_seats(layout)
        self._lay_out_lengths(layout)
        self._lay_out_uncertain_lengths(layout)
        self._lay_out_blocks(layout)
        self._finish(layout)
        self._sphere_state: dict[int, FloatArray] = {}

    # ------------------------------------------------------------------ layout steps

    def _index_used_poses(self) -> None:
        """Which poses some constraint uses, and their probing uncertainty (0 elsewhere)."""
        used = np.zeros(self.obs.n_poses, dtype=bool)
        for c in self.obs.constraints:
            used[c.poses] = True
        self.used = np.flatnonzero(used)
        self.all_used = bool(used.all())
        self.pose_sigma = np.where(used, self.obs.sigma_mm, 0.0)

    def _lay_out_seats(self, layout: _Layout) -> None:
        """Every seat point's 3 rows; a sparse matrix gives each seat's weighted mean.

        The seat's centre (3 nuisance unknowns, linear) is eliminated exactly by
        centring its points on their weighted mean; a point's leverage is its
        share of the seat's weight.
        """
        obs = self.obs
        seats = [(i, c) for i, c in enumerate(obs.constraints) if isinstance(c, Cone)]
        entry_pose = (
            np.concatenate([c.poses for _, c in seats]) if seats else np.zeros(0, dtype=np.intp)
        )
        seat_sizes = np.array([c.poses.size for _, c in seats], dtype=np.intp)
        seat_of_entry = np.repeat(np.arange(len(seats)), seat_sizes)
        weight = 1.0 / obs.sigma_mm[entry_pose] ** 2
        seat_weight = np.bincount(seat_of_entry, weights=weight, minlength=len(seats))
        share = weight / seat_weight[seat_of_entry] if entry_pose.size else weight
        n = entry_pose.size
        self.cone_pose = entry_pose
        self.cone_gid = seat_of_entry
        self.cone_sq = np.sqrt(weight)
        self.cone_avg = sp.csr_matrix((share, (seat_of_entry, np.arange(n))), shape=(len(seats), n))
        first = int(entry_pose[0]) if n else 0
        contiguous = n and np.array_equal(entry_pose, np.arange(first, first + n))
        self.cone_slice = slice(first, first + n) if contiguous else None
        self.cone_rows = layout.add_rows(
            3 * n,
            np.repeat(obs.sigma_mm[entry_pose], 3),
            np.repeat(layout.units + np.arange(n), 3),
            np.repeat(share, 3),
        )
        seat_index = np.array([i for i, _ in seats], dtype=np.intp)
        layout.add_units(KIND_CONE, np.repeat(seat_index, seat_sizes), entry_pose, np.full(n, -1))
        layout.nuisance += 3 * len(seats)

    def _lay_out_lengths(self, layout: _Layout) -> None:
        """The calibrated lengths (not ball-ended): averaging matrices for the two ends
        of every position, their uncertainties, and the rows of the exact ones."""
        obs = self.obs
        self.len_sets = [
            (i, c)
            for i, c in enumerate(obs.constraints)
            if isinstance(c, LengthSet) and not c.ball_ends
        ]
        positions = [
            (i, c, p, ea, eb)
            for i, c in self.len_sets
            for p, (ea, eb) in enumerate(zip(c.ends_a, c.ends_b, strict=True))
        ]
        self.len_ends: list[tuple[IntArray, IntArray]] = [(ea, eb) for *_, ea, eb in positions]
        k = len(positions)
        self.n_len = k
        self.mean_a = _end_means([ea for ea, _ in self.len_ends], k, obs.n_poses)
        self.mean_b = _end_means([eb for _, eb in self.len_ends], k, obs.n_poses)
        self.len_target = np.array([c.length_mm for _, c, *_ in positions])
        var = obs.sigma_mm**2
        self.len_sigma = np.sqrt(
            self.mean_a.multiply(self.mean_a) @ var + self.mean_b.multiply(self.mean_b) @ var
        )
        self.len_unit0 = layout.units
        exact = np.array([c.u_length_mm == 0 for _, c, *_ in positions], dtype=bool)
        self.len_exact = np.flatnonzero(exact)
        self.len_exact_rows = layout.add_rows(
            self.len_exact.size,
            self.len_sigma[self.len_exact],
            layout.units + self.len_exact,
            np.zeros(self.len_exact.size),
        )
        layout.nuisance += sum(1 for _, c in self.len_sets if c.u_length_mm > 0)
        # the units are laid out now, the rows of the uncertain ones next
        layout.add_units(
            KIND_LENGTH,
            np.array([i for i, *_ in positions], dtype=np.intp),
            np.array([int(ea[0]) for *_, ea, _ in positions], dtype=np.intp),
            np.array([p for _, _, p, _, _ in positions], dtype=np.intp),
        )

    def _lay_out_uncertain_lengths(self, layout: _Layout) -> None:
        """Each uncertain length set: its positions' rows and the prior row of its true
        length (a nuisance unknown shared by the positions)."""
        self.len_prior: list[tuple[LengthSet, IntArray, slice]] = []
        start = 0
        for _i, c in self.len_sets:
            sel = np.arange(start, start + len(c.ends_a))
            start += sel.size
            if c.u_length_mm == 0:
                continue
            sk = self.len_sigma[sel]
            wk = 1.0 / sk**2
            total = wk.sum() + 1.0 / c.u_length_mm**2
            rows = layout.add_rows(
                sel.size + 1,
                np.append(sk, c.u_length_mm),
                np.append(self.len_unit0 + sel, -1),
                np.append(wk / total, 1.0 / (c.u_length_mm**2 * total)),
            )
            self.len_prior.append((c, sel, rows))

    def _lay_out_blocks(self, layout: _Layout) -> None:
        """References, spheres, planes and ball-ended lengths: one block of rows each,
        its leverages filled per evaluation."""
        self.others: list[_Other] = []
        for i, c in enumerate(self.obs.constraints):
            if isinstance(c, Cone):
                continue
            block = self._block_rows(c, layout.units)
            if block is None:
                continue
            kind, sigma, rows_sigma, rows_unit, poses, positions, nuisance = block
            rows = layout.add_rows(
                rows_sigma.size, rows_sigma, rows_unit, np.zeros(rows_sigma.size)
            )
            self.others.append(_Other(i, c, rows, sigma))
            layout.add_units(kind, np.full(poses.size, i, dtype=np.intp), poses, positions)
            layout.nuisance += nuisance

    def _block_rows(
        self, c: LengthSet | ReferencePoints | Sphere | Plane, unit0: int
    ) -> tuple[str, FloatArray, FloatArray, IntArray, IntArray, IntArray, int] | None:
        """A block constraint's kind, per-point sigma, row sigmas and units, unit poses
        and positions, and nuisance count; ``None`` for a plain (not ball-ended) length."""
        sigma_mm = self.obs.sigma_mm
        if isinstance(c, LengthSet) and c.ball_ends:
            poses, position = ballbar_order(c)
            s = sigma_mm[poses]
            units = unit0 + np.arange(poses.size)
            row_sigma = s
            if ballbar_rows(c) > poses.size:  # the length prior's row
                row_sigma, units = np.append(s, c.u_length_mm), np.append(units, -1)
            nuisance = 5 * len(c.ends_a) + (1 if c.u_length_mm > 0 else 0)
            return KIND_BALL_END, s, row_sigma, units, poses, position, nuisance
        if isinstance(c, LengthSet):
            return None
        no_position = np.full(c.poses.size, -1, dtype=np.intp)
        points = unit0 + np.arange(c.poses.size)
        if isinstance(c, ReferencePoints):
            s = reference_sigma(c, sigma_mm)
            nuisance = 0 if c.base_known else 6
            return (
                KIND_REFERENCE,
                s,
                np.repeat(s, 3),
                np.repeat(points, 3),
                c.poses,
                no_position,
                nuisance,
            )
        if isinstance(c, Sphere):
            s = sigma_mm[c.poses]
            row_sigma, units = s, points
            if sphere_rows(c) > c.poses.size:  # the radius prior's row
                row_sigma, units = np.append(s, c.u_radius_mm), np.append(points, -1)
            nuisance = 4 if (c.free_radius or c.u_radius_mm > 0) else 3
            return KIND_SPHERE, s, row_sigma, units, c.poses, no_position, nuisance
        s = sigma_mm[c.poses]
        return KIND_PLANE, s, s, points, c.poses, no_position, 3

    def _finish(self, layout: _Layout) -> None:
        """The per-row and per-unit tables as arrays."""
        self.m = layout.rows
        self.n_nuisance = layout.nuisance
        self.n_units = layout.units
        self.sigma = np.concatenate(layout.row_sigma)
        self.unit_of_row = np.concatenate(layout.row_unit).astype(np.intp)
        self.h_static = np.concatenate(layout.row_leverage)
        self.unit_constraint = np.concatenate(layout.unit_constraint).astype(np.intp)
        self.unit_kind = np.repeat(np.array(layout.unit_kind, dtype=object), layout.unit_kind_count)
        self.unit_pose = np.concatenate(layout.unit_pose).astype(np.intp)
        self.unit_position = np.concatenate(layout.unit_position).astype(np.intp)

    def unit(self, i: int) -> Unit:
        """The unit ``i``: its constraint, kind and poses."""
        kind = str(self.unit_kind[i])
        if kind == KIND_LENGTH:
            ea, eb = self.len_ends[i - self.len_unit0]
            poses = (*ea.tolist(), *eb.tolist())
        else:
            poses = (int(self.unit_pose[i]),)
        return Unit(int(self.unit_constraint[i]), kind, poses, int(self.unit_position[i]))

    # ------------------------------------------------------------------ evaluation

    def _model(self, params: AnyParams) -> tuple[Model, ErrorModel | None]:
        joints = n_joints(params)
        if joints != self.obs.n_joints:
            raise CalibrationError(
                f"the observations have {self.obs.n_joints} joint readings per pose, "
                f"the arm {joints} joints"
            )
        try:
            return Model(arm_part(params)), error_model(params)
        except KinematicsError as e:
            raise CalibrationError(f"parameter set out of range during the fit: {e}") from None

    @staticmethod
    def _core(
        model: tuple[Model, ErrorModel | None],
        th: FloatArray,
        jacobian: bool,
        temp_c: FloatArray | None = None,
    ) -> tuple[FloatArray, FloatArray | None]:
        """Points (and Jacobians) of readings ``th``: the arm's own, or with its error
        model, at the link temperatures ``temp_c`` (n, N) (None: its reference ones)."""
        m, em = model
        if em is None:
            return m.points_jacobians(th) if jacobian else (m.points(th), None)
        try:  # temp_c (n, N): the per-pose core in one call, faster than batches by set
            if jacobian:
                return em_points_jacobians(m, em, th, temp_c)
            return em_points(m, em, th, temp_c), None
        except KinematicsError as e:  # the harmonics' sum beyond the core's limit
            raise CalibrationError(f"error model out of range during the fit: {e}") from None

    def _points(
        self, model: tuple[Model, ErrorModel | None], jacobian: bool
    ) -> tuple[FloatArray, FloatArray | None]:
        th = self.obs.theta_rad
        temps = self.obs.temp_c
        if self.all_used:
            return self._core(model, th, jacobian, temps)
        n = th.shape[0]
        pts = np.zeros((n, 3))
        u = self.used
        tu = None if temps is None else temps[u]
        if not jacobian:
            pts[u] = self._core(model, th[u], False, tu)[0]
            return pts, None
        extra = model[1].n_cols if model[1] is not None else 0
        pj = np.zeros((n, 3, model[0].n_params + extra))
        p_u, j_u = self._core(model, th[u], True, tu)
        pts[u], pj[u] = p_u, j_u
        return pts, pj

    def residuals(self, params: AnyParams) -> Residuals:
        """Whitened residuals only (the tip points alone, no Jacobian: cheaper).

        Raises CalibrationError as :meth:`evaluate`.
        """
        pts, _ = self._points(self._model(params), False)
        r = np.empty(self.m)
        nuis = self._fill(pts, None, r, None, None)
        return Residuals(params, r, pts, nuis)

    def evaluate(self, params: AnyParams, extra_point_jac: FloatArray | None = None) -> Evaluation:
        """Residuals and projected Jacobian at ``params``.

        ``extra_point_jac`` (n, 3, E): derivatives of each pose's tip point
        with respect to E further unknowns (an error model being tested);
        their projected columns are appended to the Jacobian (m, P + E).

        Raises CalibrationError if the parameters are invalid for the core, the
        arm's joint count is not the observations', or a constraint degenerates
        (both ends of a length at one point, ...).
        """
        pts, pj0 = self._points(self._model(params), True)
        assert pj0 is not None
        w = np.where(
            self.pose_sigma > 0, 1.0 / np.where(self.pose_sigma > 0, self.pose_sigma, 1.0) ** 2, 0.0
        )
        raw = w @ np.einsum("nak,nak->nk", pj0, pj0)
        pj = pj0
        if extra_point_jac is not None:
            pj = np.concatenate([pj0, np.asarray(extra_point_jac, dtype=np.float64)], axis=2)
        r = np.empty(self.m)
        jac = np.empty((self.m, pj.shape[2]))
        h = self.h_static.copy()
        nuis = self._fill(pts, pj, r, jac, h)
        return Evaluation(
            params,
            r,
            pts,
            nuis,
            jac,
            self.sigma,
            h,
            self.unit_of_row,
            pj0,
            raw,
            self.pose_sigma,
        )

    def _fill(
        self,
        pts: FloatArray,
        pj: FloatArray | None,
        r: FloatArray,
        jac: FloatArray | None,
        h: FloatArray | None,
    ) -> dict[int, dict[str, FloatArray]]:
        if self.cone_pose.size:
            self._cones(pts, pj, r, jac)
        if self.n_len:
            self._lengths(pts, pj, r, jac)
        nuis: dict[int, dict[str, FloatArray]] = {}
        for o in self.others:
            c = o.c
            if isinstance(c, ReferencePoints):
                b = reference_block(c, o.sigma, pts, pj)
            elif isinstance(c, Sphere):
                b, self._sphere_state[o.ci] = sphere_block(
                    c, o.sigma, pts, pj, self._sphere_state.get(o.ci)
                )
            elif isinstance(c, LengthSet):
                b, self._sphere_state[o.ci] = ballbar_block(
                    c, o.sigma, pts, pj, self._sphere_state.get(o.ci)
                )
            else:
                b = plane_block(c, o.sigma, pts, pj)
            self._put(b, o.rows, r, jac, h)
            nuis[o.ci] = b.nuisance
        return nuis

    @staticmethod
    def _put(
        b: BlockResult, rows: slice, r: FloatArray, jac: FloatArray | None, h: FloatArray | None
    ) -> None:
        r[rows] = b.r
        if jac is not None and b.jac is not None:
            jac[rows] = b.jac
        if h is not None and b.h is not None:
            h[rows] = b.h

    def _cones(
        self, pts: FloatArray, pj: FloatArray | None, r: FloatArray, jac: FloatArray | None
    ) -> None:
        idx, gid, sq, avg = self.cone_pose, self.cone_gid, self.cone_sq, self.cone_avg
        p = pts[idx]
        r[self.cone_rows] = ((p - (avg @ p)[gid]) * sq[:, None]).reshape(-1)
        if pj is None or jac is None:
            return
        ncol = pj.shape[2]
        out = jac[self.cone_rows].reshape(idx.size, 3, ncol)  # a view: filled in place
        if self.cone_slice is not None:
            out[...] = pj[self.cone_slice]
        else:
            np.take(pj, idx, axis=0, out=out)
        mean = (avg @ out.reshape(idx.size, -1)).reshape(-1, 3, ncol)
        out -= mean[gid]
        out *= sq[:, None, None]

    def _lengths(
        self, pts: FloatArray, pj: FloatArray | None, r: FloatArray, jac: FloatArray | None
    ) -> None:
        n = pts.shape[0]
        ma, mb = self.mean_a, self.mean_b
        d = ma @ pts - mb @ pts
        dist = np.linalg.norm(d, axis=1)
        if np.any(dist < 1e-6):
            u = self.unit(self.len_unit0 + int(np.argmin(dist)))
            raise CalibrationError(
                f"{self.obs.constraints[u.constraint].name}: position {u.position + 1}: "
                "both ends at one point"
            )
        s = self.len_sigma
        row = None
        if pj is not None and jac is not None:
            dj = ((ma - mb) @ pj.reshape(n, -1)).reshape(-1, 3, pj.shape[2])
            row = np.einsum("ka,kac->kc", d / dist[:, None], dj)
        ex = self.len_exact
        if ex.size:
            sk = s[ex]
            r[self.len_exact_rows] = (dist[ex] - self.len_target[ex]) / sk
            if row is not None and jac is not None:
                jac[self.len_exact_rows] = row[ex] / sk[:, None]
        for c, sel, rows in self.len_prior:
            sk, dk = s[sel], dist[sel]
            ul = c.u_length_mm
            wk = 1.0 / sk**2
            tot = wk.sum() + 1.0 / ul**2
            lam = (wk @ dk + c.length_mm / ul**2) / tot
            r[rows] = np.append((dk - lam) / sk, (lam - c.length_mm) / ul)
            if row is not None and jac is not None:
                jk = row[sel]
                jbar = (wk @ jk) / tot
                jac[rows] = np.vstack([(jk - jbar) / sk[:, None], jbar / ul])
