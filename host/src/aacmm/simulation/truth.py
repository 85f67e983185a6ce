"""The simulated arm's true geometry and its error sources (docs/simulator.md, "Truth").

A :class:`Truth` is what the arm really is, as opposed to the parameter set
stored in the device: its structural parameters and encoder configuration
(the eight keys of a parameter file, docs/cli.md) plus error sources the
device's model cannot know:

- **encoder noise**: Gaussian, ``sigma_counts`` per joint, a fresh draw for
  every reading the simulated operator sends;
- **encoder eccentricity** (an error the DH model cannot describe): the
  reading of joint i is off by ``amplitude_arcsec[i] * sin(angle + phase_rad[i])``,
  once per revolution of the joint, as an encoder disc mounted off-centre
  and read by one head;
- **probing noise**: the operator's probe tip sits ``N(0, sigma_um)`` per axis
  (isotropic Gaussian) away from the target at each point it probes.

The truth file (TOML, ``format = "aacmm-truth-1"``) is a parameter file that
``aacmm params set`` accepts (the truth tables are ignored there) plus the
tables ``[encoder_noise]``, ``[eccentricity]`` and ``[probing]``; ``[origin]``
records how it was made and ``[arm] serial_number`` which device it is (the
simulator reports it in its device info). :func:`random_truth` perturbs a
nominal set by the documented :data:`RANDOM_SIZES`.

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
an :class:`~aacmm.arm.Arm`. :func:`check_truth_model` refuses a truth whose
arm is not of a model's shape (joint count, conventions, betas, tip kind).

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
from aacmm.errors import AacmmError
from aacmm.models import ArmModel

if TYPE_CHECKING:  # the default (PEP 696) is for the type checker only
    from typing_extensions import TypeVar

    #: The kind of a truth's geometry: the paper's Params (the default) or an Arm.
    P = TypeVar("P", Params, Arm, default=Params)
else:
    from typing import TypeVar

    P = TypeVar("P", Params, Arm)

FORMAT: Final = "aacmm-truth-1"
ARCSEC_RAD: Final = math.pi / (180.0 * 3600.0)
TABLES: Final = ("encoder_noise", "eccentricity", "probing", "origin", "arm")
#: serial number of an arm built to drawing (the simulator's default device)
NOMINAL_SERIAL: Final = 1


@dataclass(frozen=True)
class RandomSizes:
    """Perturbation sizes of :func:`random_truth` (uniform on +-size unless stated)."""

    length_mm: float = 0.5  #: d, a (each joint) and l (an arm: each tip component)
    angle_deg: float = 0.05  #: alpha and theta offset of each joint (an arm: each beta too)
    encoder_noise_arcsec: float = 0.3  #: sigma of the encoder noise (same on every joint)
    eccentricity_arcsec: tuple[float, float] = (0.5, 2.0)  #: amplitude, uniform in this range
    probing_sigma_um: float = 2.0  #: probing noise sigma per axis


#: The documented sizes of ``--truth random:SEED`` (docs/simulator.md).
RANDOM_SIZES: Final = RandomSizes()


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
    tuples of one length); :meth:`none` for another joint count.
    """

    encoder_noise_counts: tuple[float, ...] = (0.0,) * JOINTS  #: Gaussian sigma, per reading
    eccentricity_arcsec: tuple[float, ...] = (0.0,) * JOINTS  #: once-per-rev amplitude
    eccentricity_phase_rad: tuple[float, ...] = (0.0,) * JOINTS
    probing_sigma_um: float = 0.0  #: isotropic Gaussian on the tip, per axis

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
        return self.noise_free and max(self.eccentricity_arcsec) == 0


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
        sn = self.serial_number
        if sn is not None and not (isinstance(sn, int) and 0 <= sn <= 0xFFFFFFFF):
            raise ValueError(f"serial_number must be an integer 0..2^32-1, got {sn!r}")

    @property
    def device_serial(self) -> int:
        """The device serial number of this arm (module doc, "Identity")."""
        if self.serial_number is not None:
            return self.serial_number
        if self.params == Params() and self.errors.perfect:
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
        """The eccentricity error (n, N) in rad of readings at joint angles ``theta_rad``."""
        th = np.asarray(theta_rad, dtype=np.float64)
        amp = np.asarray(self.errors.eccentricity_arcsec) * ARCSEC_RAD
        phase = np.asarray(self.errors.eccentricity_phase_rad)
        out: npt.NDArray[np.float64] = amp * np.sin(th + phase)
        return out

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
            "probing": {"sigma_um": x.probing_sigma_um},
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
    probing = dict(data.get("probing", {}))
    for table, got, allowed in (
        ("encoder_noise", noise, {"sigma_counts"}),
        ("eccentricity", ecc, {"amplitude_arcsec", "phase_rad"}),
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
    )


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


@overload
def random_truth(
    seed: int,
    nominal: Params | None = None,
    cpr: int = 1 << 32,
    sizes: RandomSizes = RANDOM_SIZES,
    encoders: EncoderConfig | None = None,
) -> Truth[Params]: ...
@overload
def random_truth(
    seed: int,
    nominal: Arm,
    cpr: int = 1 << 32,
    sizes: RandomSizes = RANDOM_SIZES,
    encoders: EncoderConfig | None = None,
) -> Truth[Arm]: ...
def random_truth(
    seed: int,
    nominal: Params | Arm | None = None,
    cpr: int = 1 << 32,
    sizes: RandomSizes = RANDOM_SIZES,
    encoders: EncoderConfig | None = None,
) -> Truth[Any]:
    """A random arm near ``nominal`` (default Table 1, or any arm): every
    structural parameter perturbed uniformly by ``sizes`` (:func:`perturbed`),
    encoder noise, eccentricity and probing noise of ``sizes`` on each joint.
    Same seed, same arm (numpy PCG64). ``encoders``: the arm's encoders (an
    arm model's, :func:`model_truth`) instead of ``cpr`` counts on every joint,
    zero offset 0, direction +1; the noise in counts follows each joint's
    resolution."""
    if not 0 <= seed < 1 << 64:
        raise TruthError(f"random truth seed {seed} outside 0 .. 2^64-1")
    nom: Params | Arm = nominal or Params()
    joints = len(nom.d_mm) if isinstance(nom, Params) else nom.n_joints
    rng = np.random.Generator(np.random.PCG64(seed))
    params = perturbed(nom, rng, sizes)
    lo, hi = sizes.eccentricity_arcsec
    enc = encoders or EncoderConfig((cpr,) * joints, (0,) * joints, (1,) * joints)
    if enc.joints != joints:
        raise TruthError(f"the encoders describe {enc.joints} joints, the arm has {joints}")
    noise = tuple(
        sizes.encoder_noise_arcsec * ARCSEC_RAD * c / (2.0 * math.pi) for c in enc.counts_per_rev
    )
    errors = ErrorSources(
        encoder_noise_counts=noise,
        eccentricity_arcsec=tuple(float(v) for v in rng.uniform(lo, hi, joints)),
        eccentricity_phase_rad=tuple(float(v) for v in rng.uniform(0.0, 2.0 * math.pi, joints)),
        probing_sigma_um=sizes.probing_sigma_um,
    )
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
            "eccentricity_arcsec": list(sizes.eccentricity_arcsec),
            "probing_sigma_um": sizes.probing_sigma_um,
        },
    )


def model_truth(seed: int, model: ArmModel, sizes: RandomSizes = RANDOM_SIZES) -> Truth[Arm]:
    """A random true arm of an arm model (:mod:`aacmm.models`): its arm perturbed as
    :func:`random_truth`, its own encoders. Same seed, same arm."""
    truth = random_truth(seed, model.arm, sizes=sizes, encoders=model.encoder_config())
    return replace(truth, origin={**truth.origin, "model": model.name})


def parse_truth(spec: str, cpr: int = 1 << 32) -> Truth:
    """``--truth SPEC``: ``nominal``, ``random:SEED`` or a truth file path.

    Raises:
        TruthError: a bad seed or a bad file.
    """
    if spec == "nominal":
        return nominal_truth(cpr=cpr)
    if spec.startswith("random:"):
        text = spec[len("random:") :]
        if not text.isdigit():
            raise TruthError(f"--truth {spec}: the seed must be a non-negative integer")
        return random_truth(int(text), cpr=cpr)
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


def parse_model_truth(spec: str, model: ArmModel) -> Truth[Any]:
    """``--truth SPEC`` for an arm model: ``nominal`` (its nominal arm and encoders,
    no error source), ``random:SEED`` (:func:`model_truth`) or a truth file of
    the model's shape (:func:`check_truth_model`).

    Raises:
        TruthError: a bad seed, a bad file, or a truth of another shape.
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
        return model_truth(int(text), model)
    truth = load_truth(spec)
    check_truth_model(truth, model, spec)
    return truth
