"""Typed Python wrapper of the firmware's kinematics core (double precision).

The C core (``firmware/src/kinematics_f64.c``, bound by cffi as
``aacmm._core``) is the single implementation of the arm's model; this module
gives it numpy-friendly, validated entry points so the host tools use exactly
the code the arm runs. See ``firmware/include/aacmm/kinematics.h`` for the
model (N joints, standard or modified DH, Hayati betas, a tip on z or a tip
vector; the paper's Eq. 1-3 for its arm) and the Jacobian column order.

Main names:

* :class:`Params` -- the paper's arm in its 25-parameter form (mm, rad);
  ``Params()`` is the paper's Table 1, :meth:`Params.to_arm` the same as an
  :class:`aacmm.arm.Arm`.
* :class:`EncoderConfig` -- per-joint encoder description (any joint count).
* :class:`Model` -- a prepared model of a :class:`Params` or any
  :class:`aacmm.arm.Arm` (:attr:`Model.joints`, :attr:`Model.n_params`,
  :attr:`Model.param_names`): :meth:`Model.point`,
  :meth:`Model.point_jacobian`, :meth:`Model.points`,
  :meth:`Model.points_jacobians`, :meth:`Model.points_jacobians_tiled`,
  :meth:`Model.points_from_counts`, :meth:`Model.abs_jacobian_sums`.
* :data:`TILE_F64`, :data:`TILE_F32`, :func:`untile_jacobians` -- the tiled
  Jacobian layout of :meth:`Model.points_jacobians_tiled`.
* :func:`counts_to_angles`, :func:`perturbed_points`.
* :data:`PARAM_NAMES` -- the paper's 25 parameter names in Jacobian column
  order (:attr:`aacmm.arm.Arm.param_names` for any arm).
* :func:`kernel`, :func:`set_kernel`, :func:`available_kernels` -- the batch
  kernel across SIMD lanes the batch methods run on (``aacmm/simd.h``):
  on first use the widest one this CPU runs, or the one the environment
  variable ``AACMM_KERNEL`` names (``scalar``, ``vec128``, ``avx2``,
  ``avx512`` or ``auto``).

Errors: invalid arguments raise :class:`ValueError`; an error reported by the
C core raises :class:`KinematicsError` (a ``ValueError``) carrying the C
status code and, for batches, the index of the first bad pose. A batch
method raises ValueError if ``AACMM_KERNEL`` names an unknown kernel or one
this CPU cannot run.

All functions are thread-safe; batch calls release the GIL while in C.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from aacmm._core import ffi, lib
from aacmm.arm import Arm, Joint
from aacmm.errors import AacmmError

__all__ = [
    "AXES",
    "ENV_KERNEL",
    "JAC_COLS",
    "JAC_ROWS",
    "JOINTS",
    "JOINT_ANGLE_MAX_RAD",
    "KERNELS",
    "LENGTH_MAX_MM",
    "PARAM_ANGLE_MAX_RAD",
    "PARAM_GROUPS",
    "PARAM_NAMES",
    "PARAM_UNITS",
    "TILE_F32",
    "TILE_F64",
    "EncoderConfig",
    "FloatArray",
    "KinematicsError",
    "Model",
    "Params",
    "available_kernels",
    "counts_to_angles",
    "kernel",
    "perturbed_points",
    "set_kernel",
    "status_str",
    "untile_jacobians",
]

#: The paper's arm: joints and Jacobian columns (a general model has its own:
#: :attr:`Model.joints`, :attr:`Model.n_params`).
JOINTS = 6
JAC_ROWS = 3
JAC_COLS = 25
AXES: tuple[str, ...] = ("x", "y", "z")
PARAM_GROUPS: tuple[str, ...] = ("theta", "alpha", "d", "a", "l")
#: The 25 structural parameters in Jacobian column order (paper Eq. 10).
PARAM_NAMES: tuple[str, ...] = (
    *(f"theta{i}" for i in range(1, 7)),
    *(f"alpha{i}" for i in range(1, 7)),
    *(f"d{i}" for i in range(1, 7)),
    *(f"a{i}" for i in range(1, 7)),
    "l",
)
#: Unit of each parameter (and of its Jacobian column: mm per unit).
PARAM_UNITS: tuple[str, ...] = ("rad",) * 12 + ("mm",) * 13

LENGTH_MAX_MM = 10000.0
PARAM_ANGLE_MAX_RAD = 2.0 * math.pi
JOINT_ANGLE_MAX_RAD = 1024.0

FloatArray = npt.NDArray[np.float64]
_PAPER_D_MM = (300.0, 65.5, 792.7, 65.5, 883.2, 0.0)


class KinematicsError(AacmmError, ValueError):
    """The C core rejected an input.

    ``status`` is the ``aacmm_status_t`` code (e.g. -2 out of range, -3 not
    finite); ``index`` is the first offending pose or trial of a batch (or
    ``None`` for a single call).
    """

    def __init__(self, message: str, status: int, index: int | None = None) -> None:
        super().__init__(message)
        self.status = status
        self.index = index


def status_str(status: int) -> str:
    """The core's text for a status code (``"value out of range"``, ...)."""
    text: bytes = ffi.string(lib.aacmm_status_str(status))
    return text.decode("ascii")


def _check(status: int, what: str, index: int | None = None) -> None:
    if status != 0:
        where = "" if index is None else f" at index {index}"
        raise KinematicsError(f"{what}: {status_str(status)}{where}", status, index)


#: The batch kernels, in ``aacmm_kernel_t`` order (aacmm/simd.h).
KERNELS: tuple[str, ...] = ("scalar", "vec128", "avx2", "avx512")
#: Environment variable that forces a kernel (``auto`` or one of :data:`KERNELS`).
ENV_KERNEL = "AACMM_KERNEL"


def available_kernels() -> tuple[str, ...]:
    """The kernels this build and this CPU can run, narrowest first."""
    return tuple(k for i, k in enumerate(KERNELS) if lib.aacmm_kernel_available(i))


def _kernel_index(name: str) -> int:
    if name == "auto":
        return int(lib.aacmm_kernel_best())
    if name not in KERNELS:
        raise ValueError(f"unknown batch kernel {name!r} (auto, {', '.join(KERNELS)})")
    i = KERNELS.index(name)
    if not lib.aacmm_kernel_available(i):
        raise ValueError(
            f"batch kernel {name!r} cannot run on this CPU "
            f"(available: {', '.join(available_kernels())})"
        )
    return i


_kernel: int | None = None


def set_kernel(name: str = "auto") -> str:
    """Run the batch methods on kernel ``name`` (``auto``: the widest available).

    Process-wide; returns the kernel's name. Raises ValueError for an unknown
    kernel or one this CPU cannot run.
    """
    global _kernel
    _kernel = _kernel_index(name)
    return KERNELS[_kernel]


def _current_kernel() -> int:
    """The kernel in force: on first use, ``$AACMM_KERNEL`` (default ``auto``).

    Raises ValueError if the variable names an unknown kernel or one this CPU
    cannot run (on every use, until :func:`set_kernel` is called).
    """
    global _kernel
    if _kernel is None:
        name = os.environ.get(ENV_KERNEL, "").strip() or "auto"
        try:
            _kernel = _kernel_index(name)
        except ValueError as e:
            raise ValueError(f"{ENV_KERNEL}: {e}") from None
    return _kernel


def kernel() -> str:
    """The name of the kernel the batch methods run on.

    Raises ValueError if ``$AACMM_KERNEL`` is invalid (see :func:`set_kernel`).
    """
    return KERNELS[_current_kernel()]


def _six(name: str, values: Sequence[float]) -> tuple[float, ...]:
    out = tuple(float(v) for v in values)
    if len(out) != JOINTS:
        raise ValueError(f"{name} needs {JOINTS} values, got {len(out)}")
    return out


@dataclass(frozen=True)
class Params:
    """Structural parameters of one arm (mm, rad); the default is the paper's Table 1.

    ``theta_offset_rad`` is added to each joint reading; ``alpha_rad`` is the
    DH twist; ``d_mm`` and ``a_mm`` the DH offsets; ``l_mm`` the probe length.
    Construction checks lengths only; :meth:`validate` checks the ranges.
    """

    theta_offset_rad: tuple[float, ...] = (0.0,) * JOINTS
    alpha_rad: tuple[float, ...] = (math.pi / 2.0,) * JOINTS
    d_mm: tuple[float, ...] = _PAPER_D_MM
    a_mm: tuple[float, ...] = (0.0,) * JOINTS
    l_mm: float = 183.5

    def __post_init__(self) -> None:
        for name in ("theta_offset_rad", "alpha_rad", "d_mm", "a_mm"):
            object.__setattr__(self, name, _six(name, getattr(self, name)))
        object.__setattr__(self, "l_mm", float(self.l_mm))

    @classmethod
    def paper(cls) -> Params:
        """The paper's Table 1 (same as ``Params()`` and the C default)."""
        return cls()

    def to_vector(self) -> FloatArray:
        """The 25 parameters in Jacobian column order (see :data:`PARAM_NAMES`)."""
        return np.array(
            [*self.theta_offset_rad, *self.alpha_rad, *self.d_mm, *self.a_mm, self.l_mm],
            dtype=np.float64,
        )

    @classmethod
    def from_vector(cls, v: npt.ArrayLike) -> Params:
        """Inverse of :meth:`to_vector`. Raises ValueError unless 25 values."""
        a = np.asarray(v, dtype=np.float64).reshape(-1)
        if a.size != JAC_COLS:
            raise ValueError(f"a parameter vector has {JAC_COLS} values, got {a.size}")
        f = [float(x) for x in a]
        return cls(tuple(f[0:6]), tuple(f[6:12]), tuple(f[12:18]), tuple(f[18:24]), f[24])

    def to_arm(self) -> Arm:
        """These parameters as a general :class:`aacmm.arm.Arm` (the paper's shape)."""
        return Arm(
            joints=tuple(
                Joint(theta_offset_rad=t, alpha_rad=al, d_mm=d, a_mm=a)
                for t, al, d, a in zip(
                    self.theta_offset_rad, self.alpha_rad, self.d_mm, self.a_mm, strict=True
                )
            ),
            tip="z",
            tip_mm=(0.0, 0.0, self.l_mm),
        )

    @classmethod
    def from_arm(cls, arm: Arm) -> Params:
        """The 25-parameter form of an arm of the paper's shape.

        Raises ValueError for an arm of another shape (joint count,
        conventions, betas, tip kind).
        """
        if not arm.is_paper_shape:
            raise ValueError(
                "only an arm of the paper's shape (6 standard joints, no beta, tip l) has "
                "the 25-parameter form"
            )
        return cls.from_vector(arm.to_vector())

    def _fill(self, c: Any) -> Any:
        c.theta_offset_rad = list(self.theta_offset_rad)
        c.alpha_rad = list(self.alpha_rad)
        c.d_mm = list(self.d_mm)
        c.a_mm = list(self.a_mm)
        c.l_mm = self.l_mm
        return c

    def to_c(self) -> Any:
        """A freshly allocated ``aacmm_params_f64_t *`` holding these values."""
        return self._fill(ffi.new("aacmm_params_f64_t *"))

    def to_c32(self) -> Any:
        """A freshly allocated ``aacmm_params_f32_t *`` (values rounded to float)."""
        return self._fill(ffi.new("aacmm_params_f32_t *"))

    def validate(self) -> None:
        """Check the ranges with the core's own validator.

        Raises KinematicsError (a ValueError) for a NaN/inf value or one beyond
        the limits (|angle| <= 2 pi, |length| <= 10000 mm).
        """
        _check(lib.aacmm_params_validate_f64(self.to_c()), "invalid parameters")


@dataclass(frozen=True)
class EncoderConfig:
    """Per-joint encoder description (see ``aacmm_arm_encoders_t``), one entry per joint.

    Default: six joints (the paper's arm) of 2^32 counts per revolution, zero
    offset 0, direction +1; :meth:`default` for another joint count. Raises
    ValueError unless the three tuples have the same length, 1 to 7.
    """

    counts_per_rev: tuple[int, ...] = (1 << 32,) * JOINTS
    zero_offset_counts: tuple[int, ...] = (0,) * JOINTS
    direction: tuple[int, ...] = (1,) * JOINTS

    def __post_init__(self) -> None:
        n = len(tuple(self.counts_per_rev))
        if not 1 <= n <= 7:
            raise ValueError(f"counts_per_rev needs 1 to 7 values (one per joint), got {n}")
        for name in ("counts_per_rev", "zero_offset_counts", "direction"):
            vals = tuple(int(v) for v in getattr(self, name))
            if len(vals) != n:
                raise ValueError(f"{name} needs {n} values, got {len(vals)}")
            object.__setattr__(self, name, vals)

    @classmethod
    def default(cls, joints: int = JOINTS) -> EncoderConfig:
        """2^32 counts per revolution, offset 0, direction +1 on ``joints`` joints."""
        return cls((1 << 32,) * joints, (0,) * joints, (1,) * joints)

    @property
    def joints(self) -> int:
        """The number of joints described."""
        return len(self.counts_per_rev)

    def to_c(self) -> Any:
        """A validated ``aacmm_arm_encoders_t *``.

        Raises ValueError for values outside the C ranges (resolution
        2 .. 2^32, zero offset below the resolution, direction +1 or -1).
        """
        for cpr, z, d in zip(
            self.counts_per_rev, self.zero_offset_counts, self.direction, strict=True
        ):
            if not 2 <= cpr <= (1 << 32):
                raise ValueError(f"counts_per_rev must be in 2 .. 2^32, got {cpr}")
            if not 0 <= z < cpr:
                raise ValueError(f"zero_offset_counts must be in 0 .. counts_per_rev-1, got {z}")
            if d not in (1, -1):
                raise ValueError(f"direction must be +1 or -1, got {d}")
        c = ffi.new("aacmm_arm_encoders_t *")
        c.joints = self.joints
        c.counts_per_rev = list(self.counts_per_rev)
        c.zero_offset_counts = list(self.zero_offset_counts)
        c.direction = list(self.direction)
        _check(lib.aacmm_arm_encoders_validate(c), "invalid encoder config")
        return c


def _poses(theta_rad: npt.ArrayLike, dtype: type = np.float64, joints: int = JOINTS) -> Any:
    a: npt.NDArray[Any] = np.ascontiguousarray(theta_rad, dtype=dtype)
    if a.ndim == 1 and a.size == joints:
        a = a.reshape(1, joints)
    if a.ndim != 2 or a.shape[1] != joints:
        raise ValueError(f"joint angles must have shape (n, {joints}), got {a.shape}")
    return a


def _arm_c(arm: Arm, single: bool = False) -> Any:
    """A freshly allocated ``aacmm_arm_f64_t *`` (``aacmm_arm_f32_t *``) holding the arm."""
    c = ffi.new("aacmm_arm_f32_t *" if single else "aacmm_arm_f64_t *")
    n = arm.n_joints
    unused = int(lib.AACMM_JOINTS_MAX) - n
    pad = [0.0] * unused
    c.shape.joints = n
    c.shape.tip = lib.AACMM_TIP_XYZ if arm.tip == "xyz" else lib.AACMM_TIP_Z
    c.shape.convention = [_CONVENTION_CODES[j.convention] for j in arm.joints] + [0] * unused
    c.shape.beta = [int(j.beta_rad is not None) for j in arm.joints] + [0] * unused
    c.theta_offset_rad = [j.theta_offset_rad for j in arm.joints] + pad
    c.alpha_rad = [j.alpha_rad for j in arm.joints] + pad
    c.d_mm = [j.d_mm for j in arm.joints] + pad
    c.a_mm = [j.a_mm for j in arm.joints] + pad
    c.beta_rad = [float(j.beta_rad or 0.0) for j in arm.joints] + pad
    c.tip_mm = list(arm.tip_mm)
    return c


# ``aacmm_dh_convention_t`` of each convention name (aacmm.arm.CONVENTIONS).
_CONVENTION_CODES: dict[str, int] = {
    "standard": int(lib.AACMM_DH_STANDARD),
    "modified": int(lib.AACMM_DH_MODIFIED),
}


def _dptr(a: FloatArray) -> Any:
    return ffi.cast("double *", ffi.from_buffer(a))


def _fptr(a: npt.NDArray[np.float32]) -> Any:
    return ffi.cast("float *", ffi.from_buffer(a))


def _precision(dtype: npt.DTypeLike) -> bool:
    """True for single precision; ValueError unless float64 or float32."""
    d = np.dtype(dtype)
    if d == np.float64:
        return False
    if d == np.float32:
        return True
    raise ValueError(f"dtype must be float64 or float32, got {d}")


#: Poses per tile of the tiled Jacobian layout (``AACMM_SIMD_TILE_F64/_F32``):
#: an entry of a tile's poses is 64 bytes in either precision.
TILE_F64 = 8
TILE_F32 = 16


def _aligned_empty(shape: tuple[int, ...], dtype: Any) -> npt.NDArray[Any]:
    """An uninitialised C-contiguous array whose data starts on 64 bytes."""
    dt = np.dtype(dtype)
    size = int(np.prod(shape)) * dt.itemsize
    raw = np.empty(size + 64, dtype=np.uint8)
    start = -raw.ctypes.data % 64
    out: npt.NDArray[Any] = raw[start : start + size].view(dt).reshape(shape)
    return out


def untile_jacobians(tiled: npt.NDArray[Any], n: int) -> npt.NDArray[Any]:
    """The ``(n, 3, P)`` Jacobians of a ``(tiles, 3, P, T)`` tiled array (a copy).

    Raises ValueError if the shape is not a tiled one or ``n`` does not fit it.
    """
    a = np.asarray(tiled)
    if a.ndim != 4 or a.shape[1] != JAC_ROWS or a.shape[2] < 1:
        raise ValueError(f"tiled Jacobians must have shape (tiles, 3, P, T), not {a.shape}")
    cols, tile = a.shape[2], a.shape[3]
    if not (a.shape[0] - 1) * tile < n <= a.shape[0] * tile:
        raise ValueError(f"{n} poses do not fill {a.shape[0]} tiles of {tile}")
    out: npt.NDArray[Any] = a.transpose(0, 3, 1, 2).reshape(-1, JAC_ROWS, cols)[:n].copy()
    return out


@dataclass(frozen=True)
class Model:
    """A prepared kinematic model (``aacmm_model_f64_t``) of one arm.

    ``params`` is the paper's arm in its 25-parameter form (:class:`Params`,
    the default: Table 1) or any :class:`aacmm.arm.Arm`; a :class:`Params`
    and its :meth:`Params.to_arm` give the same model. Raises
    KinematicsError (a ValueError) if the parameters are invalid.
    Joint angles are readings in rad (the model adds the theta offsets); every
    batch method takes an ``(n, N)`` array (a single ``(N,)`` pose is
    accepted as ``n = 1``; N = :attr:`joints`) and runs on the batch kernel
    :func:`kernel`; Jacobians are ``(n, 3, P)``, P = :attr:`n_params`, columns
    as :attr:`param_names`. ``dtype=np.float32`` runs the single-precision
    core (parameters rounded to float; the Cortex-M4F's arithmetic) and
    returns float32 arrays.
    """

    params: Params | Arm = field(default_factory=Params)
    _c: Any = field(init=False, repr=False, compare=False)
    _c32: list[Any] = field(init=False, repr=False, compare=False)
    _arm: Arm = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        c = ffi.new("aacmm_model_f64_t *")
        if isinstance(self.params, Params):
            _check(lib.aacmm_model_init_f64(c, self.params.to_c()), "invalid parameters")
            arm = self.params.to_arm()  # valid: the core accepted the values
        elif isinstance(self.params, Arm):
            arm = self.params
            _check(lib.aacmm_model_init_arm_f64(c, _arm_c(arm)), "invalid arm")
        else:
            raise ValueError(f"a model needs Params or an Arm, got {type(self.params).__name__}")
        object.__setattr__(self, "_c", c)
        object.__setattr__(self, "_c32", [])
        object.__setattr__(self, "_arm", arm)

    @property
    def c_model(self) -> Any:
        """The underlying ``aacmm_model_f64_t *`` (for other cffi callers)."""
        return self._c

    @property
    def c_model32(self) -> Any:
        """The ``aacmm_model_f32_t *`` of the single-precision core (built on first use)."""
        return self._model32()

    @property
    def arm(self) -> Arm:
        """The arm of this model (for :class:`Params`, :meth:`Params.to_arm`)."""
        return self._arm

    @property
    def joints(self) -> int:
        """N, the joint count: the width of every pose array."""
        return self._arm.n_joints

    @property
    def n_params(self) -> int:
        """P, the Jacobian's columns (25 for the paper's arm)."""
        return int(self._c.n_params)

    @property
    def param_names(self) -> tuple[str, ...]:
        """The P parameter names in Jacobian column order (:attr:`aacmm.arm.Arm.param_names`)."""
        return self._arm.param_names

    def _model32(self) -> Any:
        if not self._c32:  # built on first use; a race builds it twice, harmlessly
            c = ffi.new("aacmm_model_f32_t *")
            if isinstance(self.params, Params):
                st = lib.aacmm_model_init_f32(c, self.params.to_c32())
            else:
                st = lib.aacmm_model_init_arm_f32(c, _arm_c(self._arm, single=True))
            _check(st, "invalid parameters (single precision)")
            self._c32.append(c)
        return self._c32[0]

    def point(self, theta_rad: Sequence[float] | FloatArray) -> FloatArray:
        """Probe point (3,) in mm for one pose."""
        p: FloatArray = self.points(theta_rad)[0]
        return p

    def point_jacobian(
        self, theta_rad: Sequence[float] | FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Probe point (3,) and Jacobian (3, P) for one pose."""
        p, j = self.points_jacobians(theta_rad)
        return p[0], j[0]

    def points(
        self, theta_rad: npt.ArrayLike, dtype: npt.DTypeLike = np.float64
    ) -> npt.NDArray[Any]:
        """Probe points (n, 3) in mm. Raises KinematicsError for a bad pose."""
        p: npt.NDArray[Any] = self._batch(theta_rad, dtype, jacobian=False)[0]
        return p

    def points_jacobians(
        self, theta_rad: npt.ArrayLike, dtype: npt.DTypeLike = np.float64
    ) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
        """Probe points (n, 3) and Jacobians (n, 3, P), columns as :attr:`param_names`.

        Raises KinematicsError for a bad pose.
        """
        p, j = self._batch(theta_rad, dtype, jacobian=True)
        return p, j

    def points_jacobians_tiled(
        self, theta_rad: npt.ArrayLike, dtype: npt.DTypeLike = np.float64
    ) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
        """Probe points (n, 3) and the Jacobians in tiles, ``(tiles, 3, P, T)``.

        The same values as :meth:`points_jacobians`, bit for bit, in the
        layout the batch kernels write fastest (``aacmm/simd.h``): pose ``l``'s
        entry ``(r, c)`` is ``tiled[l // T, r, c, l % T]``, ``T`` =
        :data:`TILE_F64` (8) or :data:`TILE_F32` (16); the lanes of the last
        tile past the last pose repeat it. Each ``tiled[t, r, c]`` is one
        64-byte cache line (the array is 64-byte aligned). For consumers that
        work entry by entry over many poses (normal equations, sums);
        :func:`untile_jacobians` gives ``(n, 3, P)``. Raises KinematicsError
        for a bad pose.
        """
        p, j = self._batch(theta_rad, dtype, jacobian=True, tiled=True)
        return p, j

    def _batch(
        self, theta_rad: npt.ArrayLike, dtype: npt.DTypeLike, jacobian: bool, tiled: bool = False
    ) -> Any:
        single = _precision(dtype)
        th = _poses(theta_rad, np.float32 if single else np.float64, self.joints)
        n, cols = th.shape[0], self.n_params
        p = np.empty((n, 3), dtype=th.dtype)
        j: npt.NDArray[Any] | None
        if tiled:
            tile = TILE_F32 if single else TILE_F64
            j = _aligned_empty((-(-n // tile), JAC_ROWS, cols, tile), th.dtype)
            fn = (
                lib.aacmm_simd_batch_angles_tiled_f32
                if single
                else lib.aacmm_simd_batch_angles_tiled_f64
            )
        else:
            j = np.empty((n, JAC_ROWS, cols), dtype=th.dtype) if jacobian else None
            fn = lib.aacmm_simd_batch_angles_f32 if single else lib.aacmm_simd_batch_angles_f64
        done = ffi.new("size_t *")
        ptr = _fptr if single else _dptr
        model = self._model32() if single else self._c
        jp = ffi.NULL if j is None else ptr(j)
        st = fn(_current_kernel(), model, n, ptr(th), ptr(p), jp, done)
        _check(st, "invalid joint angles", int(done[0]) if st else None)
        return p, j

    def points_from_counts(
        self, counts: npt.ArrayLike, encoders: EncoderConfig | None = None
    ) -> tuple[FloatArray, FloatArray]:
        """Points (n, 3) and Jacobians (n, 3, P) from raw readings (n, N).

        Counts -> angles with the core's converter (as the firmware), then the
        batch kernel; ``encoders`` defaults to 2^32 counts/rev, offset 0,
        direction +1 on each joint. Raises ValueError for readings outside
        0 .. 2^32-1, a bad config or one of another joint count,
        KinematicsError (``index`` = pose) for a reading >= counts_per_rev.
        """
        enc = encoders if encoders is not None else EncoderConfig.default(self.joints)
        if enc.joints != self.joints:
            raise ValueError(
                f"the encoder configuration has {enc.joints} joints, the model {self.joints}"
            )
        p, j = self.points_jacobians(counts_to_angles(counts, enc))
        return p, j

    def abs_jacobian_sums(
        self,
        theta_rad: npt.ArrayLike,
        scale: npt.ArrayLike | None = None,
        offset: npt.ArrayLike | None = None,
    ) -> tuple[FloatArray, FloatArray]:
        """Sums over the poses of |J| and of J^2, each (3, P).

        The fused C loop on the batch kernel (``aacmm_simd_abs_jacobian_sums_f64``):
        no Jacobian is stored. With ``scale`` and ``offset`` (N values
        each) the poses are ``theta_rad * scale + offset`` per joint, formed
        in C (the same values as computing them with numpy first, one pass
        less). Raises KinematicsError for a bad pose.
        """
        th = _poses(theta_rad, joints=self.joints)
        s = np.zeros((JAC_ROWS, self.n_params), dtype=np.float64)
        q = np.zeros((JAC_ROWS, self.n_params), dtype=np.float64)
        done = ffi.new("size_t *")
        if scale is None and offset is None:
            st = lib.aacmm_simd_abs_jacobian_sums_f64(
                _current_kernel(), self._c, th.shape[0], _dptr(th), _dptr(s), _dptr(q), done
            )
        else:
            sc = np.ascontiguousarray(scale, dtype=np.float64).reshape(self.joints)
            off = np.ascontiguousarray(offset, dtype=np.float64).reshape(self.joints)
            st = lib.aacmm_simd_abs_jacobian_sums_scaled_f64(
                _current_kernel(),
                self._c,
                th.shape[0],
                _dptr(th),
                _dptr(sc),
                _dptr(off),
                _dptr(s),
                _dptr(q),
                done,
            )
        _check(st, "invalid joint angles", int(done[0]) if st else None)
        return s, q


def _counts(counts: npt.ArrayLike, joints: int) -> npt.NDArray[np.uint32]:
    raw = np.asarray(counts)
    if raw.ndim == 1 and raw.size == joints:
        raw = raw.reshape(1, joints)
    if raw.ndim != 2 or raw.shape[1] != joints:
        raise ValueError(f"encoder readings must have shape (n, {joints}), got {raw.shape}")
    if raw.size and (raw.min() < 0 or raw.max() > 0xFFFFFFFF):
        raise ValueError("encoder readings must be in 0 .. 2^32-1")
    return np.ascontiguousarray(raw, dtype=np.uint32)


def counts_to_angles(counts: npt.ArrayLike, encoders: EncoderConfig | None = None) -> FloatArray:
    """Joint angles (n, N) in rad from raw readings (n, N) with the core's converter.

    N is the encoder configuration's joint count (default: the paper's six).
    Raises ValueError for negative or non-integer-range readings and
    KinematicsError for a reading >= counts_per_rev.
    """
    cfg = encoders or EncoderConfig()
    c = _counts(counts, cfg.joints)
    enc = cfg.to_c()
    out = np.empty(c.shape, dtype=np.float64)
    done = ffi.new("size_t *")
    st = lib.aacmm_counts_to_angles_f64(
        enc, c.shape[0], ffi.cast("uint32_t *", ffi.from_buffer(c)), _dptr(out), done
    )
    _check(st, "invalid encoder reading", int(done[0]) if st else None)
    return out


def perturbed_points(
    nominal: Params | Arm, delta: npt.ArrayLike, theta_rad: npt.ArrayLike
) -> FloatArray:
    """Probe points (T, n, 3) of arms with parameters ``nominal + delta[t]``.

    ``delta`` is (T, P) in Jacobian column order (rad and mm; P = 25 for
    :class:`Params`, :attr:`aacmm.arm.Arm.n_params` for an arm); one model is
    built per trial and evaluated at every pose of ``theta_rad`` (n, N) on the
    batch kernel (as :meth:`Model.points`).
    Raises ValueError for bad shapes and KinematicsError (``index`` = trial)
    if a perturbed parameter set or a pose is invalid.
    """
    arm = nominal.to_arm() if isinstance(nominal, Params) else nominal
    d = np.ascontiguousarray(delta, dtype=np.float64)
    if d.ndim != 2 or d.shape[1] != arm.n_params:
        raise ValueError(f"parameter deltas must have shape (T, {arm.n_params}), got {d.shape}")
    th = _poses(theta_rad, joints=arm.n_joints)
    out = np.empty((d.shape[0], th.shape[0], 3), dtype=np.float64)
    done = ffi.new("size_t *")
    st = lib.aacmm_simd_perturbed_points_f64(
        _current_kernel(),
        _arm_c(arm),
        d.shape[0],
        _dptr(d),
        th.shape[0],
        _dptr(th),
        _dptr(out),
        done,
    )
    _check(st, "perturbed model invalid", int(done[0]) if st else None)
    return out
