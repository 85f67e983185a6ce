"""The error model beside the kinematic model (issue 27): what DH cannot describe.

Per joint, encoder angle harmonics: the reading ``q`` (rad) becomes
``q + sum_k (c_k cos kq + s_k sin kq)``, ``k = 1 .. K``, ``K <= 4`` per joint;
per link, a coefficient of thermal expansion (1/K) and a reference
temperature (degC): at link temperatures ``T`` every length of link ``i``
(``d_i``, ``a_i``; the tip belongs to link N) is scaled by
``1 + cte_i (T_i - tref_i)``. ``firmware/include/aacmm/kinematics.h`` is the
contract; this module binds the C core (``aacmm._core``) for it.

Main names:

* :class:`ErrorModel` -- the harmonic coefficients, CTEs and reference
  temperatures of an N-joint arm; :meth:`ErrorModel.none`,
  :attr:`ErrorModel.param_names` (the extended Jacobian's extra columns).
* :func:`corrected_angles` -- the corrected joint angles.
* :func:`points`, :func:`points_jacobians` -- probe points and the extended
  ``(n, 3, P + E)`` Jacobians of a :class:`aacmm.core.Model` with an error
  model, at the link temperatures.

Errors: a malformed error model raises ValueError at construction; the C
core's rejection of an input (a reading or temperature out of range, NaN)
raises :class:`aacmm.core.KinematicsError` (a ValueError) with its status and
the index of the first bad pose.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aacmm._core import ffi, lib
from aacmm.core import JAC_ROWS, Model, _check, _current_kernel, _dptr, _fptr, _poses, _precision

__all__ = [
    "CTE_MAX_PER_K",
    "HARMONICS_MAX",
    "HARMONIC_SUM_MAX_RAD",
    "TEMP_MAX_C",
    "TEMP_MIN_C",
    "TEMP_REF_DEFAULT_C",
    "ErrorModel",
    "corrected_angles",
    "param_names",
    "points",
    "points_jacobians",
]

HARMONICS_MAX = 4
HARMONIC_SUM_MAX_RAD = 0.1
TEMP_MIN_C = -40.0
TEMP_MAX_C = 85.0
TEMP_REF_DEFAULT_C = 20.0
CTE_MAX_PER_K = 1e-3


@dataclass(frozen=True)
class ErrorModel:
    """Encoder harmonics and thermal expansion of an N-joint arm.

    ``harmonics[i]`` is joint ``i``'s tuple of ``(c_k, s_k)`` pairs (rad),
    ``k = 1 .. K_i`` (``K_i <= 4``; an empty tuple: no correction);
    ``cte_per_k[i]`` and ``tref_c[i]`` are link ``i``'s coefficient of thermal
    expansion (1/K, ``|x| <= 1e-3``) and reference temperature (degC,
    -40 .. 85). ``cte_columns``: the extended Jacobian carries one column per
    link's CTE. Raises ValueError for a malformed or out-of-range value.
    """

    harmonics: tuple[tuple[tuple[float, float], ...], ...]
    cte_per_k: tuple[float, ...] = ()
    tref_c: tuple[float, ...] = ()
    cte_columns: bool = False

    def __post_init__(self) -> None:
        n = len(self.harmonics)
        if not 4 <= n <= 7:
            raise ValueError(f"an error model has 4 to 7 joints, got {n}")
        hs: list[tuple[tuple[float, float], ...]] = []
        for i, terms in enumerate(self.harmonics, start=1):
            pairs = tuple((float(c), float(s)) for c, s in terms)
            if len(pairs) > HARMONICS_MAX:
                raise ValueError(f"joint {i}: at most {HARMONICS_MAX} harmonics, got {len(pairs)}")
            if not all(math.isfinite(v) for p in pairs for v in p):
                raise ValueError(f"joint {i}: harmonic coefficients must be finite")
            total = sum(abs(c) + abs(s) for c, s in pairs)
            if total > HARMONIC_SUM_MAX_RAD:
                raise ValueError(
                    f"joint {i}: the harmonic coefficients sum to {total:g} rad "
                    f"(at most {HARMONIC_SUM_MAX_RAD:g})"
                )
            hs.append(pairs)
        cte = tuple(float(x) for x in self.cte_per_k) or (0.0,) * n
        tref = tuple(float(x) for x in self.tref_c) or (TEMP_REF_DEFAULT_C,) * n
        if len(cte) != n or len(tref) != n:
            raise ValueError(f"cte_per_k and tref_c need {n} values (one per link)")
        for i, (a, t) in enumerate(zip(cte, tref, strict=True), start=1):
            if not (math.isfinite(a) and abs(a) <= CTE_MAX_PER_K):
                raise ValueError(f"link {i}: cte must be finite and within +-{CTE_MAX_PER_K:g}/K")
            if not (math.isfinite(t) and TEMP_MIN_C <= t <= TEMP_MAX_C):
                raise ValueError(f"link {i}: reference temperature must be within -40 .. 85 degC")
        object.__setattr__(self, "harmonics", tuple(hs))
        object.__setattr__(self, "cte_per_k", cte)
        object.__setattr__(self, "tref_c", tref)
        object.__setattr__(self, "cte_columns", bool(self.cte_columns))

    @classmethod
    def none(cls, joints: int) -> ErrorModel:
        """An error model that changes nothing: no harmonics, CTE 0, 20 degC."""
        return cls(harmonics=((),) * joints)

    @property
    def joints(self) -> int:
        """N, the joint count."""
        return len(self.harmonics)

    @property
    def n_cols(self) -> int:
        """E, the extended Jacobian's extra columns: 2 sum(K) (+ N CTE columns)."""
        return 2 * sum(len(h) for h in self.harmonics) + (self.joints if self.cte_columns else 0)

    @property
    def param_names(self) -> tuple[str, ...]:
        """The E extra column names in order, joints counted from 1: ``c<j>_<k>``,
        ``s<j>_<k>`` joint after joint, then ``cte<i>`` per link."""
        names = [
            f"{w}{j}_{k}"
            for j, h in enumerate(self.harmonics, start=1)
            for k in range(1, len(h) + 1)
            for w in ("c", "s")
        ]
        if self.cte_columns:
            names += [f"cte{i}" for i in range(1, self.joints + 1)]
        return tuple(names)

    def to_c(self, single: bool = False) -> Any:
        """A freshly allocated ``aacmm_errmodel_f64_t *`` (``_f32_t *``)."""
        c = ffi.new("aacmm_errmodel_f32_t *" if single else "aacmm_errmodel_f64_t *")
        fill = lib.aacmm_errmodel_default_f32 if single else lib.aacmm_errmodel_default_f64
        _check(fill(c, self.joints), "invalid error model")
        c.cte_columns = int(self.cte_columns)
        for i, h in enumerate(self.harmonics):
            c.harmonics[i] = len(h)
            for k, (cv, sv) in enumerate(h):
                c.c_rad[i][k] = cv
                c.s_rad[i][k] = sv
            c.cte_per_k[i] = self.cte_per_k[i]
            c.tref_c[i] = self.tref_c[i]
        return c


def _temps(temp_c: npt.ArrayLike | None, n: int, joints: int, dtype: Any) -> Any:
    """None, one set of N link temperatures (every pose), or (n, N)."""
    if temp_c is None:
        return None
    t: npt.NDArray[Any] = np.ascontiguousarray(temp_c, dtype=dtype)
    if t.shape == (joints,) or t.shape == (n, joints):
        return t
    raise ValueError(
        f"link temperatures must have shape ({joints},) or ({n}, {joints}), not {t.shape}"
    )


def corrected_angles(em: ErrorModel, theta_rad: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """The corrected joint angles (n, N) of readings (n, N), in double precision."""
    th = _poses(theta_rad, joints=em.joints)
    out: npt.NDArray[np.float64] = np.empty_like(th)
    c = em.to_c()
    for k in range(th.shape[0]):
        _check(
            lib.aacmm_errmodel_angles_f64(c, _dptr(th[k]), _dptr(out[k])), "invalid joint angles", k
        )
    return out


def _run(
    model: Model,
    em: ErrorModel,
    theta_rad: npt.ArrayLike,
    temp_c: npt.ArrayLike | None,
    dtype: npt.DTypeLike,
    jacobian: bool,
) -> tuple[npt.NDArray[Any], npt.NDArray[Any] | None]:
    if em.joints != model.joints:
        raise ValueError(f"the error model has {em.joints} joints, the model {model.joints}")
    single = _precision(dtype)
    th = _poses(theta_rad, np.float32 if single else np.float64, model.joints)
    n = th.shape[0]
    t = _temps(temp_c, n, model.joints, th.dtype)
    p = np.empty((n, 3), dtype=th.dtype)
    j = np.empty((n, JAC_ROWS, model.n_params + em.n_cols), dtype=th.dtype) if jacobian else None
    ptr = _fptr if single else _dptr
    cm = model.c_model32 if single else model.c_model
    ce = em.to_c(single)
    done = ffi.new("size_t *")
    jp = ffi.NULL if j is None else ptr(j)
    if t is not None and t.ndim == 2:
        # a temperature set per pose: the per-pose core
        fn = lib.aacmm_batch_angles_em_f32 if single else lib.aacmm_batch_angles_em_f64
        st = fn(cm, ce, n, ptr(th), ptr(t), ptr(p), jp, done)
    else:
        fn = lib.aacmm_simd_batch_angles_em_f32 if single else lib.aacmm_simd_batch_angles_em_f64
        tp = ffi.NULL if t is None else ptr(t)
        st = fn(_current_kernel(), cm, ce, n, ptr(th), tp, ptr(p), jp, done)
    _check(st, "invalid joint angles or temperatures", int(done[0]) if st else None)
    return p, j


def points(
    model: Model,
    em: ErrorModel,
    theta_rad: npt.ArrayLike,
    temp_c: npt.ArrayLike | None = None,
    dtype: npt.DTypeLike = np.float64,
) -> npt.NDArray[Any]:
    """Probe points (n, 3) in mm of readings (n, N) with the error model.

    ``temp_c``: link temperatures in degC, ``None`` (the reference
    temperatures), one set ``(N,)`` for every pose (the batch kernel) or one
    per pose ``(n, N)`` (the per-pose core). Raises KinematicsError for a bad
    pose or temperature.
    """
    return _run(model, em, theta_rad, temp_c, dtype, jacobian=False)[0]


def points_jacobians(
    model: Model,
    em: ErrorModel,
    theta_rad: npt.ArrayLike,
    temp_c: npt.ArrayLike | None = None,
    dtype: npt.DTypeLike = np.float64,
) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
    """Points (n, 3) and extended Jacobians (n, 3, P + E), columns
    ``model.param_names + em.param_names`` (as :func:`points` otherwise)."""
    p, j = _run(model, em, theta_rad, temp_c, dtype, jacobian=True)
    assert j is not None
    return p, j


def param_names(model: Model, em: ErrorModel) -> tuple[str, ...]:
    """The P + E column names of the extended Jacobian."""
    names: Sequence[str] = (*model.param_names, *em.param_names)
    return tuple(names)
