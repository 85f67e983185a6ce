"""The simulated arm's true geometry and its error sources (docs/simulator.md, "Truth").

A :class:`Truth` is what the arm really is, as opposed to the parameter set
stored in the device: its structural parameters and encoder configuration
(the eight keys of a parameter file, docs/cli.md) plus error sources the
device's model cannot know:

- **encoder noise**: Gaussian, ``sigma_counts`` per joint, a fresh draw for
  every reading the simulated operator sends;
- **encoder reading errors** (what the DH model cannot describe): the
  reading of joint i is off by ``amplitude_arcsec[i] * sin(angle + phase_rad[i])``,
  once per revolution of the joint (the eccentricity of a disc mounted
  off-centre), plus harmonics ``k = 2..4``: ``A_ki sin(k angle + phase_ki)``
  (an encoder grade's, :mod:`aacmm.simulation.encgrade`);
- **probing noise**: the operator's probe tip sits ``N(0, sigma_um)`` per axis
  (isotropic Gaussian) away from the target at each point it probes.

The truth file (TOML, ``format = "aacmm-truth-1"``) is a parameter file that
``aacmm params set`` accepts (the truth tables are ignored there) plus the
tables ``[encoder_noise]``, ``[eccentricity]`` (harmonic 1), ``[harmonics]``
(orders 2..4, when there are any) and ``[probing]``; ``[origin]`` records how
it was made (``encoder_grade``: the grade of a random truth other than
two-head) and ``[arm] serial_number`` which device it is (the simulator
reports it in its device info). :func:`random_truth` perturbs a nominal set
by the documented :data:`~aacmm.simulation.perturb.RANDOM_SIZES` and draws
the encoders' harmonics of an encoder grade; :meth:`Truth.reading_error_model`
gives them in the C core's form. An optional ``[thermal]`` table holds each
link's material, true CTE and reference temperature
(:mod:`aacmm.simulation.thermal`, ``random_truth(..., thermal=True)``).

**Identity.** Every arm has a serial number of its own: an arm built to
drawing (the device's built-in set, no error source) is serial 1, as the
plain simulator; any other truth without an explicit ``[arm] serial_number``
gets one derived from its content (:attr:`Truth.device_serial`), so the same
truth is always the same device and two different truths are two devices.

**Any arm** (issue 26): ``params`` may be an :class:`aacmm.arm.Arm` of 4 to 7
joints (its encoders and error sources one entry per joint);
:func:`random_truth` of an arm perturbs every parameter of it, betas and tip
included, by the same sizes (angles: theta offsets, alphas, betas; lengths:
d, a and the tip). The truth file of such an arm is a parameter file of it
(:mod:`aacmm.records.paramfile`, "Any arm": N values per list, conventions,
betas, a tip vector) with the error tables of N values each; a file of the
paper's shape reads as the paper's :class:`~aacmm.core.Params`, any other as
an :class:`~aacmm.arm.Arm`. :mod:`aacmm.simulation.truthspec` reads
``--truth SPEC`` (of an arm model too).

Analysis code never reads a truth: only tests compare results with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final, Generic, overload

import numpy as np
import numpy.typing as npt

from aacmm.arm import Arm
from aacmm.core import JOINTS, EncoderConfig, Model, Params
from aacmm.errmodel import ErrorModel
from aacmm.errors import AacmmError
from aacmm.models import ArmModel
from aacmm.simulation.encgrade import (
    DEFAULT_GRADE,
    EncoderGrade,
    draw_harmonics,
    encoder_grade,
    harmonic_error_model,
    harmonics_from_table,
)
from aacmm.simulation.perturb import RANDOM_SIZES, RandomSizes, perturbed
from aacmm.simulation.thermal import (
    ThermalProfile,
    default_materials,
    profile_from_table,
    random_profile,
)

if TYPE_CHECKING:  # the default (PEP 696) is for the type checker only
    from typing_extensions import TypeVar

    #: The kind of a truth's geometry: the paper's Params (the default) or an Arm.
    P = TypeVar("P", Params, Arm, default=Params)
else:
    from typing import TypeVar

    P = TypeVar("P", Params, Arm)

FORMAT: Final = "aacmm-truth-1"
ARCSEC_RAD: Final = math.pi / (180.0 * 3600.0)
TABLES: Final = (
    "encoder_noise",
    "eccentricity",
    "harmonics",
    "probing",
    "thermal",
    "origin",
    "arm",
)
#: serial number of an arm built to drawing (the simulator's default device)
NOMINAL_SERIAL: Final = 1


class TruthError(AacmmError, ValueError):
    """A truth file or specification is not valid (exit status 2 in the CLI)."""


def _six(
    name: str, values: Any, src: str, lo: float = -math.inf, n: int = JOINTS
) -> tuple[float, ...]:
    if not isinstance(values, list) or len(values) != n:
        raise TruthError(f"{src}: {name} must be a list of {n} numbers")
    out = []
    for i, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise TruthError(f"{src}: {name}[{i}] must be a finite number, got {v!r}")
        if v < lo:
            raise TruthError(f"{src}: {name}[{i}]={v} must be >= {lo:g}")
        out.append(float(v))
    return tuple(out)


@dataclass(frozen=True)
class ErrorSources:
    """The truth's error sources; all zero = a perfect arm (see the module doc).

    One value per joint (six by default, the paper's arm; 1 to 7, all three
    tuples of one length); :meth:`none` for another joint count. The
    harmonics of order 2..4 (``harmonic_orders``, increasing): per order N
    amplitudes (arcsec, >= 0) and N phases (rad).
    """

    encoder_noise_counts: tuple[float, ...] = (0.0,) * JOINTS  #: Gaussian sigma, per reading
    eccentricity_arcsec: tuple[float, ...] = (0.0,) * JOINTS  #: once-per-rev amplitude
    eccentricity_phase_rad: tuple[float, ...] = (0.0,) * JOINTS
    probing_sigma_um: float = 0.0  #: isotropic Gaussian on the tip, per axis
    # not in the repr: a device serial made from it stays what it was without them
    harmonic_orders: tuple[int, ...] = field(default=(), repr=False)
    harmonic_arcsec: tuple[tuple[float, ...], ...] = field(default=(), repr=False)
    harmonic_phase_rad: tuple[tuple[float, ...], ...] = field(default=(), repr=False)

    def __post_init__(self) -> None:
        joints = len(tuple(self.encoder_noise_counts))
        if not 1 <= joints <= 7:
            raise ValueError(f"encoder_noise_counts needs 1 to 7 values, got {joints}")
        for name in ("encoder_noise_counts", "eccentricity_arcsec", "eccentricity_phase_rad"):
            v = tuple(float(x) for x in getattr(self, name))
            if len(v) != joints or not all(math.isfinite(x) for x in v):
                raise ValueError(f"{name} needs {joints} finite values")
            object.__setattr__(self, name, v)
        if min(self.encoder_noise_counts) < 0 or min(self.eccentricity_arcsec) < 0:
            raise ValueError("noise and eccentricity amplitudes must be >= 0")
        if not (math.isfinite(self.probing_sigma_um) and self.probing_sigma_um >= 0):
            raise ValueError("probing_sigma_um must be a finite number >= 0")
        orders = tuple(self.harmonic_orders)
        if list(orders) != sorted(set(orders)) or any(type(k) is not int for k in orders):
            raise ValueError(f"harmonic_orders must be increasing integers, got {list(orders)}")
        if not all(2 <= k <= 4 for k in orders):
            raise ValueError(f"harmonic_orders must be within 2..4, got {list(orders)}")
        for name in ("harmonic_arcsec", "harmonic_phase_rad"):
            rows = tuple(tuple(float(x) for x in row) for row in getattr(self, name))
            if len(rows) != len(orders) or any(
                len(r) != joints or not all(math.isfinite(x) for x in r) for r in rows
            ):
                raise ValueError(f"{name} needs {joints} finite values per harmonic order")
            object.__setattr__(self, name, rows)
        object.__setattr__(self, "harmonic_orders", orders)
        if any(x < 0 for r in self.harmonic_arcsec for x in r):
            raise ValueError("harmonic amplitudes must be >= 0")

    @classmethod
    def none(cls, joints: int = JOINTS) -> ErrorSources:
        """No error source on ``joints`` joints."""
        zeros = (0.0,) * joints
        return cls(zeros, zeros, zeros)

    @property
    def joints(self) -> int:
        """The number of joints described."""
        return len(self.encoder_noise_counts)

    @property
    def noise_free(self) -> bool:
        """No random error at all (eccentricity, being systematic, may remain)."""
        return max(self.encoder_noise_counts) == 0 and self.probing_sigma_um == 0

    @property
    def perfect(self) -> bool:
        """No error source at all."""
        higher = max((x for r in self.harmonic_arcsec for x in r), default=0.0)
        return self.noise_free and max(self.eccentricity_arcsec) == 0 and higher == 0

    def harmonics_arcsec(self) -> dict[int, tuple[tuple[float, ...], tuple[float, ...]]]:
        """Every harmonic order of the reading error: ``{k: (amplitudes, phases)}``,
        N values each (order 1 is the eccentricity)."""
        out = {1: (self.eccentricity_arcsec, self.eccentricity_phase_rad)}
        for k, a, p in zip(
            self.harmonic_orders, self.harmonic_arcsec, self.harmonic_phase_rad, strict=True
        ):
            out[k] = (a, p)
        return out


@dataclass(frozen=True)
class Truth(Generic[P]):
    """An arm's true geometry, encoders and error sources.

    ``params``: the paper's 25-parameter form or any :class:`aacmm.arm.Arm`
    (``Truth[Params]``, the default, or ``Truth[Arm]``);
    ``encoders`` and ``errors`` have one entry per joint of it. Raises
    ValueError (KinematicsError for values the core rejects) if not.
    """

    params: P = field(default_factory=Params)  # type: ignore[assignment]
    encoders: EncoderConfig = field(default_factory=EncoderConfig)
    errors: ErrorSources = field(default_factory=ErrorSources)
    origin: dict[str, Any] = field(default_factory=dict, compare=False)
    serial_number: int | None = field(default=None, compare=False)
    thermal: ThermalProfile | None = None  #: None: lengths the same at every temperature

    def __post_init__(self) -> None:
        if isinstance(self.params, Params):
            self.params.validate()
        else:
            Model(self.params)  # raises KinematicsError if the core rejects the arm
        joints = self.joints
        if self.encoders.joints != joints or self.errors.joints != joints:
            raise ValueError(
                f"the arm has {joints} joints, the encoders {self.encoders.joints}, "
                f"the error sources {self.errors.joints}"
            )
        self.encoders.to_c()  # raises ValueError if out of range
        if self.thermal is not None and self.thermal.links != joints:
            raise ValueError(
                f"the arm has {joints} links, the thermal profile {self.thermal.links}"
            )
        sn = self.serial_number
        if sn is not None and not (isinstance(sn, int) and 0 <= sn <= 0xFFFFFFFF):
            raise ValueError(f"serial_number must be an integer 0..2^32-1, got {sn!r}")

    @property
    def device_serial(self) -> int:
        """The device serial number of this arm (module doc, "Identity")."""
        if self.serial_number is not None:
            return self.serial_number
        if self.params == Params() and self.errors.perfect and self.thermal is None:
            return NOMINAL_SERIAL
        import json
        import zlib

        if isinstance(self.params, Params):
            body = {k: v for k, v in self.to_mapping().items() if k not in ("origin", "arm")}
        else:
            body = {
                "arm": repr(self.params),
                "encoders": repr(self.encoders),
                "errors": repr(self.errors),
            }
            data = self.to_mapping()
            body.update({t: repr(data[t]) for t in ("harmonics", "thermal") if t in data})
        crc = zlib.crc32(json.dumps(body, sort_keys=True).encode())
        return 0x40000000 | (crc & 0x3FFFFFFF)  # never 1, within 31 bits

    @property
    def joints(self) -> int:
        """N, the arm's joint count."""
        return len(self.params.d_mm) if isinstance(self.params, Params) else self.params.n_joints

    def model(self) -> Model:
        """The true kinematic model (double precision core)."""
        return Model(self.params)

    # ------------------------------------------------------------ encoders

    def reading_error_rad(self, theta_rad: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """The reading error (n, N) in rad of readings at joint angles ``theta_rad``:
        the eccentricity ``A sin(theta + phase)`` plus every harmonic order k of
        ``[harmonics]``, ``A_k sin(k theta + phase_k)``."""
        th = np.asarray(theta_rad, dtype=np.float64)
        amp = np.asarray(self.errors.eccentricity_arcsec) * ARCSEC_RAD
        phase = np.asarray(self.errors.eccentricity_phase_rad)
        out: npt.NDArray[np.float64] = amp * np.sin(th + phase)
        x = self.errors
        for k, a, p in zip(x.harmonic_orders, x.harmonic_arcsec, x.harmonic_phase_rad, strict=True):
            out = out + np.asarray(a) * ARCSEC_RAD * np.sin(k * th + np.asarray(p))
        return out

    def reading_error_model(self) -> ErrorModel:
        """The reading error as the C core's error model (no thermal part): its
        corrected angles of the true angles are the true readings (before noise
        and rounding); a calibration of readings finds about the opposite (to
        first order). :func:`~aacmm.simulation.encgrade.harmonic_error_model`."""
        return harmonic_error_model(self.errors.harmonics_arcsec())

    def counts(
        self, theta_rad: npt.ArrayLike, rng: np.random.Generator | None = None
    ) -> npt.NDArray[np.int64]:
        """Raw readings (n, N) of the true encoders at joint angles ``theta_rad`` (n, N).

        ``theta_rad`` are the angles the core's encoder conversion would
        return for perfect encoders (the DH angle minus the theta offset).
        Each reading is ``zero + direction * round((theta + e(theta)) * cpr / 2 pi
        + noise)`` modulo cpr, with the eccentricity ``e`` and, if ``rng`` is
        given, Gaussian noise of ``encoder_noise_counts``.
        """
        th = np.atleast_2d(np.asarray(theta_rad, dtype=np.float64))
        if th.shape[-1] != self.joints:
            raise ValueError(f"joint angles must have shape (n, {self.joints})")
        cpr = np.asarray(self.encoders.counts_per_rev, dtype=np.float64)
        steps = (th + self.reading_error_rad(th)) * cpr / (2.0 * math.pi)
        if rng is not None and max(self.errors.encoder_noise_counts) > 0:
            steps = steps + rng.normal(size=th.shape) * np.asarray(self.errors.encoder_noise_counts)
        s = np.rint(steps).astype(np.int64)
        direction = np.asarray(self.encoders.direction, dtype=np.int64)
        zero = np.asarray(self.encoders.zero_offset_counts, dtype=np.int64)
        out: npt.NDArray[np.int64] = (zero + direction * s) % np.asarray(
            self.encoders.counts_per_rev, dtype=np.int64
        )
        return out

    def probing_offset_mm(self, rng: np.random.Generator | None) -> npt.NDArray[np.float64]:
        """Where the tip really sits relative to the target (3,): the probing noise."""
        if rng is None or self.errors.probing_sigma_um == 0:
            return np.zeros(3)
        out: npt.NDArray[np.float64] = rng.normal(size=3) * self.errors.probing_sigma_um * 1e-3
        return out

    # ------------------------------------------------------------ file form

    def to_mapping(self) -> dict[str, Any]:
        """The truth file's content (TOML-ready): a parameter file of the arm
        (any shape, :func:`aacmm.records.paramfile.param_set_dict`) and the tables."""
        from aacmm.protocol import ParamSet
        from aacmm.records.paramfile import param_set_dict

        p, e, x = self.params, self.encoders, self.errors
        ps = ParamSet.from_core(p, e) if isinstance(p, Params) else ParamSet.from_arm(p, e)
        data: dict[str, Any] = {
            "format": FORMAT,
            **param_set_dict(ps),
            "encoder_noise": {"sigma_counts": list(x.encoder_noise_counts)},
            "eccentricity": {
                "amplitude_arcsec": list(x.eccentricity_arcsec),
                "phase_rad": list(x.eccentricity_phase_rad),
            },
        }
        if x.harmonic_orders:
            data["harmonics"] = {
                "order": list(x.harmonic_orders),
                "amplitude_arcsec": [list(r) for r in x.harmonic_arcsec],
                "phase_rad": [list(r) for r in x.harmonic_phase_rad],
            }
        data["probing"] = {"sigma_um": x.probing_sigma_um}
        if self.thermal is not None:
            data["thermal"] = {
                "material": list(self.thermal.material),
                "cte_per_k": list(self.thermal.cte_per_k),
                "tref_c": list(self.thermal.tref_c),
            }
        if self.origin:
            data["origin"] = dict(self.origin)
        if self.serial_number is not None:
            data["arm"] = {"serial_number": self.serial_number}
        return data

    def dumps(self) -> str:
        """The truth file's text (TOML)."""
        import tomli_w

        head = (
            "# aacmm simulated arm: its TRUE geometry (docs/simulator.md). A parameter file\n"
            "# ('aacmm params set' reads the eight parameter keys) plus error sources.\n"
        )
        data = self.to_mapping()
        data["arm"] = {"serial_number": self.device_serial}
        return head + tomli_w.dumps(data)


def truth_from_mapping(data: Any, src: str = "truth") -> Truth[Any]:
    """A :class:`Truth` from a truth file's content.

    Raises:
        TruthError: a missing, unknown or bad key (the message names ``src`` and the key).
    """
    from aacmm.records.paramfile import ParamFileError, param_set_from_mapping

    if not isinstance(data, dict):
        raise TruthError(f"{src}: expected a table")
    fmt = data.get("format", FORMAT)
    if fmt != FORMAT:
        raise TruthError(f"{src}: format is {fmt!r}, expected {FORMAT!r}")
    for key, value in data.items():
        if key in TABLES and not isinstance(value, dict):
            raise TruthError(f"{src}: {key} must be a table")
    plain = {k: v for k, v in data.items() if k not in TABLES and k != "format"}
    try:
        ps = param_set_from_mapping(plain, src)
    except ParamFileError as exc:
        raise TruthError(str(exc)) from None
    noise = dict(data.get("encoder_noise", {}))
    ecc = dict(data.get("eccentricity", {}))
    harm = dict(data.get("harmonics", {}))
    thermal = dict(data.get("thermal", {}))
    probing = dict(data.get("probing", {}))
    for table, got, allowed in (
        ("encoder_noise", noise, {"sigma_counts"}),
        ("eccentricity", ecc, {"amplitude_arcsec", "phase_rad"}),
        ("harmonics", harm, {"order", "amplitude_arcsec", "phase_rad"}),
        ("thermal", thermal, {"material", "cte_per_k", "tref_c"}),
        ("probing", probing, {"sigma_um"}),
    ):
        for k in got:
            if k not in allowed:
                raise TruthError(f"{src}: unknown key {table}.{k}")
    n = ps.joints
    zeros = [0.0] * n
    sigma_um = probing.get("sigma_um", 0.0)
    if isinstance(sigma_um, bool) or not isinstance(sigma_um, (int, float)):
        raise TruthError(f"{src}: probing.sigma_um must be a number")
    if not (math.isfinite(sigma_um) and sigma_um >= 0):
        raise TruthError(f"{src}: probing.sigma_um must be a finite number >= 0")
    errors = ErrorSources(
        encoder_noise_counts=_six(
            "encoder_noise.sigma_counts", noise.get("sigma_counts", zeros), src, 0.0, n
        ),
        eccentricity_arcsec=_six(
            "eccentricity.amplitude_arcsec", ecc.get("amplitude_arcsec", zeros), src, 0.0, n
        ),
        eccentricity_phase_rad=_six(
            "eccentricity.phase_rad", ecc.get("phase_rad", zeros), src, -math.inf, n
        ),
        probing_sigma_um=float(sigma_um),
        **_table(harmonics_from_table, harm, n, src),
    )
    origin = data.get("origin", {})
    arm = dict(data.get("arm", {}))
    for k in arm:
        if k != "serial_number":
            raise TruthError(f"{src}: unknown key arm.{k}")
    serial = arm.get("serial_number")
    if serial is not None and (
        isinstance(serial, bool) or not isinstance(serial, int) or not 0 <= serial <= 0xFFFFFFFF
    ):
        raise TruthError(f"{src}: arm.serial_number must be an integer 0..2^32-1")
    params: Params | Arm
    if ps.is_paper_shape:
        params = Params(ps.theta_offset_rad, ps.alpha_rad, ps.d_mm, ps.a_mm, ps.l_mm)
    else:
        try:
            params = ps.to_arm()[0]
        except ValueError as exc:
            raise TruthError(f"{src}: {exc}") from None
    return Truth[Any](
        params=params,
        encoders=EncoderConfig(ps.counts_per_rev, ps.zero_offset_counts, ps.direction),
        errors=errors,
        origin=dict(origin) if isinstance(origin, dict) else {},
        serial_number=serial,
        thermal=_table(profile_from_table, thermal, n, src) or None,
    )


def _table(parse: Any, table: dict[str, Any], n: int, src: str) -> Any:
    """An optional table's value (``{}`` if absent) from ``parse``, its errors named."""
    if not table:
        return {}
    try:
        return parse(table, n)
    except ValueError as exc:
        raise TruthError(f"{src}: {exc}") from None


def load_truth(path: str | Path) -> Truth[Any]:
    """Read and check a truth file (TOML).

    Raises:
        TruthError: unreadable, not TOML, or not a valid truth (file and key named).
    """
    from aacmm.fileio import InputFileError, load_toml

    try:
        data = load_toml(path)
    except InputFileError as exc:
        raise TruthError(str(exc)) from None
    truth = truth_from_mapping(data, str(path))
    return replace(truth, origin={"kind": "file", "path": str(path), **truth.origin})


@overload
def nominal_truth(params: Params | None = None, cpr: int = 1 << 32) -> Truth[Params]: ...
@overload
def nominal_truth(params: Arm, cpr: int = 1 << 32) -> Truth[Arm]: ...
def nominal_truth(params: Params | Arm | None = None, cpr: int = 1 << 32) -> Truth[Any]:
    """A perfect arm equal to ``params`` (default: the paper's Table 1, the
    simulator's default set; or any arm) with ``cpr`` counts per revolution,
    zero offsets 0 and direction +1: the device's built-in set, no error source."""
    p: Params | Arm = params or Params()
    joints = len(p.d_mm) if isinstance(p, Params) else p.n_joints
    return Truth[Any](
        params=p,
        encoders=EncoderConfig((cpr,) * joints, (0,) * joints, (1,) * joints),
        errors=ErrorSources.none(joints),
        origin={"kind": "nominal"},
    )


@overload
def random_truth(
    seed: int,
    nominal: Params | None = None,
    cpr: int = 1 << 32,
    sizes: RandomSizes = RANDOM_SIZES,
    encoders: EncoderConfig | None = None,
    grade: EncoderGrade | str = DEFAULT_GRADE,
    thermal: bool = False,
) -> Truth[Params]: ...
@overload
def random_truth(
    seed: int,
    nominal: Arm,
    cpr: int = 1 << 32,
    sizes: RandomSizes = RANDOM_SIZES,
    encoders: EncoderConfig | None = None,
    grade: EncoderGrade | str = DEFAULT_GRADE,
    thermal: bool = False,
) -> Truth[Arm]: ...
def random_truth(
    seed: int,
    nominal: Params | Arm | None = None,
    cpr: int = 1 << 32,
    sizes: RandomSizes = RANDOM_SIZES,
    encoders: EncoderConfig | None = None,
    grade: EncoderGrade | str = DEFAULT_GRADE,
    thermal: bool = False,
) -> Truth[Any]:
    """A random arm near ``nominal`` (default Table 1, or any arm): every
    structural parameter perturbed uniformly by ``sizes`` (:func:`perturbed`),
    encoder noise and probing noise of ``sizes`` on each joint, the encoders'
    reading errors drawn from ``grade`` (a name or an
    :class:`~aacmm.simulation.encgrade.EncoderGrade`; order 1 is the
    eccentricity, orders 2..4 the ``[harmonics]``). Same seed, same arm (numpy
    PCG64; the geometry is the same for every grade, and two-head, the
    default, is the random truth of before grades existed). ``encoders``: the
    arm's encoders (an arm model's, :func:`model_truth`) instead of ``cpr``
    counts on every joint, zero offset 0, direction +1; the noise in counts
    follows each joint's resolution. ``thermal``: also a thermal profile,
    :func:`~aacmm.simulation.thermal.random_profile` of the nominal arm's
    :func:`~aacmm.simulation.thermal.default_materials`, drawn last (the rest
    is the same arm as without it).

    Raises:
        TruthError: a seed outside 0 .. 2^64-1, encoders of another joint count.
        EncoderGradeError: an unknown grade name.
    """
    if not 0 <= seed < 1 << 64:
        raise TruthError(f"random truth seed {seed} outside 0 .. 2^64-1")
    g = encoder_grade(grade) if isinstance(grade, str) else grade
    nom: Params | Arm = nominal or Params()
    joints = len(nom.d_mm) if isinstance(nom, Params) else nom.n_joints
    rng = np.random.Generator(np.random.PCG64(seed))
    params = perturbed(nom, rng, sizes)
    enc = encoders or EncoderConfig((cpr,) * joints, (0,) * joints, (1,) * joints)
    if enc.joints != joints:
        raise TruthError(f"the encoders describe {enc.joints} joints, the arm has {joints}")
    noise = tuple(
        sizes.encoder_noise_arcsec * ARCSEC_RAD * c / (2.0 * math.pi) for c in enc.counts_per_rev
    )
    h = draw_harmonics(g, rng, joints)
    errors = ErrorSources(
        encoder_noise_counts=noise,
        eccentricity_arcsec=h.amplitude_arcsec[0],
        eccentricity_phase_rad=h.phase_rad[0],
        probing_sigma_um=sizes.probing_sigma_um,
        harmonic_orders=tuple(range(2, g.orders + 1)),
        harmonic_arcsec=h.amplitude_arcsec[1:],
        harmonic_phase_rad=h.phase_rad[1:],
    )
    grade_origin = {} if g.name == DEFAULT_GRADE else {"encoder_grade": g.name}
    profile = random_profile(rng, default_materials(nom)) if thermal else None
    return Truth[Any](
        params=params,
        encoders=enc,
        errors=errors,
        origin={
            "kind": "random",
            "seed": seed,
            "length_mm": sizes.length_mm,
            "angle_deg": sizes.angle_deg,
            "encoder_noise_arcsec": sizes.encoder_noise_arcsec,
            "eccentricity_arcsec": list(g.amplitude_arcsec[0]),
            "probing_sigma_um": sizes.probing_sigma_um,
            **grade_origin,
        },
        thermal=profile,
    )


def model_truth(
    seed: int,
    model: ArmModel,
    sizes: RandomSizes = RANDOM_SIZES,
    grade: EncoderGrade | str = DEFAULT_GRADE,
) -> Truth[Arm]:
    """A random true arm of an arm model (:mod:`aacmm.models`): its arm perturbed as
    :func:`random_truth`, its own encoders (reading errors of ``grade``). Same seed,
    same arm."""
    truth = random_truth(seed, model.arm, sizes=sizes, encoders=model.encoder_config(), grade=grade)
    return replace(truth, origin={**truth.origin, "model": model.name})
