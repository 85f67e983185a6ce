"""A recalibration starts from the set in force, its error model included (issue 27).

A one-head arm (``random_truth(27, grade="one-head")``: encoder harmonics of
10-30 arcsec) probes the kinematic-calibration plan twice with the same
counts, as ``aacmm capture`` writes sessions, under two sets in force: the
truth's geometry with the harmonics' correction (``true_correction``,
computed here from the truth's reading errors: a set as good as a
calibration gets) and the same geometry without it (the arm alone).
``aacmm calibrate`` reports "before" figures of the set in force: with the
correction in force they are the noise floor, a few micrometres, and at
least 5x below the arm alone's (before, the fit started from the arm alone
either way and reported the second figure for both); the quality gate then
refuses the recalibration of the near-perfect set (nothing is shown better).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from aacmm.core import EncoderConfig
from aacmm.errmodel import ErrorModel
from aacmm.plans import load_plan
from aacmm.records import ParamSetRecord
from aacmm.simulation.truth import random_truth
from gate_study import Sampled, sample, write_session
from harmonics_study import true_correction


def _before_length_rms_um(text: str) -> float:
    m = re.search(r"length_rms\s+([0-9.]+) um", text)
    assert m, text
    return float(m.group(1))


def test_recalibration_starts_from_the_set_in_force(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from aacmm.cli import main

    truth = random_truth(27, grade="one-head")
    corr = true_correction(truth)
    harmonics = tuple(
        tuple((float(corr[j, k, 0]), float(corr[j, k, 1])) for k in (1, 2))
        for j in range(truth.joints)
    )
    enc = EncoderConfig()
    alone = ParamSetRecord.from_device(ParamSetRecord(0, truth.params, enc).to_device())
    fixed = ParamSetRecord.from_device(
        ParamSetRecord(0, truth.params, enc, ErrorModel(harmonics)).to_device()
    )
    assert fixed.errors is not None and alone.errors is None
    plan = load_plan("kinematic-calibration")
    s = sample(plan, truth, alone, np.random.default_rng(2027))
    figures: dict[str, float] = {}
    codes: dict[str, int] = {}
    for name, ps in (("fixed", fixed), ("alone", alone)):
        folder = write_session(tmp_path / name, Sampled(plan, s.counts, ps), serial=27)
        out = tmp_path / f"{name}.toml"
        codes[name] = main(["calibrate", str(folder), "-o", str(out), "-q"])
        text = capsys.readouterr().out
        figures[name] = _before_length_rms_um(text)
    assert figures["fixed"] < 8.0, figures
    assert figures["fixed"] * 5 < figures["alone"], figures
    assert codes["fixed"] == 9 and not (tmp_path / "fixed.toml").exists()  # the gate refuses
    assert codes["alone"] == 0 and (tmp_path / "alone.toml").exists()  # and takes this one
