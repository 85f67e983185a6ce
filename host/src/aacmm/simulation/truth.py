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

Analysis code never reads a truth: only tests compare results with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from aacmm.core import JOINTS, EncoderConfig, Model, Params
from aacmm.errors import AacmmError

FORMAT: Final = "aacmm-truth-1"
ARCSEC_RAD: Final = math.pi / (180.0 * 3600.0)
TABLES: Final = ("encoder_noise", "eccentricity", "probing", "origin", "arm")
#: serial number of an arm built to drawing (the simulator's default device)
NOMINAL_SERIAL: Final = 1


@dataclass(frozen=True)
class RandomSizes:
    """Perturbation sizes of :func:`random_truth` (uniform on +-size unless stated)."""

    length_mm: float = 0.5  #: d, a (each joint) and l
    angle_deg: float = 0.05  #: alpha and theta offset of each joint
    encoder_noise_arcsec: float = 0.3  #: sigma of the encoder noise (same on every joint)
    eccentricity_arcsec: tuple[float, float] = (0.5, 2.0)  #: amplitude, uniform in this range
    probing_sigma_um: float = 2.0  #: probing noise sigma per axis


#: The documented sizes of ``--truth random:SEED`` (docs/simulator.md).
RANDOM_SIZES: Final = RandomSizes()


class TruthError(AacmmError, ValueError):
    """A truth file or specification is not valid (exit status 2 in the CLI)."""


def _six(name: str, values: Any, src: str, lo: float = -math.inf) -> tuple[float, ...]:
    if not isinstance(values, list) or len(values) != JOINTS:
        raise TruthError(f"{src}: {name} must be a list of {JOINTS} numbers")
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
    """The truth's error sources; all zero = a perfect arm (see the module doc)."""

    encoder_noise_counts: tuple[float, ...] = (0.0,) * JOINTS  #: Gaussian sigma, per reading
    eccentricity_arcsec: tuple[float, ...] = (0.0,) * JOINTS  #: once-per-rev amplitude
    eccentricity_phase_rad: tuple[float, ...] = (0.0,) * JOINTS
    probing_sigma_um: float = 0.0  #: isotropic Gaussian on the tip, per axis

    def __post_init__(self) -> None:
        for name in ("encoder_noise_counts", "eccentricity_arcsec", "eccentricity_phase_rad"):
            v = tuple(float(x) for x in getattr(self, name))
            if len(v) != JOINTS or not all(math.isfinite(x) for x in v):
                raise ValueError(f"{name} needs {JOINTS} finite values")
            object.__setattr__(self, name, v)
        if min(self.encoder_noise_counts) < 0 or min(self.eccentricity_arcsec) < 0:
            raise ValueError("noise and eccentricity amplitudes must be >= 0")
        if not (math.isfinite(self.probing_sigma_um) and self.probing_sigma_um >= 0):
            raise ValueError("probing_sigma_um must be a finite number >= 0")

    @property
    def noise_free(self) -> bool:
        """No random error at all (eccentricity, being systematic, may remain)."""
        return max(self.encoder_noise_counts) == 0 and self.probing_sigma_um == 0

    @property
    def perfect(self) -> bool:
        """No error source at all."""
        return self.noise_free and max(self.eccentricity_arcsec) == 0


@dataclass(frozen=True)
class Truth:
    """An arm's true geometry, encoders and error sources."""

    params: Params = field(default_factory=Params)
    encoders: EncoderConfig = field(default_factory=EncoderConfig)
    errors: ErrorSources = field(default_factory=ErrorSources)
    origin: dict[str, Any] = field(default_factory=dict, compare=False)
    serial_number: int | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        self.params.validate()
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

        body = {k: v for k, v in self.to_mapping().items() if k not in ("origin", "arm")}
        crc = zlib.crc32(json.dumps(body, sort_keys=True).encode())
        return 0x40000000 | (crc & 0x3FFFFFFF)  # never 1, within 31 bits

    def model(self) -> Model:
        """The true kinematic model (double precision core)."""
        return Model(self.params)

    # ------------------------------------------------------------ encoders

    def reading_error_rad(self, theta_rad: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """The eccentricity error (n, 6) in rad of readings at joint angles ``theta_rad``."""
        th = np.asarray(theta_rad, dtype=np.float64)
        amp = np.asarray(self.errors.eccentricity_arcsec) * ARCSEC_RAD
        phase = np.asarray(self.errors.eccentricity_phase_rad)
        out: npt.NDArray[np.float64] = amp * np.sin(th + phase)
        return out

    def counts(
        self, theta_rad: npt.ArrayLike, rng: np.random.Generator | None = None
    ) -> npt.NDArray[np.int64]:
        """Raw readings (n, 6) of the true encoders at joint angles ``theta_rad`` (n, 6).

        ``theta_rad`` are the angles the core's encoder conversion would
        return for perfect encoders (the DH angle minus the theta offset).
        Each reading is ``zero + direction * round((theta + e(theta)) * cpr / 2 pi
        + noise)`` modulo cpr, with the eccentricity ``e`` and, if ``rng`` is
        given, Gaussian noise of ``encoder_noise_counts``.
        """
        th = np.atleast_2d(np.asarray(theta_rad, dtype=np.float64))
        if th.shape[-1] != JOINTS:
            raise ValueError(f"joint angles must have shape (n, {JOINTS})")
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
        """The truth file's content (TOML-ready)."""
        p, e, x = self.params, self.encoders, self.errors
        data: dict[str, Any] = {
            "format": FORMAT,
            "theta_offset_rad": list(p.theta_offset_rad),
            "alpha_rad": list(p.alpha_rad),
            "d_mm": list(p.d_mm),
            "a_mm": list(p.a_mm),
            "l_mm": p.l_mm,
            "counts_per_rev": list(e.counts_per_rev),
            "zero_offset_counts": list(e.zero_offset_counts),
            "direction": list(e.direction),
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


def truth_from_mapping(data: Any, src: str = "truth") -> Truth:
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
    zeros = [0.0] * JOINTS
    sigma_um = probing.get("sigma_um", 0.0)
    if isinstance(sigma_um, bool) or not isinstance(sigma_um, (int, float)):
        raise TruthError(f"{src}: probing.sigma_um must be a number")
    if not (math.isfinite(sigma_um) and sigma_um >= 0):
        raise TruthError(f"{src}: probing.sigma_um must be a finite number >= 0")
    errors = ErrorSources(
        encoder_noise_counts=_six(
            "encoder_noise.sigma_counts", noise.get("sigma_counts", zeros), src, 0.0
        ),
        eccentricity_arcsec=_six(
            "eccentricity.amplitude_arcsec", ecc.get("amplitude_arcsec", zeros), src, 0.0
        ),
        eccentricity_phase_rad=_six("eccentricity.phase_rad", ecc.get("phase_rad", zeros), src),
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
    return Truth(
        params=Params(ps.theta_offset_rad, ps.alpha_rad, ps.d_mm, ps.a_mm, ps.l_mm),
        encoders=EncoderConfig(ps.counts_per_rev, ps.zero_offset_counts, ps.direction),
        errors=errors,
        origin=dict(origin) if isinstance(origin, dict) else {},
        serial_number=serial,
    )


def load_truth(path: str | Path) -> Truth:
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


def nominal_truth(params: Params | None = None, cpr: int = 1 << 32) -> Truth:
    """A perfect arm equal to ``params`` (default: the paper's Table 1, the
    simulator's default set) with ``cpr`` counts per revolution, zero offsets 0
    and direction +1: the device's built-in set, no error source."""
    return Truth(
        params=params or Params(),
        encoders=EncoderConfig((cpr,) * JOINTS),
        origin={"kind": "nominal"},
    )


def random_truth(
    seed: int,
    nominal: Params | None = None,
    cpr: int = 1 << 32,
    sizes: RandomSizes = RANDOM_SIZES,
) -> Truth:
    """A random arm near ``nominal``: every structural parameter perturbed
    uniformly by ``sizes`` (lengths +-length_mm, angles +-angle_deg), encoder
    noise, eccentricity and probing noise of ``sizes``. Same seed, same arm
    (numpy PCG64)."""
    if not 0 <= seed < 1 << 64:
        raise TruthError(f"random truth seed {seed} outside 0 .. 2^64-1")
    nom = nominal or Params()
    rng = np.random.Generator(np.random.PCG64(seed))
    ang = math.radians(sizes.angle_deg)
    delta = np.concatenate(
        [
            rng.uniform(-ang, ang, 12),  # theta offsets, alpha
            rng.uniform(-sizes.length_mm, sizes.length_mm, 13),  # d, a, l
        ]
    )
    params = Params.from_vector(nom.to_vector() + delta)
    lo, hi = sizes.eccentricity_arcsec
    noise_counts = sizes.encoder_noise_arcsec * ARCSEC_RAD * cpr / (2.0 * math.pi)
    errors = ErrorSources(
        encoder_noise_counts=(noise_counts,) * JOINTS,
        eccentricity_arcsec=tuple(float(v) for v in rng.uniform(lo, hi, JOINTS)),
        eccentricity_phase_rad=tuple(float(v) for v in rng.uniform(0.0, 2.0 * math.pi, JOINTS)),
        probing_sigma_um=sizes.probing_sigma_um,
    )
    return Truth(
        params=params,
        encoders=EncoderConfig((cpr,) * JOINTS),
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
