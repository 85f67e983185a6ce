"""Arm models (issue 26 items 1-2): every shipped model computed by the C core
against an independent computation, and bad model files.

The reference reads each shipped model's TOML file itself (tomllib, its own
unit conversion and its own column order from docs/kinematics.md: thetas,
alphas, d, a, declared betas, tip), multiplies the elementary 4x4 homogeneous
matrices of each joint in complex long double (standard: [Ry(beta)] Rz(theta)
Tz(d) Tx(a) Rx(alpha); modified: Rx(alpha) Tx(a) [Ry(beta)] Rz(theta) Tz(d))
and takes every Jacobian column by complex step (h = 1e-30: no difference is
taken, so the column is exact to long double's rounding). Nothing of
aacmm.arm, aacmm.models or the core's frame recursion is used for it.

Bounds: double precision 1e-12 mm (mm/rad, mm/mm) for every shipped model
(the core guarantees max(1e-12, 4 ulp of the reach), docs/kinematics.md, which
is 1.82e-12 for a reach beyond 2048 mm; on these poses every model and every
batch kernel stays below 1e-12: measured 8.0e-13 for the 7-axis arm); single
precision today's class, 1e-3 mm and 2e-3 (mm/rad, mm/mm), and the fixed-point
path its class, 1e-4 mm and 1e-4, both scaled by the reach beyond the paper's
2290 mm (docs/kinematics.md, docs/fixed-point.md).
"""

from __future__ import annotations

import math
import os
import subprocess
import tomllib
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from aacmm.arm import Arm
from aacmm.core import Model, counts_to_angles
from aacmm.errors import AacmmError, ModelError
from aacmm.models import (
    DEFAULT_MODEL,
    ArmModel,
    load_model,
    loads_model,
    shipped_model_path,
    shipped_models,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytestmark = pytest.mark.timeout(300)
REPO = Path(__file__).resolve().parents[2]
MODELS = shipped_models()
PAPER_REACH_MM = 2290.4
POSES = 64
C = npt.NDArray[np.clongdouble]


# ------------------------------------------------------------- the reference


@dataclass(frozen=True)
class Spec:
    """A model as the test reads it from the file (independent of the loader)."""

    conventions: tuple[str, ...]
    params: tuple[float, ...]  # thetas, alphas, d, a, betas, tip (rad, mm)
    betas: tuple[int, ...]  # joints (0-based) that declare a beta
    tip: str
    limits: tuple[tuple[float, float], ...]  # rad

    @property
    def n(self) -> int:
        return len(self.conventions)

    @property
    def reach_mm(self) -> float:
        n, b = self.n, len(self.betas)
        return float(
            sum(abs(x) for x in self.params[2 * n : 4 * n])
            + sum(abs(x) for x in self.params[4 * n + b :])
        )


def _angle(j: dict[str, Any], base: str) -> float | None:
    if f"{base}_deg" in j:  # x * (pi / 180): the rounding of math.radians, the loader's
        return float(j[f"{base}_deg"]) * (math.pi / 180.0)
    if f"{base}_rad" in j:
        return float(j[f"{base}_rad"])
    return None


def read_spec(path: Path) -> Spec:
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    js = data["joints"]
    th = [_angle(j, "theta_offset") or 0.0 for j in js]
    al = [_angle(j, "alpha") or 0.0 for j in js]
    be = [(i, _angle(j, "beta")) for i, j in enumerate(js)]
    betas = [(i, b) for i, b in be if b is not None]
    lims = []
    for j in js:
        lo, hi = j["limits_deg"] if "limits_deg" in j else j["limits_rad"]
        f = (math.pi / 180.0) if "limits_deg" in j else 1.0
        lims.append((lo * f, hi * f))
    tip = data["tip"]
    vec = [float(x) for x in tip["vector_mm"]]
    params = (
        *th,
        *al,
        *(float(j["d_mm"]) for j in js),
        *(float(j["a_mm"]) for j in js),
        *(b for _, b in betas),
        *(vec if tip["kind"] == "xyz" else vec[2:]),
    )
    return Spec(
        conventions=tuple(j["convention"] for j in js),
        params=tuple(params),
        betas=tuple(i for i, _ in betas),
        tip=tip["kind"],
        limits=tuple(lims),
    )


def _rot(axis: str, t: C) -> C:
    """Rotations (..., 4, 4) about ``axis`` by the angles ``t`` (...)."""
    m = np.zeros((*t.shape, 4, 4), dtype=np.clongdouble)
    m[..., 0, 0] = m[..., 1, 1] = m[..., 2, 2] = m[..., 3, 3] = 1.0
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    c, s = np.cos(t), np.sin(t)
    m[..., i, i], m[..., i, j], m[..., j, i], m[..., j, j] = c, -s, s, c
    return m


def _trans(axis: int, v: C) -> C:
    m = np.zeros((*v.shape, 4, 4), dtype=np.clongdouble)
    m[..., 0, 0] = m[..., 1, 1] = m[..., 2, 2] = m[..., 3, 3] = 1.0
    m[..., axis, 3] = v
    return m


def chain(spec: Spec, q: C, theta: npt.NDArray[np.longdouble]) -> C:
    """Tip points (M, K, 3) for poses ``theta`` (M, N) and parameter rows ``q`` (K, P)."""
    n, m, k = spec.n, theta.shape[0], q.shape[0]
    t = np.broadcast_to(np.eye(4, dtype=np.clongdouble), (m, k, 4, 4)).copy()
    col_beta = 4 * n
    for i, conv in enumerate(spec.conventions):
        ang = theta[:, i, None].astype(np.clongdouble) + q[None, :, i]
        full = (m, k)
        alpha = np.broadcast_to(q[None, :, n + i], full)
        d = np.broadcast_to(q[None, :, 2 * n + i], full)
        a = np.broadcast_to(q[None, :, 3 * n + i], full)
        beta: list[C] = []
        if i in spec.betas:
            beta = [_rot("y", np.broadcast_to(q[None, :, col_beta], full))]
            col_beta += 1
        if conv == "standard":
            mats = [*beta, _rot("z", ang), _trans(2, d), _trans(0, a), _rot("x", alpha)]
        else:
            mats = [_rot("x", alpha), _trans(0, a), *beta, _rot("z", ang), _trans(2, d)]
        for f in mats:
            t = t @ f
    tip = q[:, col_beta:]
    if spec.tip == "z":
        tip = np.concatenate([np.zeros((k, 2), dtype=np.clongdouble), tip], axis=1)
    hom = np.concatenate([tip, np.ones((k, 1), dtype=np.clongdouble)], axis=1)
    out: C = np.einsum("mkij,kj->mki", t, hom)[..., :3]
    return out


def reference(
    spec: Spec, theta: npt.NDArray[np.longdouble]
) -> tuple[npt.NDArray[np.longdouble], npt.NDArray[np.longdouble]]:
    """Points (M, 3) and Jacobians (M, 3, P) by complex step, in long double."""
    p = len(spec.params)
    h = np.longdouble(1e-30)
    q = np.tile(np.array(spec.params, dtype=np.longdouble), (p + 1, 1)).astype(np.clongdouble)
    q[np.arange(1, p + 1), np.arange(p)] += 1j * h
    pts = chain(spec, q, theta)
    point = pts[:, 0, :].real
    jac = (pts[:, 1:, :].imag / h).transpose(0, 2, 1)
    return point, jac


def poses(spec: Spec, name: str) -> npt.NDArray[np.float64]:
    """POSES readings inside the joint limits (rolls: a turn), and the zero pose."""
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    cols = []
    for lo, hi in spec.limits:
        lo_, hi_ = (-math.pi, math.pi) if math.isinf(lo) else (lo, hi)
        cols.append(rng.uniform(lo_, hi_, POSES))
    th = np.stack(cols, axis=1)
    return np.concatenate([np.zeros((1, spec.n)), th])


def scale(reach_mm: float) -> float:
    return max(1.0, reach_mm / PAPER_REACH_MM)


F64_BOUND = 1e-12


# ------------------------------------------------------------- every shipped model


def test_shipped_models_and_the_default() -> None:
    assert {"gao2013", "mpe2018", "commercial7", "microscribe5", "desk4"} <= set(MODELS)
    assert DEFAULT_MODEL == "gao2013" and load_model().name == "gao2013"
    counts = {load_model(n).n_joints for n in MODELS}
    assert counts == {4, 5, 6, 7}
    for name in MODELS:
        m = load_model(name)
        assert m.name == name and shipped_model_path(name).stem == name
        assert m.source and m.description
        assert isinstance(m, ArmModel) and m.arm.n_params == len(m.arm.param_names)


def test_gao2013_is_the_papers_arm_exactly() -> None:
    m = load_model("gao2013")
    assert m.arm == Arm.paper()
    assert np.array_equal(m.arm.to_vector(), Arm.paper().to_vector())
    rng = np.random.default_rng(1)
    th = rng.uniform(-3, 3, (100, 6))
    p1, j1 = Model(m.arm).points_jacobians(th)
    p2, j2 = Model().points_jacobians(th)
    assert np.array_equal(p1, p2) and np.array_equal(j1, j2)
    # its encoders are the firmware's and the simulator's defaults
    assert m.encoder_config() == type(m.encoder_config()).default(6)
    assert {e.interface for e in m.encoders} == {"biss"}
    # the paper publishes the geometry, not the limits nor the encoders
    assert not {n for n in m.assumed if not n.startswith(("limits", "encoder"))}


@pytest.mark.parametrize("name", MODELS)
def test_loader_reads_what_the_file_says(name: str) -> None:
    spec = read_spec(shipped_model_path(name))
    m = load_model(name)
    assert m.arm.to_vector().tolist() == list(spec.params)
    assert tuple(j.convention for j in m.arm.joints) == spec.conventions
    assert m.arm.beta_joints == spec.betas and m.arm.tip == spec.tip
    assert m.joint_limits_rad == spec.limits
    assert m.reach_mm == pytest.approx(spec.reach_mm, rel=1e-15)


@pytest.mark.parametrize("name", MODELS)
def test_double_precision_equals_the_4x4_complex_step_reference(name: str) -> None:
    spec = read_spec(shipped_model_path(name))
    m = load_model(name)
    th = poses(spec, name)
    p_ref, j_ref = reference(spec, th.astype(np.longdouble))
    p, j = Model(m.arm).points_jacobians(th)
    assert j.shape == (th.shape[0], 3, len(spec.params))
    bound = F64_BOUND
    err_p = float(np.max(np.abs(p - p_ref)))
    err_j = float(np.max(np.abs(j - j_ref)))
    assert err_p <= bound, (name, err_p, bound)
    assert err_j <= bound, (name, err_j, bound)
    # the reference is not trivially equal to the core: it moves with the parameters
    assert float(np.max(np.abs(p_ref[1:] - p_ref[:-1]))) > 1.0
    # single-pose calls give the batch's numbers
    p1, j1 = Model(m.arm).point_jacobian(th[3])
    assert np.array_equal(p1, p[3]) and np.array_equal(j1, j[3])


@pytest.mark.parametrize("name", MODELS)
def test_single_precision_within_its_class(name: str) -> None:
    spec = read_spec(shipped_model_path(name))
    m = load_model(name)
    th = poses(spec, name)
    p_ref, j_ref = reference(spec, th.astype(np.float32).astype(np.longdouble))
    p, j = Model(m.arm).points_jacobians(th.astype(np.float32), dtype=np.float32)
    assert p.dtype == np.float32 and j.dtype == np.float32
    s = scale(spec.reach_mm)
    assert float(np.max(np.abs(p - p_ref))) < 1e-3 * s
    assert float(np.max(np.abs(j - j_ref))) < 2e-3 * s


def _fixed_tool() -> Path:
    env = os.environ.get("AACMM_FIXED_ARM_TOOL")
    tool = Path(env) if env else REPO / "build" / "models" / "fixed_arm_stdio"
    if not env:  # pytest run by hand: build the tool as `make test-models` does
        subprocess.run(
            ["make", "--no-print-directory", "-s", "models-fixed-tool"],
            cwd=REPO,
            check=True,
            capture_output=True,
            timeout=240,
        )
    assert tool.is_file(), tool
    return tool


def run_fixed(spec: Spec, bam: npt.NDArray[np.uint32]) -> tuple[Any, Any]:
    """Points (M, 3) and Jacobians (M, 3, P) of the fixed-point path (the C tool)."""
    n, b = spec.n, len(spec.betas)
    v = spec.params
    beta_vals = [0.0] * n
    for k, i in enumerate(spec.betas):
        beta_vals[i] = v[4 * n + k]
    tip = list(v[4 * n + b :]) if spec.tip == "xyz" else [0.0, 0.0, v[4 * n + b]]
    words = [str(n), "1" if spec.tip == "xyz" else "0"]
    words += ["1" if c == "modified" else "0" for c in spec.conventions]
    words += ["1" if i in spec.betas else "0" for i in range(n)]
    words += [float(x).hex() for x in (*v[: 4 * n], *beta_vals, *tip)]
    words += [str(bam.shape[0])] + [str(int(x)) for x in bam.reshape(-1)]
    out = subprocess.run(
        [str(_fixed_tool())],
        input=" ".join(words),
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    ).stdout.split("\n")
    assert out[0] == f"ok {len(v)}", out[0]
    rows = np.array([[float.fromhex(x) for x in line.split()] for line in out[1:] if line])
    return rows[:, :3], rows[:, 3:].reshape(-1, 3, len(v))


@pytest.mark.parametrize("name", MODELS)
def test_fixed_point_within_its_class(name: str) -> None:
    spec = read_spec(shipped_model_path(name))
    th = poses(spec, name)
    turns = np.round(np.mod(th, 2 * math.pi) * (2.0**32 / (2 * math.pi))).astype(np.uint64)
    bam = (turns % (1 << 32)).astype(np.uint32)
    exact = bam.astype(np.longdouble) * (2 * np.pi / np.longdouble(2.0**32))
    p_ref, j_ref = reference(spec, exact)
    p, j = run_fixed(spec, bam)
    s = scale(spec.reach_mm)
    assert float(np.max(np.abs(p - p_ref))) < 1e-4 * s
    assert float(np.max(np.abs(j - j_ref))) < 1e-4 * s


@pytest.mark.parametrize("name", MODELS)
def test_encoders_and_limits(name: str) -> None:
    m = load_model(name)
    cfg = m.encoder_config()
    assert cfg.joints == m.n_joints
    # counts -> readings with the model's encoders, then the core: a quarter turn
    cpr = np.array(cfg.counts_per_rev, dtype=np.uint64)
    counts = ((cpr // 4 + np.array(cfg.zero_offset_counts)) % cpr).astype(np.uint32)
    th = counts_to_angles(counts, cfg)
    assert np.allclose(th, np.array(cfg.direction) * math.pi / 2, atol=1e-9)
    p, _ = Model(m.arm).points_from_counts(counts, cfg)
    assert np.array_equal(p[0], Model(m.arm).point(th[0]))
    spec = read_spec(shipped_model_path(name))
    for pose in poses(spec, name)[1:]:  # the zero pose is outside some hinges' ranges
        assert m.within_limits(pose)
    for i, (lo, hi) in enumerate(m.joint_limits_rad):
        if not math.isinf(lo):
            inside = [0.0 if math.isinf(a) else (a + b) / 2 for a, b in m.joint_limits_rad]
            assert m.within_limits(inside)
            out = np.array(inside)
            out[i] = hi + 1e-3
            assert not m.within_limits(out), (name, i)
            out[i] = hi + 1e-3 - 2 * math.pi  # the same reading a turn away
            assert not m.within_limits(out), (name, i)
            out[i] = lo + 1e-3 + 2 * math.pi
            assert m.within_limits(out), (name, i)


def test_every_shipped_model_says_what_is_assumed() -> None:
    for name in MODELS:
        m = load_model(name)
        names = set(m.arm.param_names)
        extra = {f"{k}{j}" for k in ("limits", "encoder", "convention") for j in range(1, 8)}
        assert m.assumed <= names | extra, m.assumed - names - extra
    # the 7-, 5- and 4-axis arms publish no figures: every parameter is assumed
    for name in ("commercial7", "microscribe5", "desk4"):
        m = load_model(name)
        assert set(m.arm.param_names) <= m.assumed, set(m.arm.param_names) - m.assumed
    # mpe2018's geometry is published, its convention, limits and encoders are not
    m = load_model("mpe2018")
    assert not set(m.arm.param_names) & m.assumed
    assert {f"convention{j}" for j in range(1, 7)} <= m.assumed
    # microscribe5 has the parallel hinges' beta on joint 3, modified DH throughout
    ms = load_model("microscribe5")
    assert ms.arm.beta_joints == (2,) and {j.convention for j in ms.arm.joints} == {"modified"}
    assert load_model("commercial7").n_joints == 7
    assert load_model("desk4").arm.beta_joints == (2, 3)  # its parallel hinges 3 and 4


# ------------------------------------------------------------- bad models

BASE = shipped_model_path("gao2013").read_text(encoding="utf-8")


def _line_of(text: str, needle: str, nth: int = 0) -> int:
    """The 1-based line of the nth line of ``text`` that starts with ``needle``."""
    hits = [i + 1 for i, ln in enumerate(text.splitlines()) if ln.startswith(needle)]
    return hits[nth]


def _joints(text: str, keep: int) -> str:
    head, *js = text.split("[[joints]]")
    return head + "".join("[[joints]]" + j for j in js[:keep])


BAD: list[tuple[str, str, str, str]] = [
    # (id, text, field, problem fragment); the line is checked where the field is known
    ("N 3", _joints(BASE, 3), "joints", "4 to 7 joints, this one 3"),
    (
        "N 8",
        _joints(BASE, 6) + ("[[joints]]" + BASE.split("[[joints]]")[2]) * 2,
        "joints",
        "4 to 7 joints, this one 8",
    ),
    ("nan", BASE.replace("d_mm = 792.7", "d_mm = nan"), "joint 3 d_mm", "not nan"),
    ("inf", BASE.replace("d_mm = 792.7", "d_mm = inf"), "joint 3 d_mm", "must be finite"),
    (
        "missing a",
        BASE.replace("a_mm = 0.0\nlimits_deg = [25.0", "limits_deg = [25.0"),
        "joint 4 a_mm",
        "missing field",
    ),
    (
        "missing alpha",
        BASE.replace("alpha_deg = 90.0\nd_mm = 65.5", "d_mm = 65.5", 1),
        "joint 2 alpha_deg",
        "missing field (alpha_deg or alpha_rad)",
    ),
    (
        "beta on joint 1",
        BASE.replace("d_mm = 300.0", "d_mm = 300.0\nbeta_deg = 0.1"),
        "joint 1 beta_deg",
        "joint 1 cannot have a beta",
    ),
    (
        "unknown key",
        BASE.replace("d_mm = 65.5", "d_mm = 65.5\ncolour = 'red'", 1),
        "joint 2 colour",
        "unknown field",
    ),
    (
        "unknown top key",
        BASE.replace("format =", "serial = 3\nformat ="),
        "serial",
        "unknown field",
    ),
    (
        "limits inverted",
        BASE.replace("[60.0, 300.0]", "[300.0, 60.0]"),
        "joint 2 limits_deg",
        "inverted",
    ),
    (
        "limits half open",
        BASE.replace("[60.0, 300.0]", "[60.0, inf]"),
        "joint 2 limits_deg",
        "[-inf, inf]",
    ),
    (
        "limits missing",
        BASE.replace("limits_deg = [60.0, 300.0]\n", ""),
        "joint 2 limits_deg",
        "missing field",
    ),
    (
        "tip missing",
        BASE.replace('[tip]\nkind = "z"\nvector_mm = [0.0, 0.0, 183.5]\n', ""),
        "tip",
        "missing field",
    ),
    (
        "tip vector short",
        BASE.replace("[0.0, 0.0, 183.5]", "[0.0, 183.5]"),
        "tip.vector_mm",
        "3 numbers",
    ),
    (
        "tip z with x",
        BASE.replace("[0.0, 0.0, 183.5]", "[1.0, 0.0, 183.5]"),
        "tip.vector_mm",
        "x = y = 0",
    ),
    (
        "convention",
        BASE.replace('convention = "standard"', 'convention = "craig"', 1),
        "joint 1 convention",
        "unknown value 'craig'",
    ),
    (
        "both units",
        BASE.replace("alpha_deg = 90.0", "alpha_deg = 90.0\nalpha_rad = 1.0", 1),
        "joint 1 alpha_rad",
        "not both",
    ),
    ("format", BASE.replace("aacmm-model-1", "aacmm-model-2"), "format", "unsupported"),
    ("no format", BASE.replace('format = "aacmm-model-1"\n', ""), "format", "missing field"),
    (
        "angle range",
        BASE.replace("alpha_deg = 90.0", "alpha_deg = 400.0", 1),
        "joint 1",
        "alpha_rad must be within",
    ),
    (
        "huge integer",
        BASE.replace("d_mm = 300.0", "d_mm = " + "9" * 400),
        "joint 1 d_mm",
        "beyond TOML's 64 bits",
    ),
    (
        "huge count",
        BASE.replace("counts_per_rev = 4294967296", "counts_per_rev = " + "9" * 400),
        "encoder.counts_per_rev",
        "400 digits",
    ),
    (
        "encoder cpr",
        BASE.replace("counts_per_rev = 4294967296", "counts_per_rev = 1"),
        "encoder.counts_per_rev",
        "2 .. 4294967296",
    ),
    (
        "encoder zero",
        BASE.replace("zero_offset_counts = 0", "zero_offset_counts = -1"),
        "encoder.zero_offset_counts",
        "0 .. counts_per_rev - 1",
    ),
    (
        "encoder interface",
        BASE.replace('interface = "biss"', 'interface = "usb"'),
        "encoder.interface",
        "unknown value",
    ),
    (
        "assumed unknown",
        BASE.replace('assumed = ["limits"]', 'assumed = ["colour"]', 1),
        "joint 1 assumed item 1",
        "not a figure",
    ),
    (
        "assumed near miss",
        BASE.replace('assumed = ["limits"]', 'assumed = ["limits_mm"]', 1),
        "joint 1 assumed item 1",
        "not a figure",
    ),
    (
        "string for number",
        BASE.replace("d_mm = 65.5", 'd_mm = "65.5"', 1),
        "joint 2 d_mm",
        "must be a number",
    ),
]


@pytest.mark.parametrize(
    ("text", "field", "problem"), [b[1:] for b in BAD], ids=[b[0] for b in BAD]
)
def test_bad_models_give_one_line(text: str, field: str, problem: str) -> None:
    with pytest.raises(ModelError) as e:
        loads_model(text, "arm.toml")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("arm.toml"), msg
    assert e.value.field == field, msg
    assert problem in e.value.problem, msg
    assert isinstance(e.value, AacmmError) and isinstance(e.value, ValueError)
    if e.value.line is not None:
        assert msg.startswith(f"arm.toml:{e.value.line}: ")


def test_error_lines_point_at_the_field() -> None:
    text = BASE.replace("d_mm = 792.7", "d_mm = nan")
    with pytest.raises(ModelError) as e:
        loads_model(text, "arm.toml")
    assert e.value.line == _line_of(text, "d_mm = nan")
    text = BASE.replace("d_mm = 300.0", "d_mm = 300.0\nbeta_deg = 0.1")
    with pytest.raises(ModelError) as e:
        loads_model(text, "arm.toml")
    assert e.value.line == _line_of(text, "beta_deg")
    text = BASE.replace("[60.0, 300.0]", "[300.0, 60.0]")
    with pytest.raises(ModelError) as e:
        loads_model(text, "arm.toml")
    assert e.value.line == _line_of(text, "limits_deg = [300.0")


def test_bad_toml_and_files(tmp_path: Path) -> None:
    text = BASE.replace("[encoder]", "[encoder", 1)
    with pytest.raises(
        ModelError, match=rf"^arm.toml:{_line_of(text, '[encoder')}: not valid TOML"
    ):
        loads_model(text, "arm.toml")
    with pytest.raises(ModelError, match=r"no such file$"):
        load_model(tmp_path / "none.toml")
    with pytest.raises(
        ModelError, match=r"nor a shipped model \(shipped: commercial7, desk4, gao2013"
    ):
        load_model("gao2014")
    (tmp_path / "latin1.toml").write_bytes(BASE.encode() + b"# \xe9\n")
    with pytest.raises(ModelError, match="not UTF-8"):
        load_model(tmp_path / "latin1.toml")
    (tmp_path / "big.toml").write_bytes(b"#" * ((1 << 20) + 1))
    with pytest.raises(ModelError, match="larger than 1 MiB"):
        load_model(tmp_path / "big.toml")
    # a user's file: read by path, named as its file says
    f = tmp_path / "mine.toml"
    f.write_text(BASE.replace('name = "gao2013"', 'name = "mine"'), encoding="utf-8")
    m = load_model(f)
    assert m.name == "mine" and m.file == str(f) and m.arm == Arm.paper()


def test_a_beta_is_declared_even_when_zero_and_radians_are_exact() -> None:
    text = BASE.replace("d_mm = 65.5", "d_mm = 65.5\nbeta_rad = 0.0", 1)
    text = text.replace("alpha_deg = 90.0", "alpha_rad = 1.5707963267948966", 1)
    m = loads_model(text)
    assert m.arm.beta_joints == (1,) and m.n_params == 26 and "beta2" in m.arm.param_names
    assert m.arm.joints[0].alpha_rad == math.pi / 2


# Damaged files: every byte string either loads (then it is a valid model the core
# computes with) or raises ModelError with one line; nothing else escapes.
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    pos=st.integers(min_value=0, max_value=len(BASE) - 1),
    cut=st.integers(min_value=0, max_value=40),
    insert=st.text(alphabet="[]{}=\"'.,-+0123456789eEnaifx_ \n#", max_size=12),
)
def test_damaged_files_never_escape(pos: int, cut: int, insert: str) -> None:
    text = BASE[:pos] + insert + BASE[pos + cut :]
    try:
        m = loads_model(text, "arm.toml")
    except ModelError as e:
        assert "\n" not in str(e) and str(e).startswith("arm.toml")
        return
    p = Model(m.arm).point(np.zeros(m.n_joints))
    assert np.all(np.isfinite(p))


@settings(max_examples=200, deadline=None)
@given(
    value=st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.integers(min_value=-(10**400), max_value=10**400),
        st.text(max_size=5),
        st.booleans(),
    ),
    field=st.sampled_from(["d_mm", "a_mm", "alpha_deg", "theta_offset_deg"]),
    joint=st.integers(min_value=0, max_value=5),
)
def test_any_value_of_a_number_field(value: Any, field: str, joint: int) -> None:
    parts = BASE.split("[[joints]]")
    lines = parts[joint + 1].splitlines()
    rendered = repr(value) if isinstance(value, str) else str(value).lower()
    if isinstance(value, float) and math.isnan(value):
        rendered = "nan"
    elif isinstance(value, float) and math.isinf(value):
        rendered = "inf" if value > 0 else "-inf"
    lines = [f"{field} = {rendered}" if ln.startswith(f"{field} =") else ln for ln in lines]
    parts[joint + 1] = "\n".join(lines) + "\n"
    text = "[[joints]]".join(parts)
    try:
        m = loads_model(text, "arm.toml")
    except ModelError as e:
        assert "\n" not in str(e) and str(e).startswith("arm.toml:"), str(e)
        # a string rendered by repr() may be no TOML string at all (a lone backslash)
        syntax = isinstance(value, str) and e.problem.startswith("not valid TOML")
        assert syntax or e.field in (f"joint {joint + 1} {field}", f"joint {joint + 1}"), str(e)
        return
    v = getattr(m.arm.joints[joint], field.replace("_deg", "_rad"))
    assert math.isfinite(v)


# ------------------------------------------------------------- writing a model

ANGLE = st.floats(min_value=-2 * math.pi, max_value=2 * math.pi, allow_nan=False)
LENGTH = st.floats(min_value=-3000.0, max_value=3000.0, allow_nan=False)
ONE_LINE = st.text(
    alphabet=st.characters(exclude_categories=["Cs"]), min_size=1, max_size=30
).filter(lambda s: bool(s.strip()) and "\n" not in s.strip())


@st.composite
def arm_models(draw: st.DrawFn) -> ArmModel:
    from aacmm.arm import Joint
    from aacmm.models import Encoder

    n = draw(st.integers(min_value=4, max_value=7))
    joints, limits, encoders = [], [], []
    for i in range(n):
        beta = draw(st.none() | ANGLE) if i > 0 else None
        joints.append(
            Joint(
                draw(st.sampled_from(["standard", "modified"])),
                draw(ANGLE),
                draw(ANGLE),
                draw(LENGTH),
                draw(LENGTH),
                beta,
            )
        )
        if draw(st.booleans()):
            limits.append((-math.inf, math.inf))
        else:
            lo = draw(st.floats(min_value=-2 * math.pi, max_value=2 * math.pi - 0.01))
            span = draw(st.floats(min_value=1e-3, max_value=2 * math.pi - 1e-3))
            limits.append((lo, min(lo + span, 2 * math.pi)))
        cpr = draw(st.integers(min_value=2, max_value=1 << 32))
        encoders.append(
            Encoder(
                cpr,
                draw(st.integers(min_value=0, max_value=cpr - 1)),
                draw(st.sampled_from([1, -1])),
                draw(st.sampled_from(["biss", "ssi", "ssi-gray", "counts"])),
            )
        )
    tip = draw(st.sampled_from(["z", "xyz"]))
    tz = draw(LENGTH)
    vec = (draw(LENGTH), draw(LENGTH), tz) if tip == "xyz" else (0.0, 0.0, tz)
    arm = Arm(joints=tuple(joints), tip=tip, tip_mm=vec)
    figures = [*arm.param_names[: 4 * n + len(arm.beta_joints)]]
    figures += [f"{k}{j}" for k in ("convention", "limits", "encoder") for j in range(1, n + 1)]
    assumed = set(draw(st.lists(st.sampled_from(figures), max_size=8)))
    if draw(st.booleans()):
        assumed |= set(arm.param_names[4 * n + len(arm.beta_joints) :])
    return ArmModel(
        name=draw(st.text(alphabet="abcXYZ019_-.", min_size=1, max_size=12)),
        description=draw(ONE_LINE).strip(),
        source=draw(ONE_LINE).strip(),
        arm=arm,
        joint_limits_rad=tuple(limits),
        encoders=tuple(encoders),
        assumed=frozenset(assumed),
        notes=draw(st.text(max_size=40).map(str.strip)),
    )


@settings(max_examples=150, deadline=None)
@given(arm_models())
def test_a_written_model_reads_back_equal(m: ArmModel) -> None:
    from aacmm.models import dumps_model

    assert loads_model(dumps_model(m)) == m


@pytest.mark.parametrize("name", MODELS)
def test_shipped_models_write_and_read_back(name: str) -> None:
    from dataclasses import replace

    from aacmm.models import dumps_model

    m = load_model(name)
    assert loads_model(dumps_model(m)) == replace(m, file=None)


def test_models_is_a_pure_library() -> None:
    """No argument parsing, printing or exits in aacmm.models; nothing from commands."""
    import ast

    import aacmm.models

    found = []
    for path in sorted(Path(aacmm.models.__file__).parent.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import | ast.ImportFrom):
                mods = [a.name for a in node.names] + [getattr(node, "module", None) or ""]
                if any(
                    m == "argparse" or m.startswith(("aacmm.commands", "aacmm.cli")) for m in mods
                ):
                    found.append(f"{path.name}:{node.lineno} imports {mods}")
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
                if node.func.id in ("print", "exit", "input"):
                    found.append(f"{path.name}:{node.lineno} calls {node.func.id}()")
    assert not found, found
