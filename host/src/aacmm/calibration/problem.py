"""Residuals and their Jacobian with every nuisance unknown eliminated.

:class:`Problem` compiles an :class:`~aacmm.calibration.observations.Observations`
once; :meth:`Problem.evaluate` then gives, for one parameter set, the whitened
residual vector and its Jacobian with respect to the 25 arm parameters, the
probe points and Jacobians coming from the C core in one batch call (analytic,
no finite differences).

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
from aacmm.core import JAC_COLS, FloatArray, KinematicsError, Model, Params

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

    params: Params
    r: FloatArray
    points: FloatArray
    nuisance: dict[int, dict[str, FloatArray]] = field(default_factory=dict)

    @property
    def chi2(self) -> float:
        return float(self.r @ self.r)


@dataclass
class Evaluation(Residuals):
    """Residuals and projected Jacobian (m, 25) at one parameter set.

    ``sigma`` (m,): standard uncertainty of each row (residual in mm = r * sigma);
    ``h`` (m,): leverage of the row on the nuisance unknowns; ``unit`` (m,):
    index of the row's unit (:meth:`Problem.unit`; -1 for prior rows);
    ``point_jac`` (n, 3, 25): tip Jacobians of every pose;
    ``raw_norm2`` (25,): sum over the poses used of ||dp/dq_k||^2 / sigma^2;
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


@dataclass(frozen=True)
class _Other:
    """A reference, sphere or plane constraint and where its rows go."""

    ci: int
    c: ReferencePoints | Sphere | Plane | LengthSet
    rows: slice
    sigma: FloatArray  # per point


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
        n = obs.n_poses
        used = np.zeros(n, dtype=bool)
        for c in obs.constraints:
            used[c.poses] = True
        self.used = np.flatnonzero(used)
        self.all_used = bool(used.all())
        self.pose_sigma = np.where(used, obs.sigma_mm, 0.0)
        sig_rows: list[FloatArray] = []
        unit_rows: list[IntArray] = []
        h_rows: list[FloatArray] = []
        u_con: list[IntArray] = []
        u_kind: list[str] = []
        u_kind_n: list[int] = []
        u_pose: list[IntArray] = []
        u_pos: list[IntArray] = []
        self.n_nuisance = 0
        nu = 0  # units so far
        m = 0  # rows so far

        # seats: entries grouped by seat; a sparse matrix gives the weighted means
        cones = [(i, c) for i, c in enumerate(obs.constraints) if isinstance(c, Cone)]
        idx = np.concatenate([c.poses for _, c in cones]) if cones else np.zeros(0, dtype=np.intp)
        sizes = np.array([c.poses.size for _, c in cones], dtype=np.intp)
        gid = np.repeat(np.arange(len(cones)), sizes)
        w = 1.0 / obs.sigma_mm[idx] ** 2
        sw = np.bincount(gid, weights=w, minlength=len(cones))
        self.cone_pose = idx
        self.cone_gid = gid
        self.cone_sq = np.sqrt(w)
        self.cone_avg = sp.csr_matrix(
            (w / sw[gid] if idx.size else w, (gid, np.arange(idx.size))),
            shape=(len(cones), idx.size),
        )
        lo = int(idx[0]) if idx.size else 0
        self.cone_slice = (
            slice(lo, lo + idx.size)
            if idx.size and np.array_equal(idx, np.arange(lo, lo + idx.size))
            else None
        )
        self.cone_rows = slice(m, m + 3 * idx.size)
        m += 3 * idx.size
        sig_rows.append(np.repeat(obs.sigma_mm[idx], 3))
        unit_rows.append(np.repeat(nu + np.arange(idx.size), 3))
        h_rows.append(np.repeat(w / sw[gid] if idx.size else w, 3))
        u_con.append(np.repeat(np.array([i for i, _ in cones], dtype=np.intp), sizes))
        u_kind.append(KIND_CONE)
        u_kind_n.append(idx.size)
        u_pose.append(idx)
        u_pos.append(np.full(idx.size, -1, dtype=np.intp))
        nu += idx.size
        self.n_nuisance += 3 * len(cones)

        # lengths: sparse averaging matrices for the two ends of every position
        self.len_sets = [
            (i, c)
            for i, c in enumerate(obs.constraints)
            if isinstance(c, LengthSet) and not c.ball_ends
        ]
        ra: list[int] = []
        ca: list[int] = []
        va: list[float] = []
        rb: list[int] = []
        cb: list[int] = []
        vb: list[float] = []
        target: list[float] = []
        exact: list[bool] = []
        con: list[int] = []
        pos: list[int] = []
        first: list[int] = []
        self.len_ends: list[tuple[IntArray, IntArray]] = []
        k = 0
        for i, c in self.len_sets:
            for p_i, (ea, eb) in enumerate(zip(c.ends_a, c.ends_b, strict=True)):
                ra += [k] * ea.size
                ca += ea.tolist()
                va += [1.0 / ea.size] * ea.size
                rb += [k] * eb.size
                cb += eb.tolist()
                vb += [1.0 / eb.size] * eb.size
                target.append(c.length_mm)
                exact.append(c.u_length_mm == 0)
                con.append(i)
                pos.append(p_i)
                first.append(int(ea[0]))
                self.len_ends.append((ea, eb))
                k += 1
            if c.u_length_mm > 0:
                self.n_nuisance += 1
        self.n_len = k
        self.mean_a = sp.csr_matrix((va, (ra, ca)), shape=(k, n))
        self.mean_b = sp.csr_matrix((vb, (rb, cb)), shape=(k, n))
        self.len_target = np.array(target)
        var = obs.sigma_mm**2
        self.len_sigma = np.sqrt(
            self.mean_a.multiply(self.mean_a) @ var + self.mean_b.multiply(self.mean_b) @ var
        )
        self.len_unit0 = nu
        ex = np.array(exact, dtype=bool)
        self.len_exact = np.flatnonzero(ex)
        self.len_exact_rows = slice(m, m + self.len_exact.size)
        m += self.len_exact.size
        sig_rows.append(self.len_sigma[self.len_exact])
        unit_rows.append(nu + self.len_exact)
        h_rows.append(np.zeros(self.len_exact.size))
        # uncertain lengths: the true length is a nuisance unknown with a prior row
        self.len_prior: list[tuple[LengthSet, IntArray, slice]] = []
        start = 0
        for _i, c in self.len_sets:
            npos = len(c.ends_a)
            sel = np.arange(start, start + npos)
            start += npos
            if c.u_length_mm == 0:
                continue
            self.len_prior.append((c, sel, slice(m, m + npos + 1)))
            m += npos + 1
            sk = self.len_sigma[sel]
            wk = 1.0 / sk**2
            tot = wk.sum() + 1.0 / c.u_length_mm**2
            sig_rows.append(np.append(sk, c.u_length_mm))
            unit_rows.append(np.append(nu + sel, -1))
            h_rows.append(np.append(wk / tot, 1.0 / (c.u_length_mm**2 * tot)))
        u_con.append(np.array(con, dtype=np.intp))
        u_kind.append(KIND_LENGTH)
        u_kind_n.append(k)
        u_pose.append(np.array(first, dtype=np.intp))
        u_pos.append(np.array(pos, dtype=np.intp))
        nu += k

        # references, spheres, planes, ball-ended lengths: one block each
        self.others: list[_Other] = []
        kinds = {ReferencePoints: KIND_REFERENCE, Sphere: KIND_SPHERE, Plane: KIND_PLANE}
        for i, c in enumerate(obs.constraints):
            if isinstance(c, LengthSet) and c.ball_ends:
                idx, pos_of = ballbar_order(c)
                s = obs.sigma_mm[idx]
                rows, npts = ballbar_rows(c), idx.size
                sig, un = s, nu + np.arange(npts)
                if rows > npts:  # the length prior's row
                    sig, un = np.append(s, c.u_length_mm), np.append(un, -1)
                self.n_nuisance += 5 * len(c.ends_a) + (1 if c.u_length_mm > 0 else 0)
                kind, u_poses, u_position = KIND_BALL_END, idx, pos_of
            elif isinstance(c, (ReferencePoints, Sphere, Plane)):
                npts = c.poses.size
                kind, u_poses, u_position = kinds[type(c)], c.poses, np.full(npts, -1)
                if isinstance(c, ReferencePoints):
                    s = reference_sigma(c, obs.sigma_mm)
                    rows, sig, un = 3 * npts, np.repeat(s, 3), np.repeat(nu + np.arange(npts), 3)
                    self.n_nuisance += 0 if c.base_known else 6
                else:
                    s = obs.sigma_mm[c.poses]
                    rows, sig, un = npts, s, nu + np.arange(npts)
                    if isinstance(c, Sphere):
                        rows = sphere_rows(c)
                        if rows > npts:  # the radius prior's row
                            sig, un = np.append(s, c.u_radius_mm), np.append(un, -1)
                        self.n_nuisance += 4 if (c.free_radius or c.u_radius_mm > 0) else 3
                    else:
                        self.n_nuisance += 3
            else:
                continue
            self.others.append(_Other(i, c, slice(m, m + rows), s))
            m += rows
            sig_rows.append(sig)
            unit_rows.append(un)
            h_rows.append(np.zeros(rows))  # filled per evaluation
            u_con.append(np.full(npts, i, dtype=np.intp))
            u_kind.append(kind)
            u_kind_n.append(npts)
            u_pose.append(u_poses)
            u_pos.append(u_position.astype(np.intp))
            nu += npts

        self.m = m
        self.sigma = np.concatenate(sig_rows)
        self.unit_of_row = np.concatenate(unit_rows).astype(np.intp)
        self.h_static = np.concatenate(h_rows)
        self.unit_constraint = np.concatenate(u_con).astype(np.intp)
        self.unit_kind = np.repeat(np.array(u_kind, dtype=object), u_kind_n)
        self.unit_pose = np.concatenate(u_pose).astype(np.intp)
        self.unit_position = np.concatenate(u_pos).astype(np.intp)
        self.n_units = nu
        self._sphere_state: dict[int, FloatArray] = {}

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

    def _model(self, params: Params) -> Model:
        try:
            return Model(params)
        except KinematicsError as e:
            raise CalibrationError(f"parameter set out of range during the fit: {e}") from None

    def _points(self, model: Model, jacobian: bool) -> tuple[FloatArray, FloatArray | None]:
        th = self.obs.theta_rad
        if self.all_used:
            if jacobian:
                return model.points_jacobians(th)
            return model.points(th), None
        n = th.shape[0]
        pts = np.zeros((n, 3))
        u = self.used
        if not jacobian:
            pts[u] = model.points(th[u])
            return pts, None
        pj = np.zeros((n, 3, JAC_COLS))
        pts[u], pj[u] = model.points_jacobians(th[u])
        return pts, pj

    def residuals(self, params: Params) -> Residuals:
        """Whitened residuals only (the tip points alone, no Jacobian: cheaper).

        Raises CalibrationError as :meth:`evaluate`.
        """
        pts, _ = self._points(self._model(params), False)
        r = np.empty(self.m)
        nuis = self._fill(pts, None, r, None, None)
        return Residuals(params, r, pts, nuis)

    def evaluate(self, params: Params, extra_point_jac: FloatArray | None = None) -> Evaluation:
        """Residuals and projected Jacobian at ``params``.

        ``extra_point_jac`` (n, 3, E): derivatives of each pose's tip point
        with respect to E further unknowns (an error model being tested);
        their projected columns are appended to the Jacobian (m, 25 + E).

        Raises CalibrationError if the parameters are invalid for the core or
        a constraint degenerates (both ends of a length at one point, ...).
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
