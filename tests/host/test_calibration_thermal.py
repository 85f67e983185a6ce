"""Issue 27 item 3, thermal: the link CTEs calibrated with the arm.

The study is tests/host/thermal_calib_study.py (module doc: the aluminium
truth, the sessions at 10 and 30 degC, the data sheet's CTEs as the start,
the verification at 28 degC). The calibration reads the counts, the plan and
the stated link temperatures only; the truth's CTEs are compared here,
afterwards.

- on the 20 arms of the data-sheet study (docs/calibration.md,
  "Temperature"; 8 of them not within 1.3x with the data sheet's CTE), the
  CTEs the data identify are within 3 reported sigma of the truth's, link 1's
  (a1 0.3 mm, d1 unobservable: not identified at the start) is held at the
  data sheet's value, and |E_Uni| at 28 degC with the calibrated CTEs is
  within 1.3x of the isothermal figure on every arm;
- a 2 degC span: ``auto`` estimates no CTE and says why; ``thermal=True``
  from one temperature holds every CTE as not identified (named: confounded
  with its link's lengths);
- without temperatures (or ``thermal=False``) the calibration is the one of
  before, bit for bit;
- ``aacmm calibrate`` on session files stating 15 and 25 degC writes the
  library's CTEs into the file's [errmodel] table and says params set sends
  it only to a device that reads its link temperatures; at 19 and 21 degC,
  or with a session stating none, it estimates none and says why;
  ``--thermal on`` without temperatures: exit 2, one line;
- a temperature per link of each pose (a device reading every link): the
  points are the truth's with each link scaled at its own temperature (the
  simulator's params_at against the C core's thermal model), a mean a pose
  misses them by micrometres, and noise-free data give back the CTEs.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from aacmm.calibration import calibrate
from aacmm.calibration.identifiability import DEFAULT_KAPPA, analyse
from aacmm.calibration.observations import ObservationError, combine
from aacmm.calibration.parameters import CalibParams
from aacmm.calibration.problem import Problem
from aacmm.calibration.thermal import with_ctes
from aacmm.core import Model, Params
from thermal_calib_study import (
    CASES,
    Outcome,
    ctes,
    observations,
    run,
    table,
)
from thermal_study import aluminium_truth

ARMS = tuple(range(1, 21))
_cache: dict[int, Outcome] = {}


def outcome(seed: int) -> Outcome:
    if seed not in _cache:
        _cache[seed] = run(seed)
    return _cache[seed]


@pytest.mark.parametrize("seed", ARMS)
def test_ctes_within_three_sigma(seed: int) -> None:
    o = outcome(seed)
    res = o.result
    assert isinstance(res.params, CalibParams)
    assert res.thermal.startswith("link CTEs estimated from link temperatures spanning 20.0")
    assert "held at the start value, 1e-6/K): cte1 23.00" in res.thermal, res.thermal
    assert "cte1" in res.fixed and res.params.errors.cte_per_k[0] == 23e-6
    assert res.thermal in res.notes
    assert res.chi_square.verdict != "refuted", res.chi_square
    v, sd = ctes(res)
    names = res.params.param_names
    identified = [i for i in range(6) if f"cte{i + 1} " in res.thermal.split("; not")[0]]
    assert identified == [1, 2, 3, 4, 5], res.thermal
    for i in identified:
        assert f"cte{i + 1}" in res.free and sd[i] > 0
        true = o.true_cte_per_k[i]
        assert abs(v[i] - true) <= 3.0 * sd[i], (names, i, v[i], true, sd[i])
        assert sd[i] < 2e-6  # at most a tenth of the CTE itself
    assert res.params.errors.tref_c == (20.0,) * 6


def test_verified_at_28_degc() -> None:
    outs = [outcome(s) for s in ARMS]
    print("\n" + table(outs))
    ratio = np.array([o.e_uni[CASES[1]] / o.e_uni[CASES[0]] for o in outs])
    assert float(ratio.max()) <= 1.3, ratio
    datasheet = np.array([o.e_uni[CASES[2]] / o.e_uni[CASES[0]] for o in outs])
    misses = tuple(o.seed for o, r in zip(outs, datasheet, strict=True) if r > 1.3)
    print(f"the data sheet's CTE on the same calibrated arms: over 1.3x on arms {misses}")
    assert len(misses) >= 4  # what the calibrated CTEs put right
    for o in outs:  # an MPE of 30 um + L/50 at least: every arm passes
        assert o.e_uni[CASES[1]] < 0.030


def test_two_degree_span_not_estimated() -> None:
    truth = aluminium_truth(3)
    obs = observations(truth, 1003, (19.0, 21.0))
    res = calibrate(obs, Params())
    assert isinstance(res.params, Params)
    assert "not estimated" in res.thermal and "span 2.0 degC" in res.thermal, res.thermal
    assert res.thermal in res.notes
    plain = calibrate(replace(obs, temp_c=None), Params())
    assert np.array_equal(res.params.to_vector(), plain.params.to_vector())


def test_one_temperature_not_identified() -> None:
    truth = aluminium_truth(3)
    obs = observations(truth, 1003, (25.0, 25.0))
    res = calibrate(obs, Params(), thermal=True)
    assert isinstance(res.params, CalibParams)
    held = {f"cte{i}" for i in range(1, 7)}
    assert held <= set(res.fixed)  # held at the start, for the whole fit
    assert "not identified" in res.thermal
    assert all(n in res.thermal.split("not identified")[1] for n in held), res.thermal
    start, _ = with_ctes(obs, Params())
    ident = analyse(Problem(obs).evaluate(start), list(range(31)), DEFAULT_KAPPA)
    kinds = [d.kind for d in ident.null]
    assert kinds.count("thermal") == 6
    assert res.params.errors.cte_per_k == (0.0,) * 6  # held at the start value


def test_default_path_unchanged() -> None:
    truth = aluminium_truth(4)
    obs = observations(truth, 1004, (20.0,))
    bare = replace(obs, temp_c=None)
    a = calibrate(bare, Params())
    b = calibrate(bare, Params(), thermal=False)
    c = calibrate(obs, Params(), thermal=False)
    assert "state no link temperature" in a.thermal
    assert a.notes == b.notes and "link CTEs" not in " ".join(a.notes)
    for r in (b, c):
        assert isinstance(r.params, Params)
        assert np.array_equal(r.params.to_vector(), a.params.to_vector())
        assert np.array_equal(r.covariance, a.covariance)
        assert r.chi_square.chi2 == a.chi_square.chi2
    with pytest.raises(ValueError, match="needs the observations' link temperatures"):
        calibrate(bare, Params(), thermal=True)
    with pytest.raises(ValueError, match="thermal must be"):
        calibrate(obs, Params(), thermal="yes")
    with pytest.raises(ObservationError, match="some observations, not all"):
        combine([obs, bare])
    with pytest.raises(ObservationError, match="link temperature must be within"):
        calibrate(replace(obs, temp_c=np.full(obs.n_poses, 99.0)), Params())


def _session_files(tmp: Path, temps: tuple[float | None, ...]) -> list[str]:
    """Kinematic-calibration sessions of aluminium arm 3 as ``aacmm capture`` writes
    them, each with its run's stated temperature (None: not stated, probed at 20 degC)."""
    from aacmm.plans import load_plan
    from gate_study import Sampled, record, write_session
    from thermal_study import sessions

    truth = aluminium_truth(3)
    plan = load_plan("kinematic-calibration")
    tmp.mkdir(parents=True, exist_ok=True)
    out = []
    for k, t in enumerate(temps):
        at = 20.0 if t is None else t
        s = sessions(plan, truth, 1003 + 100 * k, (at,))[at]
        folder = tmp / f"s{k}"
        sampled = Sampled(plan, s.counts, record(Params()))
        if t is None:
            write_session(folder, sampled, serial=7)
        else:
            write_session(folder, sampled, serial=7, temperature_c=t)
        out.append(str(folder))
    return out


def test_calibrate_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from aacmm.cli import main
    from aacmm.records.paramfile import load_param_file_errmodel

    paths = _session_files(tmp_path, (15.0, 25.0))
    out = tmp_path / "cal.toml"
    assert main(["calibrate", *paths, "-o", str(out), "-q"]) == 0
    text = capsys.readouterr().out
    assert "link CTEs estimated from link temperatures spanning 10.0 degC" in text
    assert "cte2" in text and "ppm/K" in text
    assert "aacmm params set sends them to a device that reads its link temperatures" in text
    *_, em = load_param_file_errmodel(out)
    # the library on the same data (the study's observations of the same sessions)
    lib = calibrate(observations(aluminium_truth(3), 1003, (15.0, 25.0)), Params())
    assert isinstance(lib.params, CalibParams)
    assert np.allclose(em.cte_per_k, lib.params.errors.cte_per_k, rtol=1e-9, atol=1e-15)
    assert em.tref_c == (20.0,) * 6
    # params set sends a thermal file only to a device with sensors (its check says so)
    assert main(["params", "set", str(out), "--check"]) == 0
    assert "only a device that reads its link temperatures takes it" in capsys.readouterr().out


def test_calibrate_command_without_estimate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from aacmm.cli import main
    from aacmm.records.paramfile import load_param_file_errmodel

    narrow = _session_files(tmp_path / "narrow", (19.0, 21.0))
    out = tmp_path / "n.toml"
    assert main(["calibrate", *narrow, "-o", str(out), "-q"]) == 0
    text = capsys.readouterr().out
    assert "span 2.0 degC, at least 5 degC needed" in text
    *_, em = load_param_file_errmodel(out)
    assert em is None or not any(em.cte_per_k)
    unstated = _session_files(tmp_path / "unstated", (15.0, None))
    assert main(["calibrate", *unstated, "-o", str(tmp_path / "u.toml"), "-q"]) == 0
    assert "a capture run states no link temperature" in capsys.readouterr().out
    bad = tmp_path / "bad.toml"
    assert main(["calibrate", *unstated, "-o", str(bad), "-q", "--thermal", "on"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--thermal on" in err[0] and not bad.exists()


def test_each_link_at_its_own_temperature() -> None:
    """Observations with a temperature per link of each pose (a device reading every
    link): the model's points are those of the truth with each link's lengths scaled
    at its own temperature (the simulator's params_at, in Python, against the C
    core's thermal model the calibration evaluates); one mean temperature a pose
    would miss them by micrometres; a noise-free calibration recovers the CTEs."""
    from aacmm.calibration.observations import Observations, ReferencePoints
    from aacmm.errmodel import ErrorModel
    from aacmm.simulation.thermal import params_at

    truth = aluminium_truth(5)
    assert truth.thermal is not None and isinstance(truth.params, Params)
    rng = np.random.default_rng(27)
    n = 60
    th = rng.uniform(-2.5, 2.5, size=(n, 6))
    temps = rng.uniform(12.0, 34.0, size=(n, 6))
    xyz = np.array(
        [
            Model(params_at(truth.params, truth.thermal, t)).point(q)
            for q, t in zip(th, temps, strict=True)
        ]
    )
    ref = ReferencePoints("tracker", np.arange(n), xyz, u_mm=0.001, base_known=True)
    obs = Observations(th, np.full(n, 0.001), (ref,), temp_c=temps)
    assert obs.temp_c is not None and obs.temp_c.shape == (n, 6)
    errors = ErrorModel(((),) * 6, truth.thermal.cte_per_k, truth.thermal.tref_c)
    exact = Problem(obs).residuals(CalibParams(truth.params, errors))
    np.testing.assert_allclose(exact.points, xyz, rtol=0, atol=1e-9)
    mean = replace(obs, temp_c=temps.mean(axis=1))
    assert mean.temp_c is not None and np.all(mean.temp_c == mean.temp_c[:, :1])
    off = Problem(mean).residuals(CalibParams(truth.params, errors))
    assert np.abs(off.points - xyz).max() > 0.001  # mm: over a micrometre somewhere
    res = calibrate(obs, truth.params, thermal=True, harmonics=0)
    assert isinstance(res.params, CalibParams)
    got = np.array(res.params.errors.cte_per_k)
    np.testing.assert_allclose(got, truth.thermal.cte_per_k, rtol=0, atol=1e-9)
    with pytest.raises(ObservationError, match=r"got 99.0 \(link 3\)"):
        bad = temps.copy()
        bad[4, 2] = 99.0
        Observations(th, np.full(n, 0.001), (ref,), temp_c=bad).validate()
    with pytest.raises(ObservationError, match=r"per link of each pose \(60, 6\)"):
        Observations(th, np.full(n, 0.001), (ref,), temp_c=temps[:, :5])
