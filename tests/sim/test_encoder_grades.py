"""Encoder grades of the simulated truth (issue 27 items 1, 2, 4):
``aacmm.simulation.encgrade`` and ``aacmm sim --encoder-grade``.

Independent references:

- the documented amplitude ranges (docs/simulator.md, "Encoder grades"),
  written out here, not read from :data:`aacmm.simulation.encgrade.GRADES`;
- the truth file's own coefficients, read with ``tomllib``: the test sums
  the harmonics itself and rounds to counts, and the simulator's reported
  counts at a known pose must be those;
- the C core's error model (``aacmm.errmodel.corrected_angles``) for
  :meth:`Truth.reading_error_model`;
- the truth files of the code before grades existed (``tests/vectors/truth``,
  written by commit 441286c): two-head is that truth, bit for bit.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w
from aacmm.errmodel import corrected_angles
from aacmm.models import load_model
from aacmm.simulation.encgrade import EncoderGradeError, encoder_grade
from aacmm.simulation.ik import ARM_LIMITS
from aacmm.simulation.run import STATIC_POSE_RAD
from aacmm.simulation.truth import (
    ErrorSources,
    Truth,
    TruthError,
    load_truth,
    model_truth,
    random_truth,
)

pytestmark = pytest.mark.timeout(120)
AACMM = Path(sys.executable).with_name("aacmm")
VECTORS = Path(__file__).resolve().parents[1] / "vectors" / "truth"
ARCSEC = math.pi / 648000.0
USAGE = 2

#: docs/simulator.md, "Encoder grades": amplitude range (arcsec) of each order k = 1..K
DOCUMENTED = {
    "two-head": [(0.5, 2.0)],
    "one-head": [(10.0, 30.0)] * 2,
    "magnetic": [(72.0, 360.0)] * 4,  # 0.02-0.1 deg
}


def file_harmonics(data: dict[str, Any]) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """{k: (amplitudes arcsec, phases rad)} of a truth file's content, as written."""
    out = {
        1: (
            np.array(data["eccentricity"]["amplitude_arcsec"], dtype=float),
            np.array(data["eccentricity"]["phase_rad"], dtype=float),
        )
    }
    h = data.get("harmonics")
    if h:
        for j, k in enumerate(h["order"]):
            out[k] = (np.array(h["amplitude_arcsec"][j]), np.array(h["phase_rad"][j]))
    return out


def file_reading_rad(data: dict[str, Any], theta: np.ndarray) -> np.ndarray:
    """What the true encoders read at ``theta`` (no noise): theta plus every harmonic."""
    e = np.zeros_like(theta)
    for k, (amp, phase) in file_harmonics(data).items():
        e += amp * ARCSEC * np.sin(k * theta + phase)
    out: np.ndarray = theta + e
    return out


# ---------------------------------------------------------------- two-head: today


def test_two_head_is_the_random_truth_of_before_bit_for_bit() -> None:
    for text, truth in (
        ((VECTORS / "random-7.toml").read_text(), random_truth(7)),
        ((VECTORS / "random-7.toml").read_text(), random_truth(7, grade="two-head")),
        (
            (VECTORS / "commercial7-random-3.toml").read_text(),
            model_truth(3, load_model("commercial7"), grade="two-head"),
        ),
    ):
        assert truth.dumps() == text  # the same file, so the same arm and the same serial
        assert truth.device_serial == tomllib.loads(text)["arm"]["serial_number"]
        assert "harmonics" not in tomllib.loads(text) and "encoder_grade" not in text


def test_grades_share_the_geometry_and_differ_in_the_encoders() -> None:
    base = random_truth(11)
    serials = {base.device_serial}
    for name in ("one-head", "magnetic"):
        t = random_truth(11, grade=name)
        assert t.params == base.params and t.encoders == base.encoders
        # order 1 draws what two-head draws: the same phases
        assert t.errors.eccentricity_phase_rad == base.errors.eccentricity_phase_rad
        assert t.errors != base.errors and t.origin["encoder_grade"] == name
        serials.add(t.device_serial)
    assert len(serials) == 3  # three grades, three devices


# ---------------------------------------------------------------- the documented ranges


@pytest.mark.parametrize("name", list(DOCUMENTED))
def test_random_amplitudes_within_the_documented_ranges(name: str) -> None:
    ranges = DOCUMENTED[name]
    seen: dict[int, list[float]] = {k: [] for k in range(1, len(ranges) + 1)}
    for seed in range(150):
        data = tomllib.loads(random_truth(seed, grade=name).dumps())
        h = file_harmonics(data)
        assert sorted(h) == list(seen)  # exactly the orders 1..K of the grade
        for k, (amp, phase) in h.items():
            lo, hi = ranges[k - 1]
            assert np.all((amp >= lo) & (amp <= hi)), (seed, k, amp)
            assert np.all((phase >= 0) & (phase < 2 * math.pi))
            seen[k] += amp.tolist()
    for k, amps in seen.items():  # uniform over the range: both ends reached
        lo, hi = ranges[k - 1]
        assert min(amps) < lo + 0.02 * (hi - lo) and max(amps) > hi - 0.02 * (hi - lo)
    # a model's truth of the grade: its own joint count, the same ranges
    t = model_truth(4, load_model("commercial7"), grade=name)
    for k, (amps7, _) in t.errors.harmonics_arcsec().items():
        assert len(amps7) == 7 and all(ranges[k - 1][0] <= a <= ranges[k - 1][1] for a in amps7)


def test_unknown_grade_is_one_error() -> None:
    with pytest.raises(EncoderGradeError, match=r"unknown encoder grade 'optical' \(known: "):
        random_truth(1, grade="optical")
    assert encoder_grade("magnetic").orders == 4


# ---------------------------------------------------------------- the reading error


@pytest.mark.parametrize("name", list(DOCUMENTED))
def test_counts_are_the_file_coefficients_reading(name: str) -> None:
    truth = random_truth(21, grade=name)
    data = tomllib.loads(truth.dumps())
    rng = np.random.default_rng(3)
    theta = rng.uniform(-3.1, 3.1, (400, 6))
    want = np.rint(file_reading_rad(data, theta) * 2**32 / (2 * math.pi)).astype(np.int64) % 2**32
    got = truth.counts(theta)
    assert np.max(np.abs(got - want)) <= 1  # the same sum to the last bit but one
    assert np.mean(got == want) > 0.99
    ideal = np.rint(theta * 2**32 / (2 * math.pi)).astype(np.int64) % 2**32
    err_arcsec = np.abs((got - ideal + 2**31) % 2**32 - 2**31).max() * 1296000 / 2**32
    assert 0.5 * DOCUMENTED[name][0][0] < err_arcsec <= sum(hi for _, hi in DOCUMENTED[name])
    # the core's error model with the truth's coefficients reads the same
    core = corrected_angles(truth.reading_error_model(), theta)
    assert np.max(np.abs(core - (theta + truth.reading_error_rad(theta)))) < 1e-14
    assert len(truth.reading_error_model().harmonics[0]) == len(DOCUMENTED[name])


def test_truth_file_round_trip_of_every_grade(tmp_path: Path) -> None:
    for name in DOCUMENTED:
        t = random_truth(5, grade=name)
        path = tmp_path / f"{name}.toml"
        path.write_text(t.dumps())
        back = load_truth(path)
        assert back == t and back.device_serial == t.device_serial
        assert back.origin.get("encoder_grade", "two-head") == name


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda h: h.update(order=[1]), "harmonics.order"),
        (lambda h: h.update(order=[3, 2]), "harmonics.order"),
        (lambda h: h.update(order=[2, 2]), "harmonics.order"),
        (lambda h: h.update(order=[5]), "harmonics.order"),
        (lambda h: h.update(order=[True]), "harmonics.order"),
        (lambda h: h.update(amplitude_arcsec=[[1.0] * 6]), "harmonics.amplitude_arcsec"),
        (lambda h: h["amplitude_arcsec"][0].pop(), r"harmonics.amplitude_arcsec\[0\]"),
        (lambda h: h["amplitude_arcsec"][1].__setitem__(2, -1.0), r"amplitude_arcsec\[1\]\[2\]"),
        (lambda h: h["phase_rad"][2].__setitem__(0, "x"), r"phase_rad\[2\]\[0\]"),
        (lambda h: h.update(bogus=1), "unknown key harmonics.bogus"),
    ],
)
def test_bad_harmonics_tables_name_the_key(tmp_path: Path, edit: Any, needle: str) -> None:
    data = random_truth(2, grade="magnetic").to_mapping()
    edit(data["harmonics"])
    path = tmp_path / "bad.toml"
    path.write_text(tomli_w.dumps(data))
    with pytest.raises(TruthError, match=needle) as info:
        load_truth(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_harmonics_change_the_serial_of_any_arm() -> None:
    t = model_truth(1, load_model("commercial7"))
    e = t.errors
    more = replace(
        e, harmonic_orders=(3,), harmonic_arcsec=((1.0,) * 7,), harmonic_phase_rad=((0.0,) * 7,)
    )
    assert replace(t, errors=more).device_serial != t.device_serial
    bare = ErrorSources.none(6)
    with_h = replace(
        bare, harmonic_orders=(2,), harmonic_arcsec=((0.5,) * 6,), harmonic_phase_rad=((0.0,) * 6,)
    )
    assert bare.perfect and not with_h.perfect
    with pytest.raises(ValueError, match="harmonic_arcsec"):
        replace(bare, harmonic_orders=(2,), harmonic_arcsec=(), harmonic_phase_rad=())
    assert Truth(errors=with_h).device_serial != Truth().device_serial


# ---------------------------------------------------------------- on the simulator


def _env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k != "AACMM_PORT"}


def aacmm(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(AACMM), *args], capture_output=True, text=True, timeout=60, env=_env(), check=False
    )


def _start_sim(*args: str) -> tuple[subprocess.Popen[str], str]:
    proc = subprocess.Popen(
        [str(AACMM), "sim", "--quiet", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
    )
    assert proc.stdout is not None and proc.stderr is not None
    url = proc.stdout.readline().strip()
    if not url.startswith("serial://"):
        proc.kill()
        pytest.fail(f"aacmm sim did not start: {proc.stderr.read()}")
    return proc, url


def _stop(proc: subprocess.Popen[str]) -> str:
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    return err


@pytest.mark.parametrize("name", list(DOCUMENTED))
def test_simulator_counts_differ_from_the_ideal_by_the_truth_harmonics(
    name: str, tmp_path: Path
) -> None:
    """The device reports, at the static pose, the counts of the truth file's
    harmonics (noise-free truth): the ideal counts plus the harmonic error."""
    truth = random_truth(31, grade=name)
    quiet = replace(truth, errors=replace(truth.errors, encoder_noise_counts=(0.0,) * 6))
    path = tmp_path / "truth.toml"
    path.write_text(quiet.dumps())
    data = tomllib.loads(path.read_text())
    theta = ARM_LIMITS.canonical(STATIC_POSE_RAD)[None, :]
    want = np.rint(file_reading_rad(data, theta) * 2**32 / (2 * math.pi)).astype(np.int64)[0]
    want %= 2**32
    ideal = np.rint(theta * 2**32 / (2 * math.pi)).astype(np.int64)[0] % 2**32
    proc, url = _start_sim("--truth", str(path), "--motion", "static")
    try:
        deadline = time.monotonic() + 20
        while True:
            r = aacmm("measure", "--port", url, "--json")
            assert r.returncode == 0, r.stderr
            counts = np.array(json.loads(r.stdout)["counts"], dtype=np.int64)
            if np.any(counts != 0) or time.monotonic() > deadline:
                break
            time.sleep(0.1)
    finally:
        _stop(proc)
    assert np.max(np.abs(counts - want)) <= 1, (counts, want)
    diff = (counts - ideal + 2**31) % 2**32 - 2**31  # signed, in counts
    harmonic = (file_reading_rad(data, theta) - theta)[0] * 2**32 / (2 * math.pi)
    assert np.max(np.abs(diff - harmonic)) <= 1.0
    # the error is really there, and the grade's size: a count is 0.0003 arcsec
    lo = DOCUMENTED[name][0][0]
    assert np.abs(diff).max() * 1296000 / 2**32 > 0.3 * lo


def test_sim_encoder_grade_option(tmp_path: Path) -> None:
    out = tmp_path / "truth.toml"
    proc, _url = _start_sim(
        "--model", "commercial7", "--truth", "random:9", "--encoder-grade", "magnetic",
        "--truth-out", str(out),
    )  # fmt: skip
    _stop(proc)
    back = load_truth(out)
    want = model_truth(9, load_model("commercial7"), grade="magnetic")
    assert back == want and back.origin["encoder_grade"] == "magnetic"
    # the summary line says the grade (not --quiet)
    p = subprocess.Popen(
        [str(AACMM), "sim", "--truth", "random:9", "--encoder-grade", "one-head"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
    )
    assert p.stdout is not None and p.stderr is not None
    assert p.stdout.readline().startswith("serial://")
    line = ""
    while "running" not in line:  # after the simulator's own start-up line
        line = p.stderr.readline()
        assert line, "aacmm sim said nothing"
    _stop(p)
    assert "with a random truth, encoder grade one-head;" in line, line


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--truth", "random:1", "--encoder-grade", "optical"], "unknown encoder grade 'optical'"),
        (["--encoder-grade", "magnetic"], "--encoder-grade needs --truth random:SEED"),
        (["--truth", "nominal", "--encoder-grade", "one-head"], "needs --truth random:SEED"),
        (["--scenario", "iso10360-12", "--encoder-grade", "one-head"], "needs --truth random"),
    ],
)
def test_bad_encoder_grade_is_one_line(args: list[str], needle: str) -> None:
    r = aacmm("sim", *args)
    assert r.returncode == USAGE and r.stderr.count("\n") == 1, r.stderr
    assert needle in r.stderr and r.stdout == ""
