"""Issue 27, thermal: an aluminium arm calibrated at 20 degC and verified at 28 degC.

The study is tests/host/thermal_study.py (module doc: the truth, the sessions,
the compensation, the artefacts). Here: the warm truth agrees with the C
core's thermal model, and on 20 random arms (seeds 1..20, about 1 s)

- without compensation |E_Uni| grows (the links 184 ppm longer: about 0.19 mm
  over the 1 m bar) and fails its MPE on every arm;
- compensated with the true CTEs (a control: what a thermal calibration of
  the CTEs would give) it is the isothermal |E_Uni| to within 0.5 um;
- compensated with the data-sheet CTE (23e-6 /K on every link, the links'
  true CTEs 22..24e-6 /K) |E_Uni| passes its MPE on every arm, is at least
  5x below the uncompensated one, and within 1.3x of the isothermal run in
  the median (per arm: the count is printed; docs/calibration.md,
  "Temperature");

and ``aacmm verify --params FILE --temperature C`` on such a session: the
study's compensated figure from the session's counts, the report's
temperature and compensation lines, and every bad input refused in one line
(exit status 2, nothing written).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from aacmm.core import Params
from aacmm.simulation.thermal import true_points
from calib_synth import random_poses
from thermal_study import (
    CASES,
    ORACLE,
    T_REF_C,
    T_WARM_C,
    Outcome,
    aluminium_truth,
    calibrated,
    compensation,
    run,
    sessions,
    table,
    warm_params,
)

SEEDS = range(1, 21)


def test_warm_truth_is_the_core_thermal_model() -> None:
    truth = aluminium_truth(3)
    assert truth.thermal is not None
    assert set(truth.thermal.material) == {"aluminium"}
    assert all(22e-6 <= a <= 24e-6 for a in truth.thermal.cte_per_k)
    q = random_poses(np.random.default_rng(1), 50, (0.3, 1.4), (0.6, 1.8))
    from aacmm.core import Model

    warm = Model(warm_params(truth.params, truth.thermal, T_WARM_C)).points(q)
    core = true_points(truth, q, np.full(6, T_WARM_C))
    assert np.max(np.abs(warm - core)) < 1e-9
    cold = Model(truth.params).points(q)
    assert np.max(np.linalg.norm(warm - cold, axis=1)) > 0.1  # 8 K moves the tip


@pytest.fixture(scope="module")
def outcomes() -> list[Outcome]:
    return [run(s) for s in SEEDS]


def test_e_uni_20_to_28_degc(outcomes: list[Outcome]) -> None:
    print("\n" + table(outcomes))
    iso, raw, comp = CASES
    ratios = []
    for o in outcomes:
        e = o.e_uni
        where = f"seed {o.seed}: {', '.join(f'{k} {v * 1e3:.1f} um' for k, v in e.items())}"
        # uncompensated: the warm links' growth, far beyond the isothermal arm
        assert e[raw] > 0.15 and e[raw] > 8.0 * e[iso], where
        assert o.reports[raw].result("e_uni").decision.failed, where
        assert o.reports[iso].result("e_uni").decision.passed, where
        # the control: the compensation itself is exact when the CTEs are
        assert abs(e[ORACLE] - e[iso]) < 0.5e-3, where
        # the data-sheet CTE: most of the growth removed, within the MPE
        assert o.reports[comp].result("e_uni").decision.passed, where
        assert e[comp] < e[raw] / 5.0, where
        ratios.append(e[comp] / e[iso])
    within = sum(r <= 1.3 for r in ratios)
    print(
        f"compensated / isothermal |E_Uni|: median {np.median(ratios):.2f}, "
        f"worst {max(ratios):.2f}; within 1.3x on {within} of {len(ratios)} arms"
    )
    assert float(np.median(ratios)) <= 1.3


# ------------------------------------------------------------------ aacmm verify --temperature


def _one_line(err: str) -> str:
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1, err
    return lines[0]


@pytest.fixture(scope="module")
def warm_session(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Params, float]:
    """A verification session of arm 2 at 28 degC with its 20 degC calibration in force
    (the sessions of ``run(2)``), the calibration's parameter file with the data-sheet
    CTE in its [errmodel] table, and what the study finds for it compensated."""
    from aacmm.plans import load_plan
    from aacmm.records.paramfile import dump_param_set
    from gate_study import Sampled, record, write_session

    seed = 2
    truth = aluminium_truth(seed)
    cal = calibrated(truth, 1000 + seed)
    plan = load_plan("arm-verification")
    warm = sessions(plan, truth, 2000 + seed, (T_REF_C, T_WARM_C))[T_WARM_C]
    folder = tmp_path_factory.mktemp("thermal")
    in_force = record(cal)
    session = write_session(folder / "s28", Sampled(plan, warm.counts, in_force), serial=7)
    # the same, its temperature stated at capture (aacmm capture --temperature 28)
    write_session(
        folder / "s28-stated", Sampled(plan, warm.counts, in_force), serial=7, temperature_c=28.0
    )
    params = folder / "cal.toml"
    params.write_text(dump_param_set(in_force.to_device(), "toml", errmodel=compensation()))
    return session, params, cal, run(seed).e_uni[CASES[2]]


def _e_uni(out: str) -> float:
    doc = json.loads(out)
    (res,) = [r for r in doc["results"] if r["key"] == "e_uni"]
    return abs(float(res["value_mm"]))


def test_cli_verify_temperature(
    warm_session: tuple[Path, Path, Params, float],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from aacmm.cli import main

    session, params, _, expected = warm_session
    # without compensation the warm arm fails its length test
    assert main(["verify", str(session), "--json", "-"]) == 7
    plain = _e_uni(capsys.readouterr().out)
    assert plain > 0.15
    # compensated: the study's figure, recomputed from the session's counts
    code = main(["verify", str(session), "--params", str(params), "--temperature", "28"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "temp.      28 C on every link (stated with --temperature; the arm measures" in out
    assert (
        f"compens.   thermal expansion CTE per link 23e-6 /K, reference 20 degC ({params})" in out
    )
    assert "the plan states the test at 20 C; the session was taken at 28 C (compensated" in out
    js = tmp_path / "r.json"
    assert main(["verify", str(session), "--params", str(params), "--temperature", "28",
                 "--json", str(js), "-q"]) == 0  # fmt: skip
    capsys.readouterr()
    doc = json.loads(js.read_text())
    assert doc["temperature_c"] == 28.0 and "28 C on every link" in doc["session"]["temperature"]
    assert _e_uni(js.read_text()) == pytest.approx(expected, abs=1e-9)
    assert _e_uni(js.read_text()) < plain / 5.0


def test_cli_verify_temperature_refusals(
    warm_session: tuple[Path, Path, Params, float],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from aacmm.cli import main
    from aacmm.core import EncoderConfig
    from aacmm.errmodel import ErrorModel
    from aacmm.protocol import ParamSet
    from aacmm.records.paramfile import dump_param_set

    session, params, cal, _ = warm_session
    other = tmp_path / "other.toml"  # the nominal set: not the one in force
    other.write_text(
        dump_param_set(
            ParamSet.from_core(Params(), EncoderConfig()), "toml", errmodel=compensation()
        )
    )
    bare = tmp_path / "bare.toml"  # the set in force, no error model
    bare.write_text(dump_param_set(ParamSet.from_core(cal, EncoderConfig()), "toml"))
    harm = tmp_path / "harm.toml"  # the set in force, harmonics only
    em = ErrorModel(harmonics=(((1e-6, 0.0),),) + ((),) * 5)
    harm.write_text(dump_param_set(ParamSet.from_core(cal, EncoderConfig()), "toml", errmodel=em))
    out = tmp_path / "r.json"
    p = ["--params", str(params)]
    cases = [
        (["--temperature", "100", *p], "--temperature 100: the links' temperature must be"),
        (["--temperature", "-41", *p], "within -40 .. 85 degC"),
        (["--temperature", "nan", *p], "--temperature nan: the links' temperature must be"),
        (["--temperature", "inf", *p], "--temperature inf"),
        (
            ["--temperature", "warm", *p],
            "--temperature warm: the links' temperature must be a number",
        ),
        (["--temperature", "28"], "--temperature needs the links' thermal expansion"),
        (p, "point 1's capture run states no temperature: give --temperature C"),
        (["--params", str(other), "--temperature", "28"], "the session was captured with"),
        (["--params", str(bare)], "no [errmodel] table, nothing to apply"),
        (["--params", str(harm), "--temperature", "28"], "has no thermal expansion coefficients"),
        (["--params", str(tmp_path / "none.toml"), "--temperature", "28"], "none.toml"),
    ]
    for args, want in cases:
        code = main(["verify", str(session), *args, "--json", str(out)])
        _, err = capsys.readouterr()
        assert code == 2 and want in _one_line(err), (args, err)
        assert "Traceback" not in err and not out.exists(), args


def test_errmodel_thermal_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from aacmm.cli import main
    from aacmm.core import EncoderConfig
    from aacmm.errmodel import ErrorModel
    from aacmm.protocol import ParamSet
    from aacmm.records.paramfile import (
        ParamFileError,
        dump_param_set,
        load_param_file,
        load_param_file_errmodel,
    )

    ps = ParamSet.from_core(Params(), EncoderConfig())
    em = ErrorModel(
        ((),) * 6,
        cte_per_k=(23e-6, 23e-6, 0.5e-6, 23e-6, 0.5e-6, 11.5e-6),
        tref_c=(20.0, 20.0, 20.0, 20.0, 20.0, 21.5),
    )
    f = tmp_path / "p.toml"
    f.write_text(dump_param_set(ps, "toml", errmodel=em))
    assert load_param_file_errmodel(f)[1:] == (None, em)
    with pytest.raises(ParamFileError, match="cannot apply the error model"):
        load_param_file(f)  # every other reader refuses it, as with harmonics
    # a thermal part only, written by hand: no harmonics, tref defaults to 20 degC
    hand = tmp_path / "hand.toml"
    head = dump_param_set(ps, "toml")
    hand.write_text(head + "\n[errmodel]\ncte_per_k = [23e-6, 23e-6, 23e-6, 23e-6, 23e-6, 23e-6]\n")
    got = load_param_file_errmodel(hand)[2]
    assert got == ErrorModel(((),) * 6, cte_per_k=(23e-6,) * 6, tref_c=(20.0,) * 6)
    assert main(["params", "set", str(hand), "--check"]) == 0
    out, _ = capsys.readouterr()
    assert (
        "error model: thermal expansion CTE per link 23e-6 /K, reference 20 degC (only a "
        "device that reads its link temperatures takes it)"
    ) in out
    # harmonics only: written as before, no thermal keys
    harm = ErrorModel((((1e-5, -2e-6),),) + ((),) * 5)
    assert "cte_per_k" not in dump_param_set(ps, "toml", errmodel=harm)
    for body, needle in (
        ("cte_per_k = [23e-6, 23e-6]", "cte_per_k must be a list of 6 numbers"),
        ("cte_per_k = [23e-6, 23e-6, 23e-6, 23e-6, 23e-6, nan]", r"cte_per_k\[5\] is not finite"),
        ("cte_per_k = [0.01, 0, 0, 0, 0, 0]", "link 1: cte must be finite and within"),
        ("cte_per_k = [0, 0, 0, 0, 0, 0]\ntref_c = [20, 20, 20, 20, 20, 90]", "link 6: reference"),
        ("tref_c = [20, 20, 20, 20, 20, 20]", "tref_c goes with cte_per_k"),
        ("c_rad = [[], [], [], [], [], []]", "c_rad and s_rad go together"),
        ("", "an empty table"),
    ):
        hand.write_text(head + "\n[errmodel]\n" + body + "\n")
        with pytest.raises(ParamFileError, match=needle):
            load_param_file_errmodel(hand)


def test_cli_verify_stated_at_capture(
    warm_session: tuple[Path, Path, Params, float], capsys: pytest.CaptureFixture[str]
) -> None:
    """A session whose capture run states its temperature: verify uses it with
    --params, reports it without, and --temperature overrides it."""
    from aacmm.cli import main
    from aacmm.plans import load_plan

    session, params, _, expected = warm_session
    stated = session.with_name("s28-stated")
    assert main(["verify", str(stated), "--params", str(params), "--json", "-"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert _e_uni(json.dumps(doc)) == pytest.approx(expected, abs=1e-9)
    assert doc["session"]["temperature"].startswith("28 C on every link (stated at capture")
    assert doc["session"]["temperature_range_c"] == [28.0, 28.0] and doc["temperature_c"] == 28.0
    # no --params: the temperature is reported, nothing compensated
    assert main(["verify", str(stated)]) == 7
    out = capsys.readouterr().out
    n = len(load_plan("arm-verification").slots)
    assert f"temp.      28 C (stated at capture for {n} of {n} points; not compensated: no " in out
    assert "the session was taken at 28 C (not compensated)" in out
    # --temperature wins (and says what the session states): at the reference 20 degC
    # the compensation scales nothing, so it is the plain figure
    assert main(["verify", str(stated), "--json", "-"]) == 7
    plain = _e_uni(capsys.readouterr().out)
    args = ["verify", str(stated), "--params", str(params), "--temperature", "20"]
    assert main([*args, "--json", "-"]) == 7
    doc = json.loads(capsys.readouterr().out)
    assert _e_uni(json.dumps(doc)) == pytest.approx(plain, abs=1e-12)
    assert "the session's capture runs state 28 C" in doc["session"]["temperature"]


def test_stated_temperatures_per_run() -> None:
    """Each point takes the temperature of the last run started before it."""
    from types import SimpleNamespace

    from aacmm.records.files import utc_iso
    from aacmm.records.measured import stated_temperatures

    runs = [
        {"kind": "capture", "start": utc_iso(1000.0), "temperature_c": 21.5},
        {"kind": "resume", "start": utc_iso(2000.0)},
        {"kind": "resume", "start": utc_iso(3000.0), "temperature_c": 23.0},
    ]
    points = [SimpleNamespace(host_time=t) for t in (999.0, 1000.0, 1500.0, 2500.0, 3000.5)]
    got = stated_temperatures(SimpleNamespace(meta={"runs": runs}, points=points))
    assert got == (None, 21.5, 21.5, None, 23.0)
    assert stated_temperatures(SimpleNamespace(meta={}, points=points)) == (None,) * 5


def test_cli_capture_temperature_refusals(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from aacmm.cli import main

    log = tmp_path / "x.csv"
    log.write_text("")
    for args, want in (
        (["--temperature", "90"], "--temperature 90: the links' temperature must be a number"),
        (["--temperature", "nan"], "--temperature nan"),
        (
            ["--temperature", "28", "--from-log", str(log)],
            "with --from-log give it to aacmm verify",
        ),
    ):
        out = tmp_path / "s"
        code = main(["capture", "probe-calibration", "-o", str(out), *args, "--port", "tcp://x:9"])
        _, err = capsys.readouterr()
        assert code == 2 and want in _one_line(err), (args, err)
        assert not out.exists()


def test_capture_temperature_on_the_simulator(tmp_path: Path) -> None:
    """aacmm capture --temperature records it in the session's run; verify reads it."""
    from aacmm.records.measured import load_session
    from clihelp import capture_scenario

    session, _, _ = capture_scenario(
        tmp_path, "probe-calibration", "random:5", extra=("--temperature", "27.5")
    )
    runs = json.loads((session / "session.json").read_text())["runs"]
    assert [r.get("temperature_c") for r in runs] == [27.5]
    m = load_session(session)
    assert m.stated_temperature_c == (27.5,) * len(m.points)


# ------------------------------------------------------------------ the plan's stability band


def _banded_plan(folder: Path, name: str, band: float = 3.0) -> Path:
    """A shipped plan with a [verification] stability band of ``band`` degC around 20."""
    from aacmm.plans import shipped_plan_path

    text = shipped_plan_path(name).read_text(encoding="utf-8")
    if "[verification]" in text:
        text = text.replace(
            "temperature_c = 20.0", f"temperature_c = 20.0\ntemperature_band_c = {band}"
        )
    else:
        text += f"\n[verification]\ntemperature_c = 20.0\ntemperature_band_c = {band}\n"
    out = folder / f"{name}-banded.toml"
    out.write_text(text, encoding="utf-8")
    return out


def test_band_problem() -> None:
    """The band is the span of the stated temperatures and their distance from the plan's."""
    from aacmm.plans.model import Verification

    v = Verification(temperature_c=20.0, temperature_band_c=3.0)
    assert v.band_problem([]) is None and v.band_problem([20.0, 22.9]) is None
    span = v.band_problem([21.0, 24.5])
    assert span is not None and "spans 21 .. 24.5 C, more than the plan's 3 C" in span
    far = v.band_problem([23.5])
    assert far is not None and "23.5 C is 3.5 C from the plan's 20 C" in far
    assert Verification(temperature_band_c=3.0).band_problem([30.0]) is None  # no reference
    assert Verification().band_problem([20.0, 40.0]) is None  # no band


def test_capture_warns_outside_the_band(tmp_path: Path) -> None:
    """A plan with a 3 degC band around 20: a run stated at 24.5 degC gets one warning on
    stderr (the capture goes on and completes); a run that states nothing on a device
    without sensors gets a note; a device reading 24.5 degC one warning, and one reading
    20 degC (the simulator's default) neither."""
    from clihelp import capture_scenario

    plan = _banded_plan(tmp_path, "probe-calibration")
    warm, _, _ = capture_scenario(
        tmp_path / "warm", plan, "random:5", extra=("--temperature", "24.5")
    )
    err = (tmp_path / "warm" / "capture.stderr").read_text(encoding="utf-8")
    assert (
        "warning: the links' temperature 24.5 C is 4.5 C from the plan's 20 C, outside its 3 C"
        in err
    )
    assert json.loads((warm / "session.json").read_text())["status"] == "complete"
    no_sensors = ("--no-temperature-sensors",)
    capture_scenario(tmp_path / "unstated", plan, "random:5", sim_extra=no_sensors)
    err = (tmp_path / "unstated" / "capture.stderr").read_text(encoding="utf-8")
    assert "note: the plan asks for the links' temperature within a 3 C band" in err
    assert "warning" not in err
    read = ("--temperature", "24.5")
    capture_scenario(tmp_path / "read-warm", plan, "random:5", sim_extra=read)
    err = (tmp_path / "read-warm" / "capture.stderr").read_text(encoding="utf-8")
    (line,) = [x for x in err.splitlines() if "warning" in x]
    assert line == (
        "aacmm capture: warning: the device's link temperatures: the links' temperature 24.5 C "
        "is 4.5 C from the plan's 20 C, outside its 3 C stability band: let the arm settle "
        "before measuring"
    )
    capture_scenario(tmp_path / "read-20", plan, "random:5")
    err = (tmp_path / "read-20" / "capture.stderr").read_text(encoding="utf-8")
    assert "warning" not in err and "note" not in err


def test_verify_notes_a_session_outside_the_band(
    warm_session: tuple[Path, Path, Params, float],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """verify of a session stated at 28 degC on a plan with a 3 degC band says it was not
    taken in stable conditions (and still compensates); at 21 degC it says nothing."""
    from aacmm.cli import main
    from aacmm.plans import load_plan
    from aacmm.records import read_session
    from gate_study import Sampled, record, write_session

    session, params, cal, _ = warm_session
    plan = load_plan(_banded_plan(tmp_path, "arm-verification"))
    counts = np.asarray(read_session(session).counts, dtype=np.int64)
    in_force = record(cal)
    for temp, noted in ((28.0, True), (21.0, False)):
        s = write_session(
            tmp_path / f"s{temp:g}", Sampled(plan, counts, in_force), serial=7, temperature_c=temp
        )
        main(["verify", str(s), "--params", str(params)])
        out = capsys.readouterr().out
        said = "outside its 3 C stability band: the session was not taken in stable conditions"
        assert (said in out) == noted, out
