"""Parameter-set files (TOML or JSON) for ``aacmm params``.

A file holds the eight fields of a device parameter set (docs/protocol.md
2.3), flat::

    # aacmm parameter set (mm, rad, encoder counts)
    theta_offset_rad = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    alpha_rad = [1.5707963267948966, ...]
    d_mm = [300.0, 65.5, 792.7, 65.5, 883.2, 0.0]
    a_mm = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    l_mm = 183.5
    counts_per_rev = [4294967296, ...]
    zero_offset_counts = [0, 0, 0, 0, 0, 0]
    direction = [1, 1, 1, 1, 1, 1]

or split as in a log sidecar: a ``params`` table (the five kinematic keys)
and an ``encoders`` table (the three encoder keys). A log's ``.csv.json``
sidecar (``"format": "aacmm-log-1"``) can be loaded as it is: only its
``params`` and ``encoders`` are read; so can a simulator truth file
(``"format": "aacmm-truth-1"``, docs/simulator.md): only its eight parameter
keys are read (its error tables are not parameters). The optional keys ``format`` and
``param_crc32`` are ignored on reading; any other key is an error. The format is chosen by the
suffix: ``.toml`` or ``.json``.

An optional ``arm`` table says whose set it is (``aacmm calibrate`` writes it)::

    [arm]
    serial_number = 1               # the device the calibration sessions were taken on
    firmware = "0.1.0"
    start_param_crc32 = "0xf2210b6c"  # the set in force the calibration started from

``aacmm params set`` refuses a file whose ``serial_number`` is another
device's (:func:`load_param_file_arm`, :class:`ArmIdentity`).

**Any arm** (issue 26): N (4 to 7) is the length of ``theta_offset_rad``;
every per-joint list has N values. An arm of another shape than the paper's
adds the keys of :data:`SHAPE_KEYS` (all optional on reading; written only
for a set that is not of the paper's shape, so a six-joint file of the
paper's arm reads and writes exactly as before)::

    convention = ["standard", "standard", "modified", ...]  # N, default all standard
    beta_joints = [3]                    # joints (from 1) with a Hayati beta
    beta_rad = [0.0015]                  # their betas, in that order
    tip_mm = [1.5, -2.0, 110.0]          # a tip vector, instead of l_mm

An optional ``errmodel`` table carries the encoder angle harmonics of a
calibration (issue 27; ``aacmm calibrate --harmonics``): per joint ``j`` the
reading ``q`` becomes ``q + sum_k (c_k cos kq + s_k sin kq)``, ``k = 1 .. K_j``
(``K_j <= 4``, :mod:`aacmm.errmodel`); one list per joint, K_j values each (an
empty list: no harmonics)::

    [errmodel]
    c_rad = [[1.2e-5, -3.0e-6], [], [4.1e-5], [], [], []]   # c_1 .. c_K of each joint
    s_rad = [[-8.0e-6, 2.2e-6], [], [9.5e-5], [], [], []]   # s_1 .. s_K
    cte_per_k = [2.3e-5, 2.3e-5, 2.3e-5, 2.3e-5, 2.3e-5, 2.3e-5]  # optional, per link
    tref_c = [20.0, 20.0, 20.0, 20.0, 20.0, 20.0]                # optional, per link

The thermal keys (``cte_per_k``, 1/K, ``|x| <= 1e-3``, and ``tref_c``,
degC, -40 .. 85, N values each; absent: 0 and 20 degC) are the links'
thermal expansion (issue 27): per link (one per joint; the tip belongs to the
last) at link temperatures ``T`` every length of link ``i`` (``d_i``, ``a_i``)
is ``L (1 + cte_i (T_i - tref_i))``. They are the arm maker's (data-sheet)
values, written by hand, or ``aacmm calibrate --thermal``'s from sessions at
temperatures at least 5 degC apart; ``aacmm verify --params FILE
--temperature C`` applies them (docs/cli.md). ``c_rad`` and ``s_rad``
(together) and ``cte_per_k`` are each optional; ``tref_c`` goes with
``cte_per_k``; :func:`errmodel_dict` writes the thermal keys only for an error
model with thermal expansion (:func:`has_thermal`).

Only :func:`load_param_file_errmodel` reads it (``aacmm params set`` sends the
error model to the device, ``--check`` shows it; thermal expansion only to a
device that reads its link temperatures, build flag ``TEMPERATURES``); every
other reader refuses such a file in one line (:class:`ParamFileError`): it
would apply the arm's parameters without the error model they were calibrated
with.

:func:`load_param_file_arm` also takes an arm model file
(``format = "aacmm-model-1"``, docs/models.md): its nominal set
(:func:`aacmm.models.load_model`, ``ParamSet.from_arm(model.arm,
model.encoder_config())``).

:func:`load_param_file` checks everything the device would check (types,
N values each (4 to 7), finite, encoder ranges, |angle| <= 2 pi, |length| <= 10 m)
before anything is sent; problems raise :class:`ParamFileError` naming the
file and the key (a bad model file: :class:`aacmm.errors.ModelError`, also a
``ValueError``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aacmm.fileio import InputFileError, load_structured, write_output
from aacmm.protocol import ParamSet
from aacmm.protocol.constants import COUNTS_PER_REV_MAX, JOINTS, JOINTS_MAX, JOINTS_MIN
from aacmm.records.files import RecordError

KIN_KEYS = ("theta_offset_rad", "alpha_rad", "d_mm", "a_mm", "l_mm")
ENC_KEYS = ("counts_per_rev", "zero_offset_counts", "direction")
ALL_KEYS = KIN_KEYS + ENC_KEYS
#: The keys of an arm of another shape (module doc): conventions, betas, a tip vector.
SHAPE_KEYS = ("convention", "beta_joints", "beta_rad", "tip_mm")
#: Every parameter key a file may hold (``tip_mm`` replaces ``l_mm``).
FILE_KEYS = ALL_KEYS + SHAPE_KEYS
MODEL_FORMAT = "aacmm-model-1"
CONVENTION_NAMES = ("standard", "modified")
IGNORED_KEYS = frozenset({"format", "param_crc32", "param_crc32_hex"})
ANGLE_MAX = 2.0 * math.pi
LENGTH_MAX_MM = 10_000.0


ARM_TABLE = "arm"
ARM_KEYS = ("serial_number", "firmware", "start_param_crc32")
ERRMODEL_TABLE = "errmodel"
ERRMODEL_KEYS = ("c_rad", "s_rad")
ERRMODEL_THERMAL_KEYS = ("cte_per_k", "tref_c")


class ParamFileError(RecordError):
    """A parameter file cannot be read or is not a valid parameter set (a
    ``ValueError``; ``aacmm`` exit status 2)."""


@dataclass(frozen=True)
class ArmIdentity:
    """A parameter file's ``[arm]`` table: the arm the set belongs to (None: not stated)."""

    serial_number: int | None = None
    firmware: str | None = None
    start_param_crc32: str | None = None

    def to_mapping(self) -> dict[str, Any]:
        """The table's keys that are set (TOML/JSON-ready)."""
        return {k: getattr(self, k) for k in ARM_KEYS if getattr(self, k) is not None}


def arm_identity_from_mapping(value: Any, src: str = "parameters") -> ArmIdentity:
    """An :class:`ArmIdentity` from an ``arm`` table.

    Raises:
        ParamFileError: not a table, an unknown key or a value of the wrong type.
    """
    if not isinstance(value, Mapping):
        raise ParamFileError(f"{src}: {ARM_TABLE} must be a table")
    for k in value:
        if k not in ARM_KEYS:
            raise ParamFileError(
                f"{src}: unknown key {ARM_TABLE}.{k} (expected {', '.join(ARM_KEYS)})"
            )
    serial = value.get("serial_number")
    if serial is not None and (
        isinstance(serial, bool) or not isinstance(serial, int) or not 0 <= serial <= 0xFFFFFFFF
    ):
        raise ParamFileError(f"{src}: {ARM_TABLE}.serial_number must be an integer 0..2^32-1")
    for k in ("firmware", "start_param_crc32"):
        v = value.get(k)
        if v is not None and (not isinstance(v, str) or len(v) > 64 or not v.isprintable()):
            raise ParamFileError(f"{src}: {ARM_TABLE}.{k} must be a short text")
    return ArmIdentity(serial, value.get("firmware"), value.get("start_param_crc32"))


def _floats(src: str, key: str, value: Any, n: int) -> tuple[float, ...]:
    if n == 1:
        value = [value]
    if not isinstance(value, list) or len(value) != n:
        want = "a number" if n == 1 else f"a list of {n} numbers"
        raise ParamFileError(f"{src}: {key} must be {want}")
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ParamFileError(f"{src}: {key}[{i}] must be a number, got {v!r}")
        if not math.isfinite(v):
            raise ParamFileError(f"{src}: {key}[{i}] is not finite")
        out.append(float(v))
    return tuple(out)


def _ints(src: str, key: str, value: Any, lo: int, hi: int, n: int = JOINTS) -> tuple[int, ...]:
    if not isinstance(value, list) or len(value) != n:
        raise ParamFileError(f"{src}: {key} must be a list of {n} integers")
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, int):
            raise ParamFileError(f"{src}: {key}[{i}] must be an integer, got {v!r}")
        if not lo <= v <= hi:
            raise ParamFileError(f"{src}: {key}[{i}]={v} outside {lo}..{hi}")
        out.append(v)
    return tuple(out)


def _conventions(src: str, value: Any, n: int) -> tuple[int, ...]:
    """``convention``: N names (``standard``/``modified``) as the wire's 0/1."""
    if value is None:
        return ()
    if not isinstance(value, list) or len(value) != n:
        raise ParamFileError(f"{src}: convention must be a list of {n} names")
    out = []
    for i, v in enumerate(value):
        if v not in CONVENTION_NAMES:
            raise ParamFileError(
                f"{src}: convention[{i}] must be one of {', '.join(CONVENTION_NAMES)}, got {v!r}"
            )
        out.append(CONVENTION_NAMES.index(v))
    return tuple(out)


def _betas(src: str, joints: Any, values: Any, n: int) -> tuple[float | None, ...]:
    """``beta_joints`` (from 1) and ``beta_rad`` as the wire's per-joint tuple."""
    if joints is None and values is None:
        return ()
    if joints is None or values is None:
        raise ParamFileError(f"{src}: beta_joints and beta_rad go together")
    if not isinstance(joints, list) or not 1 <= len(joints) < n:
        raise ParamFileError(f"{src}: beta_joints must be a list of 1 to {n - 1} joints")
    out: list[float | None] = [None] * n
    if not isinstance(values, list) or len(values) != len(joints):
        raise ParamFileError(f"{src}: beta_rad must be a list of {len(joints)} numbers")
    betas = [_floats(src, f"beta_rad[{i}]", v, 1)[0] for i, v in enumerate(values)]
    for i, (j, b) in enumerate(zip(joints, betas, strict=True)):
        if isinstance(j, bool) or not isinstance(j, int) or not 2 <= j <= n:
            raise ParamFileError(
                f"{src}: beta_joints[{i}] must be a joint 2..{n} (joint 1 has no beta), got {j!r}"
            )
        if out[j - 1] is not None:
            raise ParamFileError(f"{src}: beta_joints[{i}]: joint {j} given twice")
        if abs(b) > ANGLE_MAX:
            raise ParamFileError(f"{src}: beta_rad[{i}]={b} beyond +-2 pi")
        out[j - 1] = b
    return tuple(out)


def errmodel_from_mapping(value: Any, joints: int, src: str = "parameters") -> Any:
    """The :class:`aacmm.errmodel.ErrorModel` of an ``errmodel`` table (module doc)
    for an arm of ``joints`` joints.

    Raises:
        ParamFileError: not a table, an unknown or missing key, not one list of at
            most 4 numbers per joint, or coefficients the error model refuses.
    """
    from aacmm.errmodel import HARMONICS_MAX, ErrorModel

    where = f"{src}: {ERRMODEL_TABLE}"
    if not isinstance(value, Mapping):
        raise ParamFileError(f"{where} must be a table")
    for k in value:
        if k not in ERRMODEL_KEYS + ERRMODEL_THERMAL_KEYS:
            raise ParamFileError(
                f"{src}: unknown key {ERRMODEL_TABLE}.{k} "
                f"(expected {', '.join(ERRMODEL_KEYS + ERRMODEL_THERMAL_KEYS)})"
            )
    if not value:
        raise ParamFileError(f"{where}: an empty table (give c_rad and s_rad, or cte_per_k)")
    if ("c_rad" in value) != ("s_rad" in value):
        raise ParamFileError(f"{where}: c_rad and s_rad go together")
    if "tref_c" in value and "cte_per_k" not in value:
        raise ParamFileError(f"{where}: tref_c goes with cte_per_k")
    lists: dict[str, list[tuple[float, ...]]] = {"c_rad": [()] * joints, "s_rad": [()] * joints}
    for k in ("c_rad", "s_rad"):
        if k not in value:
            continue
        v = value.get(k)
        if not isinstance(v, list) or len(v) != joints or not all(isinstance(x, list) for x in v):
            raise ParamFileError(f"{where}.{k} must be {joints} lists (one per joint)")
        lists[k] = [
            _floats(src, f"{ERRMODEL_TABLE}.{k}[{i}]", x, len(x))
            if len(x) != 1
            else _floats(src, f"{ERRMODEL_TABLE}.{k}[{i}]", x[0], 1)
            for i, x in enumerate(v)
        ]
    hs = []
    for i, (c, sv) in enumerate(zip(lists["c_rad"], lists["s_rad"], strict=True)):
        if len(c) != len(sv) or len(c) > HARMONICS_MAX:
            raise ParamFileError(
                f"{where}: joint {i + 1}: c_rad and s_rad need as many values, at most "
                f"{HARMONICS_MAX}"
            )
        hs.append(tuple(zip(c, sv, strict=True)))
    cte: tuple[float, ...] = ()
    tref: tuple[float, ...] = ()
    if "cte_per_k" in value:
        cte = _floats(src, f"{ERRMODEL_TABLE}.cte_per_k", value["cte_per_k"], joints)
        if "tref_c" in value:
            tref = _floats(src, f"{ERRMODEL_TABLE}.tref_c", value["tref_c"], joints)
    try:
        return ErrorModel(tuple(hs), cte_per_k=cte, tref_c=tref)
    except ValueError as exc:
        raise ParamFileError(f"{where}: {exc}") from None


def errmodel_dict(em: Any) -> dict[str, Any]:
    """The ``errmodel`` table of an :class:`aacmm.errmodel.ErrorModel`: its harmonics,
    and its thermal part when it has one (:func:`has_thermal`)."""
    out: dict[str, Any] = {
        "c_rad": [[c for c, _ in h] for h in em.harmonics],
        "s_rad": [[s for _, s in h] for h in em.harmonics],
    }
    if has_thermal(em):
        out["cte_per_k"] = list(em.cte_per_k)
        out["tref_c"] = list(em.tref_c)
    return out


def describe_errmodel(em: Any) -> str:
    """One line for an :class:`aacmm.errmodel.ErrorModel`: its harmonics per joint (if
    any, or if it has nothing else) and its thermal part (if any): ``encoder harmonics K
    per joint 2,2,0,0,0,0; thermal expansion CTE per link 22e-6 .. 23.5e-6 /K,
    reference 20 degC``."""
    parts = []
    if any(em.harmonics) or not has_thermal(em):
        parts.append("encoder harmonics K per joint " + ",".join(str(len(h)) for h in em.harmonics))
    if has_thermal(em):
        lo, hi = min(em.cte_per_k), max(em.cte_per_k)
        ref = ", ".join(f"{t:g}" for t in sorted(set(em.tref_c)))
        span = f"{lo * 1e6:g}e-6" if lo == hi else f"{lo * 1e6:g}e-6 .. {hi * 1e6:g}e-6"
        parts.append(f"thermal expansion CTE per link {span} /K, reference {ref} degC")
    return "; ".join(parts)


def has_thermal(em: Any) -> bool:
    """Whether an :class:`aacmm.errmodel.ErrorModel` corrects for temperature (a CTE
    other than 0 or a reference temperature other than 20 degC)."""
    from aacmm.errmodel import TEMP_REF_DEFAULT_C

    return any(x != 0.0 for x in em.cte_per_k) or any(t != TEMP_REF_DEFAULT_C for t in em.tref_c)


def param_set_from_mapping(
    data: Any, src: str = "parameters", *, errmodel: bool = False
) -> ParamSet:
    """A validated :class:`ParamSet` from a flat or split mapping (see the module doc).

    ``errmodel``: accept an ``errmodel`` table (checked here, read by
    :func:`load_param_file_errmodel`); refused otherwise.

    Raises:
        ParamFileError: missing, unknown or bad keys, values out of range, an
            ``errmodel`` table where it is not accepted.
    """
    if not isinstance(data, dict):
        raise ParamFileError(f"{src}: expected a table of parameters")
    fmt = data.get("format")
    if isinstance(fmt, str) and fmt.startswith("aacmm-log"):  # a log sidecar: its set only
        data = {k: data[k] for k in ("params", "encoders") if k in data}
    elif isinstance(fmt, str) and fmt.startswith("aacmm-truth"):  # a simulator truth file:
        data = {k: v for k, v in data.items() if k in FILE_KEYS}  # its set, not its error tables
    flat: dict[str, Any] = {}
    for key, value in data.items():
        if key in ("params", "encoders") and isinstance(value, dict):
            allowed = KIN_KEYS + SHAPE_KEYS if key == "params" else ENC_KEYS
            for k, v in value.items():
                if k not in allowed:
                    raise ParamFileError(f"{src}: unknown key {key}.{k}")
                flat[k] = v
        elif key in FILE_KEYS:
            flat[key] = value
        elif key == ARM_TABLE:
            arm_identity_from_mapping(value, src)  # checked here, read by load_param_file_arm
        elif key == ERRMODEL_TABLE:
            if not errmodel:
                raise ParamFileError(
                    f"{src}: an [{ERRMODEL_TABLE}] table (encoder angle harmonics): this reader "
                    "takes the arm's parameters only and cannot apply the error model"
                )
        elif key not in IGNORED_KEYS:
            raise ParamFileError(f"{src}: unknown key {key!r} (expected {', '.join(ALL_KEYS)})")
    if "tip_mm" in flat and "l_mm" in flat:
        raise ParamFileError(f"{src}: l_mm and tip_mm: give one (tip_mm is a tip vector)")
    tip_key = "tip_mm" if "tip_mm" in flat else "l_mm"
    required = tuple(tip_key if k == "l_mm" else k for k in ALL_KEYS)
    missing = [k for k in required if k not in flat]
    if missing:
        raise ParamFileError(f"{src}: missing {', '.join(missing)}")
    thetas = flat["theta_offset_rad"]
    n = len(thetas) if isinstance(thetas, list) else 0
    if not JOINTS_MIN <= n <= JOINTS_MAX:
        raise ParamFileError(
            f"{src}: theta_offset_rad must be a list of {JOINTS_MIN} to {JOINTS_MAX} numbers "
            "(one per joint)"
        )
    kin = {k: _floats(src, k, flat[k], n) for k in KIN_KEYS if k != "l_mm"}
    kin["tip"] = _floats(src, tip_key, flat[tip_key], 3 if tip_key == "tip_mm" else 1)
    for k in ("theta_offset_rad", "alpha_rad"):
        for i, v in enumerate(kin[k]):
            if abs(v) > ANGLE_MAX:
                raise ParamFileError(f"{src}: {k}[{i}]={v} beyond +-2 pi")
    for k in ("d_mm", "a_mm", "tip"):
        name = tip_key if k == "tip" else k
        for i, v in enumerate(kin[k]):
            if abs(v) > LENGTH_MAX_MM:
                raise ParamFileError(f"{src}: {name}[{i}]={v} beyond +-{LENGTH_MAX_MM:g} mm")
    conv = _conventions(src, flat.get("convention"), n)
    beta = _betas(src, flat.get("beta_joints"), flat.get("beta_rad"), n)
    cpr = _ints(src, "counts_per_rev", flat["counts_per_rev"], 2, COUNTS_PER_REV_MAX, n)
    zero = _ints(src, "zero_offset_counts", flat["zero_offset_counts"], 0, 0xFFFFFFFF, n)
    direction = _ints(src, "direction", flat["direction"], -1, 1, n)
    for i in range(n):
        if direction[i] == 0:
            raise ParamFileError(f"{src}: direction[{i}] must be +1 or -1")
        if zero[i] >= cpr[i]:
            raise ParamFileError(
                f"{src}: zero_offset_counts[{i}]={zero[i]} must be < counts_per_rev[{i}]"
            )
    if ERRMODEL_TABLE in data:
        errmodel_from_mapping(data[ERRMODEL_TABLE], n, src)
    tip = kin["tip"]
    ps = ParamSet(
        theta_offset_rad=kin["theta_offset_rad"],
        alpha_rad=kin["alpha_rad"],
        d_mm=kin["d_mm"],
        a_mm=kin["a_mm"],
        l_mm=tip[-1],
        counts_per_rev=cpr,
        zero_offset_counts=zero,
        direction=direction,
        convention=conv,
        beta_rad=beta,
        tip_xy_mm=(tip[0], tip[1]) if len(tip) == 3 else None,
    )
    from aacmm.protocol import encode_param_set

    try:
        encode_param_set(ps)  # the codec's own checks, as a last line
    except ValueError as exc:
        raise ParamFileError(f"{src}: {exc}") from None
    return ps


def file_format(path: Path) -> str:
    """``"toml"`` or ``"json"`` from a parameter file's suffix.

    Raises:
        ParamFileError: another suffix.
    """
    suffix = path.suffix.lower()
    if suffix == ".toml":
        return "toml"
    if suffix == ".json":
        return "json"
    raise ParamFileError(f"{path}: unknown format (use a .toml or .json file)")


def load_param_file(path: str | Path) -> ParamSet:
    """Read and validate a parameter file (TOML or JSON by suffix), or an arm
    model file (its nominal set; module doc).

    Raises:
        ParamFileError: unreadable, not TOML/JSON, nested deeper than
            :data:`aacmm.fileio.MAX_NESTING`, or not a valid parameter set.
        ModelError: a model file that is not a valid model.
    """
    return load_param_file_arm(path)[0]


def is_model_file(data: Any) -> bool:
    """True for the content of an arm model file (``format = "aacmm-model-1"``)."""
    return isinstance(data, dict) and data.get("format") == MODEL_FORMAT


def model_param_set(path: str | Path) -> ParamSet:
    """The nominal set of the arm model file ``path``, as the device holds it.

    Raises:
        ModelError: not a valid model file (one line naming the file and field).
    """
    from aacmm.models import load_model

    model = load_model(Path(path))
    return ParamSet.from_arm(model.arm, model.encoder_config())


def load_param_file_arm(path: str | Path) -> tuple[ParamSet, ArmIdentity | None]:
    """:func:`load_param_file` and the file's ``[arm]`` table (None if it has none,
    and for a model file).

    Raises:
        ParamFileError: as :func:`load_param_file` (also for a file with an
            ``errmodel`` table: :func:`load_param_file_errmodel` reads those).
        ModelError: a model file that is not a valid model.
    """
    ps, arm, _ = _load(path, errmodel=False)
    return ps, arm


def load_param_file_errmodel(path: str | Path) -> tuple[ParamSet, ArmIdentity | None, Any]:
    """:func:`load_param_file_arm` and the file's error model: an
    :class:`aacmm.errmodel.ErrorModel` from its ``errmodel`` table, None without one.

    Raises:
        ParamFileError, ModelError: as :func:`load_param_file_arm`.
    """
    return _load(path, errmodel=True)


def _load(path: str | Path, errmodel: bool) -> tuple[ParamSet, ArmIdentity | None, Any]:
    p = Path(path)
    file_format(p)
    try:
        data = load_structured(p)
    except InputFileError as exc:
        raise ParamFileError(str(exc)) from None
    if is_model_file(data):
        if file_format(p) != "toml":
            raise ParamFileError(f"{p}: an arm model file is TOML (.toml)")
        return model_param_set(p), None, None
    ps = param_set_from_mapping(data, str(p), errmodel=errmodel)
    arm = data.get(ARM_TABLE) if isinstance(data, dict) else None
    fmt = data.get("format") if isinstance(data, dict) else None
    em_table = data.get(ERRMODEL_TABLE) if isinstance(data, dict) else None
    em = None if em_table is None else errmodel_from_mapping(em_table, ps.joints, str(p))
    if arm is None or (isinstance(fmt, str) and fmt.startswith("aacmm-log")):
        return ps, None, em
    return ps, arm_identity_from_mapping(arm, str(p)), em


def param_set_dict(ps: ParamSet) -> dict[str, Any]:
    """The flat mapping of a parameter set (lists, JSON/TOML-ready): the eight keys
    of the paper's arm, and for a set of another shape :data:`SHAPE_KEYS` too
    (``tip_mm`` instead of ``l_mm`` for a tip vector; module doc)."""
    out: dict[str, Any] = {}
    if not ps.is_paper_shape:
        conv = ps.convention or (0,) * ps.joints
        out["convention"] = [CONVENTION_NAMES[c] for c in conv]
    out.update(
        {
            "theta_offset_rad": list(ps.theta_offset_rad),
            "alpha_rad": list(ps.alpha_rad),
            "d_mm": list(ps.d_mm),
            "a_mm": list(ps.a_mm),
        }
    )
    betas = [(i + 1, b) for i, b in enumerate(ps.beta_rad) if b is not None]
    if betas:
        out["beta_joints"] = [j for j, _ in betas]
        out["beta_rad"] = [b for _, b in betas]
    if ps.tip_xy_mm is None:
        out["l_mm"] = ps.l_mm
    else:
        out["tip_mm"] = [ps.tip_xy_mm[0], ps.tip_xy_mm[1], ps.l_mm]
    out.update(
        {
            "counts_per_rev": list(ps.counts_per_rev),
            "zero_offset_counts": list(ps.zero_offset_counts),
            "direction": list(ps.direction),
        }
    )
    return out


def dump_param_set(
    ps: ParamSet,
    fmt: str,
    crc: int | None = None,
    arm: Mapping[str, Any] | None = None,
    errmodel: Any = None,
) -> str:
    """A parameter file's text (``fmt``: ``toml`` or ``json``); ``arm``: its ``[arm]``
    table; ``errmodel``: an :class:`aacmm.errmodel.ErrorModel` for its ``[errmodel]``
    table (harmonics; None: no table)."""
    data: dict[str, Any] = {"format": "aacmm-params-1"}
    if crc is not None:
        data["param_crc32"] = crc
    data.update(param_set_dict(ps))
    if arm:
        data[ARM_TABLE] = dict(arm)
    if errmodel is not None:
        data[ERRMODEL_TABLE] = errmodel_dict(errmodel)
    if fmt == "json":
        return json.dumps(data, indent=2) + "\n"
    import tomli_w

    head = "# aacmm parameter set: lengths in mm, angles in rad, encoder counts\n"
    return head + tomli_w.dumps(data)


def write_param_file(
    ps: ParamSet,
    path: str | Path,
    crc: int | None = None,
    *,
    force: bool = False,
    errmodel: Any = None,
) -> None:
    """Write a parameter file, format by suffix (:func:`aacmm.fileio.write_output`:
    refused if it exists unless ``force``; temporary file, fsync, rename).

    Raises:
        ParamFileError: unknown suffix.
        OutputExistsError, OutputFileError: see :func:`aacmm.fileio.atomic_output`.
        OSError: the write failed (the file is untouched).
    """
    p = Path(path)
    write_output(p, dump_param_set(ps, file_format(p), crc, errmodel=errmodel), force=force)
