"""Encoder angle harmonics in the calibration (issue 27) against a known truth.

The observations are synthesised independently of the solver: exact joint
angles on a known arm (tests/host/calib_synth.py), then the encoder readings
``r`` that a true harmonic error model maps back onto them
(``r + e(r) = q``, solved here by fixed-point steps and checked with
:func:`aacmm.errmodel.corrected_angles`). The calibration sees only the
readings; the tests compare what it finds with the truth. The last test runs
the simulator's one-head encoder grade end to end (sim, capture, calibrate) and
judges the calibrations on a held-out session.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from aacmm.calibration import ReferencePoints, calibrate
from aacmm.calibration.gate import previous_from_provenance
from aacmm.calibration.harmonics import WEAK_OBSERVABILITY, parse_harmonics
from aacmm.calibration.parameters import CalibParams, arm_part, error_model
from aacmm.calibration.results import TERM_ESTIMATED, TERM_UNOBSERVED, TERM_WEAK
from aacmm.cli import main
from aacmm.core import Model, Params
from aacmm.errmodel import ErrorModel, corrected_angles
from aacmm.errmodel import points as em_points
from aacmm.protocol import param_set_crc32
from aacmm.protocol.errwire import with_error_model
from aacmm.records.paramfile import ParamFileError, load_param_file, load_param_file_errmodel
from calib_synth import perturbed_truth, plan_session, random_poses, synthetic
from test_calibration import combos, obs_of, observations

pytestmark = pytest.mark.timeout(300)
ARCSEC = math.pi / 648000.0
SIGMA = 0.005


def head_errors(rng: np.random.Generator, k: int = 2, joints: int = 6) -> ErrorModel:
    """One-read-head-like encoder errors: harmonics 1 .. k of 10 to 30 arcsec, any phase."""
    hs = []
    for _ in range(joints):
        amp = rng.uniform(10.0, 30.0, k) * ARCSEC
        ph = rng.uniform(0.0, 2 * math.pi, k)
        hs.append(
            tuple(
                (float(a * math.cos(p)), float(a * math.sin(p)))
                for a, p in zip(amp, ph, strict=True)
            )
        )
    return ErrorModel(tuple(hs))


def readings(em: ErrorModel, q: np.ndarray) -> np.ndarray:
    """The readings r with r + e(r) = q (the encoder's view of the exact angles q)."""
    r = np.array(q, dtype=np.float64, copy=True)
    for _ in range(40):
        r = q - (corrected_angles(em, r) - r)
    assert np.max(np.abs(corrected_angles(em, r) - q)) <= 1e-15
    return r


def with_readings(s, em: ErrorModel):  # type: ignore[no-untyped-def]
    s.cone_q = [readings(em, q) for q in s.cone_q]
    s.length_qa, s.length_qb = readings(em, s.length_qa), readings(em, s.length_qb)
    return s


def coefficients(em: ErrorModel) -> np.ndarray:
    return np.array([v for h in em.harmonics for pair in h for v in pair])


def points_of(p: Params | CalibParams, r: np.ndarray) -> np.ndarray:
    m, em = Model(arm_part(p)), error_model(p)
    return m.points(r) if em is None else em_points(m, em, r)


def rms_vs_truth(
    p: Params | CalibParams, truth: Params, true_em: ErrorModel, r: np.ndarray
) -> float:
    """RMS distance (mm) of the calibrated points from the true ones at readings r,
    after the base motion the data cannot see (theta1, d1 held at their start)."""
    pc, pt = points_of(p, r), em_points(Model(truth), true_em, r)
    a = arm_part(p)
    assert isinstance(a, Params)
    dth = a.theta_offset_rad[0] - truth.theta_offset_rad[0]
    rz = np.array(
        [[math.cos(dth), -math.sin(dth), 0], [math.sin(dth), math.cos(dth), 0], [0, 0, 1.0]]
    )
    pt = pt @ rz.T + np.array([0.0, 0.0, a.d_mm[0] - truth.d_mm[0]])
    return float(np.sqrt(np.mean(np.sum((pc - pt) ** 2, axis=1))))


# --------------------------------------------------------------------------- noise-free


def test_noise_free_harmonics_recovered() -> None:
    em = head_errors(np.random.default_rng(40))
    s = with_readings(synthetic(3), em)
    obs = observations(s)
    res = calibrate(obs, harmonics=2)
    assert isinstance(res.params, CalibParams)
    assert res.params.harmonics == (2,) * 6
    assert res.params.param_names[25:29] == ("c1_1", "s1_1", "c1_2", "s1_2")
    err = np.abs(coefficients(res.params.errors) - coefficients(em))
    assert err.max() <= 1e-9, err.max()
    arm = res.params.arm
    assert isinstance(arm, Params)
    assert np.max(np.abs(combos(arm) - combos(s.truth))) <= 1e-9
    assert {t.status for t in res.error_terms} == {TERM_ESTIMATED}
    assert len(res.error_terms) == 24 and all(t.in_model for t in res.error_terms)
    assert res.covariance.shape == (49, 49)
    # a per-joint K: the same as one K for every joint
    per_joint = calibrate(obs, harmonics=[2, 2, 2, 2, 2, 2])
    assert np.array_equal(per_joint.params.to_vector(), res.params.to_vector())
    # the arm alone cannot describe them: the chi-square check says so
    dh = calibrate(obs)
    assert dh.chi_square.verdict == "incomplete"


def test_k0_is_the_arm_alone_bit_for_bit() -> None:
    s = synthetic(1000, noise_mm=SIGMA)
    obs = observations(s)
    plain = calibrate(obs)
    k0 = calibrate(obs, harmonics=0)
    # an error model without harmonics through the error-model path of the core
    none = calibrate(obs, CalibParams(Params(), ErrorModel.none(6)))
    for r in (k0, none):
        assert np.array_equal(arm_part(r.params).to_vector(), plain.params.to_vector())
        assert np.array_equal(r.covariance, plain.covariance)
        assert np.array_equal(r.after.r, plain.after.r)
        assert r.chi_square.chi2 == plain.chi_square.chi2
        assert r.held == plain.held and r.free == plain.free
    assert isinstance(k0.params, Params) and k0.error_terms == ()
    assert not error_model(k0.params)


# --------------------------------------------------------------------------- with noise


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_noisy_one_head_harmonics(seed: int) -> None:
    em = head_errors(np.random.default_rng(500 + seed))
    clean = synthetic(2000 + seed, noise_mm=SIGMA)
    s = with_readings(synthetic(2000 + seed, noise_mm=SIGMA), em)
    obs = observations(s)
    baseline = calibrate(observations(clean))  # no harmonics in the data, the arm alone
    full = calibrate(obs, harmonics=2)
    assert isinstance(full.params, CalibParams)
    dh = calibrate(obs)
    q = random_poses(np.random.default_rng(9), 2000, (0.3, 1.4), (0.6, 1.8))
    r = readings(em, q)
    b = rms_vs_truth(baseline.params, clean.truth, ErrorModel.none(6), q)
    f = rms_vs_truth(full.params, s.truth, em, r)
    d = rms_vs_truth(dh.params, s.truth, em, r)
    assert f <= 3.0 * b, (f, b)  # near the baseline: 24 more unknowns from the same data
    assert d >= 5 * b and d >= 5 * f, (d, b, f)
    assert baseline.chi_square.verdict == "consistent"
    assert full.chi_square.verdict == "consistent"
    assert dh.chi_square.verdict == "incomplete"
    # the coefficients within their uncertainty
    est = coefficients(full.params.errors)
    sd = np.array([t.std for t in full.error_terms])
    assert np.all(np.abs(est - coefficients(em)) <= 5 * sd)


# --------------------------------------------------------------------------- identifiability


def test_limited_range_joint_is_named_weak_or_unobserved() -> None:
    # reference points in the base frame, joint 2 over 0.1 rad only, the others all around
    truth = perturbed_truth(np.random.default_rng(5))
    em = head_errors(np.random.default_rng(6))
    rng = np.random.default_rng(7)
    n = 200
    q = rng.uniform(-3.0, 3.0, (n, 6))
    q[:, 1] = rng.uniform(0.8, 0.9, n)
    r = readings(em, q)
    x = Model(truth).points(q)
    obs = obs_of(r, (ReferencePoints("tracker", np.arange(n), x, 0.0, base_known=True),))
    res = calibrate(obs, harmonics=2)
    assert isinstance(res.params, CalibParams)
    by = {t.name: t for t in res.error_terms}
    j2 = [by[f"{w}2_{k}"] for k in (1, 2) for w in "cs"]
    # noise-free: the rank tolerance at the solution is the rounding floor, so the
    # joint's terms are estimated, but hardly any of their effect is their own
    assert all(t.status in (TERM_WEAK, TERM_UNOBSERVED) for t in j2), j2
    assert all(t.observability < 1e-3 for t in j2), j2
    others = [t for t in res.error_terms if t.joint != 2]
    assert all(t.status == TERM_ESTIMATED for t in others)
    # the observability against another computation: the share of the scaled column
    # left after least squares on the other free columns (and the nuisance projection)
    names = list(res.params.param_names)
    free = [names.index(nm) for nm in res.free]
    a = res.after.jac[:, free] / np.sqrt(res.after.raw_norm2[free])
    for t in others[:4] + [t for t in j2 if t.status == TERM_WEAK]:
        i = free.index(names.index(t.name))
        rest = np.delete(a, i, axis=1)
        coef, *_ = np.linalg.lstsq(rest, a[:, i], rcond=None)
        share = np.linalg.norm(a[:, i] - rest @ coef)
        assert t.observability == pytest.approx(share, rel=1e-6, abs=1e-9), t
    # auto: the joint's harmonics not taken, the others' are
    auto = calibrate(obs, harmonics="auto")
    assert isinstance(auto.params, CalibParams)
    ks = auto.params.harmonics
    assert ks[1] == 0 and all(k >= 2 for i, k in enumerate(ks) if i != 1), ks
    assert all(t.observability >= WEAK_OBSERVABILITY for t in auto.error_terms)
    assert "auto: the largest K the data identify" in " ".join(auto.notes)


def test_tip_on_the_last_axis_leaves_its_harmonics_out() -> None:
    # alpha6 = 0: the tip on axis 6, its angle moves no probe point
    v = Params().to_vector()
    v[11] = 0.0
    truth = Params.from_vector(v)
    q = np.random.default_rng(3).uniform(-3.0, 3.0, (120, 6))
    q[:, 1] = np.random.default_rng(4).uniform(0.2, 1.5, 120)
    obs = obs_of(
        q,
        (ReferencePoints("tracker", np.arange(120), Model(truth).points(q), 0.0, True),),
    )
    res = calibrate(obs, truth, harmonics=1, free=("theta", "d", "a", "alpha"))
    six = [t for t in res.error_terms if t.joint == 6]
    assert [t.name for t in six] == ["c6_1", "s6_1"]
    assert all(t.status == TERM_UNOBSERVED and not t.in_model for t in six)
    assert isinstance(res.params, CalibParams) and res.params.harmonics[5] == 0


def test_parse_harmonics() -> None:
    assert parse_harmonics(3, 6) == (3,) * 6
    assert parse_harmonics("auto", 6) is None
    assert parse_harmonics("1,2,0,0,4,1", 6) == (1, 2, 0, 0, 4, 1)
    for bad in (5, -1, "x", [1, 2]):
        with pytest.raises(ValueError):
            parse_harmonics(bad, 6)
    with pytest.raises(ValueError, match=r"0 \.\. 4"):
        calibrate(observations(synthetic(3)), harmonics=5)


# --------------------------------------------------------------------------- aacmm calibrate


@pytest.fixture(scope="module")
def head_session(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, ErrorModel]:
    em = head_errors(np.random.default_rng(41))
    d = tmp_path_factory.mktemp("harm") / "s1"
    truth = perturbed_truth(np.random.default_rng(101))
    plan_session(d, "kinematic-calibration", truth, 102, SIGMA, readings=lambda q: readings(em, q))
    return d, em


def _one_line(err: str) -> str:
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1, err
    return lines[0]


def test_cli_harmonics(
    head_session: tuple[Path, ErrorModel], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    session, em = head_session
    out_file = tmp_path / "cal.toml"
    rep = tmp_path / "rep"
    args = ["-o", str(out_file), "--harmonics", "2", "-q", "--workspace", "5"]
    code = main(["calibrate", str(session), *args, "--report", str(rep)])
    out, err = capsys.readouterr()
    assert code == 0, err
    report = json.loads((rep / "report.json").read_text())
    assert len(report["result"]["error_model"]["terms"]) == 24
    assert "c6_2" in report["result"]["calibrated"]
    assert "Encoder angle harmonics (2)" in (rep / "report.txt").read_text()
    assert "Encoder angle harmonics (2): 24 of 24 terms estimated" in out
    assert f"load it and its [errmodel] table with: aacmm params set {out_file} --save" in out
    prov = json.loads((tmp_path / "cal.provenance.json").read_text())
    terms = prov["result"]["error_model"]["terms"]
    assert [t["name"] for t in terms[:2]] == ["c1_1", "s1_1"] and len(terms) == 24
    assert prov["settings"]["harmonics"] == "2"
    assert prov["result"]["chi_square"]["verdict"] == "consistent"
    # the file carries the coefficients: read back, near the truth
    ps, arm, got = load_param_file_errmodel(out_file)
    # the CRC it and its provenance name is the one the device will hold (the harmonics
    # in the wire's units: what `params set` sends), and as --previous the provenance
    # gives the arm's parameters and their (marginal) covariance block
    assert got is not None
    want = f"0x{param_set_crc32(with_error_model(ps, got)):08x}"
    assert prov["arm"]["calibrated_param_crc32"] == want
    assert f"param_crc32 = {int(want, 16)}" in out_file.read_text()
    prev = previous_from_provenance(prov, "cal.provenance.json", like=Params())
    full = np.asarray(prov["result"]["covariance"])
    assert full.shape == (25 + 24, 25 + 24) and prev.covariance.shape == (25, 25)
    assert np.array_equal(prev.covariance, full[:25, :25])
    assert got is not None and arm is not None and ps.joints == 6
    sd = np.array([t["std_rad"] for t in terms])
    assert np.all(np.abs(coefficients(got) - coefficients(em)) <= 5 * sd)
    # a reader that takes the arm's parameters only refuses it in one line
    with pytest.raises(ParamFileError, match="errmodel"):
        load_param_file(out_file)
    assert main(["params", "set", str(out_file), "--check"]) == 0
    out, _ = capsys.readouterr()
    assert "error model: encoder harmonics K per joint 2,2,2,2,2,2" in out
    # the default: auto, stated per joint; the session's true K = 2 on every joint
    dflt = tmp_path / "default.toml"
    assert main(["calibrate", str(session), "-o", str(dflt), "-q", "--workspace", "0"]) == 0
    out, _ = capsys.readouterr()
    assert "Encoder angle harmonics (auto: the largest K the data identify, 2,2,2,2,2,2)" in out
    assert "note: encoder harmonics, auto: joint 1: K 2 (k = 3" in out
    got = load_param_file_errmodel(dflt)[2]
    assert got is not None and [len(h) for h in got.harmonics] == [2] * 6
    # --harmonics 0: the arm alone, no [errmodel] table
    plain = tmp_path / "plain.toml"
    args = ["-o", str(plain), "--harmonics", "0", "-q", "--workspace", "0"]
    assert main(["calibrate", str(session), *args]) in (0, 9)
    capsys.readouterr()
    if plain.exists():
        assert "errmodel" not in plain.read_text()


def test_cli_harmonics_auto_and_refusals(
    head_session: tuple[Path, ErrorModel], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    session, _ = head_session
    out_file = tmp_path / "auto.toml"
    code = main(
        [
            "calibrate",
            str(session),
            "-o",
            str(out_file),
            "--harmonics",
            "auto",
            "-q",
            "--workspace",
            "0",
        ]
    )
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "auto: the largest K the data identify, " in out
    assert load_param_file_errmodel(out_file)[2] is not None
    for bad in ("5", "-1", "two", "1.5"):
        x = tmp_path / "x.toml"
        code = main(["calibrate", str(session), "-o", str(x), "--harmonics", bad])
        _, err = capsys.readouterr()
        assert code == 2 and "--harmonics" in _one_line(err), (bad, err)
        assert not x.exists()
    code = main(["calibrate", str(session), "-o", str(x), "--probe", "--harmonics", "1"])
    _, err = capsys.readouterr()
    assert code == 2 and "--probe" in _one_line(err)


def test_errmodel_table_round_trip_and_errors(tmp_path: Path) -> None:
    from aacmm.core import EncoderConfig
    from aacmm.records import ParamSetRecord
    from aacmm.records.paramfile import dump_param_set

    em = ErrorModel((((1e-5, -2e-6),), (), ((3e-5, 4e-6), (5e-7, -6e-7)), (), (), ((7e-6, 1e-6),)))
    ps = ParamSetRecord(0, Params(), EncoderConfig()).to_device()
    f = tmp_path / "p.toml"
    f.write_text(dump_param_set(ps, "toml", errmodel=em))
    got_ps, _, got = load_param_file_errmodel(f)
    assert got == em and got_ps == ps
    assert load_param_file_errmodel(tmp_path / "p.toml")[2] is not None
    plain = tmp_path / "plain.toml"
    plain.write_text(dump_param_set(ps, "toml"))
    assert load_param_file_errmodel(plain)[2] is None
    text = f.read_text()
    for bad, needle in (
        (text.replace("[errmodel]", "[errmodel]\nk = 1"), "unknown key errmodel.k"),
        (text.replace("c_rad = [", "c_rad = [[1e-6],"), "6 lists"),
        (text.replace("c_rad = [\n    [", "c_rad = [\n    [1e-6, 1e-6, "), "as many values"),
        (text.replace("1e-05", "0.2"), "0.1"),
    ):
        f.write_text(bad)
        with pytest.raises(ParamFileError, match=needle):
            load_param_file_errmodel(f)


# --------------------------------------------------------------------------- on the simulator


def _sim_session(folder: Path, name: str, seed: int) -> Path:
    """A kinematic-calibration session of the simulator's one-head encoders (random:12)."""
    import os
    import subprocess
    import sys

    aacmm = Path(sys.executable).with_name("aacmm")
    env = {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}
    sim = subprocess.Popen(
        [str(aacmm), "sim", "--scenario", "kinematic-calibration", "--fast", "--truth",
         "random:12", "--encoder-grade", "one-head", "--storage", str(folder / f"{name}.bin"),
         "--seed", str(seed), "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    try:
        assert sim.stdout is not None
        url = sim.stdout.readline().strip()
        assert url.startswith("serial://"), sim.stderr.read() if sim.stderr else ""
        cap = subprocess.run(
            [str(aacmm), "capture", "kinematic-calibration", "-o", str(folder / name), "--port",
             url, "-q"],
            capture_output=True, text=True, env=env, timeout=240, check=False,
        )  # fmt: skip
        assert cap.returncode == 0, cap.stderr
        sim.communicate(timeout=120)
    finally:
        if sim.poll() is None:
            sim.kill()
            sim.wait()
    return folder / name


def test_end_to_end_one_head_encoders(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # the simulator's one-head grade: harmonics 1 and 2 of 10-30 arcsec in the counts
    s1, s2 = _sim_session(tmp_path, "s1", 1), _sim_session(tmp_path, "s2", 2)
    held_out = {}
    for k in ("0", "2"):
        out = tmp_path / f"cal{k}.toml"
        args = ["--validate", str(s2), "--harmonics", k, "--workspace", "0", "-q", "--override"]
        assert main(["calibrate", str(s1), "-o", str(out), *args]) == 0
        capsys.readouterr()
        prov = json.loads(out.with_name(f"cal{k}.provenance.json").read_text())
        rows = {r["figure"]: r for r in prov["validation"]}
        held_out[k] = (prov["result"]["chi_square"]["verdict"], rows["length_rms_mm"]["after"])
    assert held_out["0"][0] == "incomplete"
    assert held_out["2"][0] in ("consistent", "overstated")
    assert held_out["2"][1] <= 0.010 and held_out["2"][1] * 10 <= held_out["0"][1], held_out


def test_auto_takes_almost_no_harmonics_from_coarse_encoders_quantisation() -> None:
    """Readings of 14- and 16-bit encoders (one count 384 and 96 urad: their
    quantisation, an error no harmonic describes, far above the stated 5 um) of arms
    without harmonics, three arms each. Against the stated uncertainties nearly every
    order looks significant (measured: K 4 on almost every joint); against the scatter
    the full fit leaves, auto takes harmonics on at most one joint per arm and none on
    most (measured: two joints of the six arms take any, K 4 and K 2), and says why."""
    taken, none = 0, 0
    for bits in (14, 16):
        for seed in (11, 21, 31):
            truth = perturbed_truth(np.random.default_rng(seed))
            rng = np.random.default_rng(seed + 1)
            n = 300
            q = rng.uniform(-3.0, 3.0, (n, 6))
            count = 2 * math.pi / 2**bits
            r = np.round(q / count) * count  # what the coarse encoders read
            x = Model(truth).points(q)
            cons = (ReferencePoints("tracker", np.arange(n), x, 0.0, base_known=True),)
            auto = calibrate(obs_of(r, cons), harmonics="auto")
            assert auto.chi_square.verdict == "incomplete"  # the quantisation is unmodelled
            ks = auto.params.harmonics if isinstance(auto.params, CalibParams) else (0,) * 6
            assert sum(1 for k in ks if k) <= 1, (bits, seed, ks)
            taken += sum(ks)
            none += not any(ks)
            assert "not significant against the residual scatter" in " ".join(auto.notes)
    assert none >= 4 and taken <= 8, (none, taken)
