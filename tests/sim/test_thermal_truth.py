"""The simulated truth's thermal profile (issue 27 item 3): ``aacmm.simulation.thermal``,
``random_truth(..., thermal=True)``, the ``[thermal]`` table and ``true_points``.

Independent references: the documented materials and ranges
(docs/simulator.md, "Thermal expansion"), written out here; the true point at
a temperature recomputed by the core's plain model on an arm whose lengths
the test scales itself (no error model); and, for one CTE on every link, the
point scaled about the base (every length times ``1 + cte dT``, the angles
unchanged).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w
from aacmm.arm import Arm, Joint
from aacmm.core import Model, Params
from aacmm.models import load_model
from aacmm.simulation.thermal import (
    ThermalProfile,
    default_materials,
    nominal_profile,
    true_points,
)
from aacmm.simulation.truth import TruthError, load_truth, model_truth, random_truth

#: docs/simulator.md, "Thermal expansion": material -> (nominal, random range), 1/K
DOCUMENTED = {
    "aluminium": (23e-6, (22e-6, 24e-6)),
    "carbon-fibre": (0.5e-6, (0.0, 1e-6)),
    "steel": (11.5e-6, (10.5e-6, 12.5e-6)),
}
PAPER_MATERIALS = (
    "aluminium",
    "aluminium",
    "carbon-fibre",
    "aluminium",
    "carbon-fibre",
    "aluminium",
)


def scaled_params(p: Params, s: np.ndarray) -> Params:
    """The paper's arm with link i's lengths times s[i] (the tip is link 6's)."""
    return Params(
        p.theta_offset_rad,
        p.alpha_rad,
        tuple(float(v) for v in np.asarray(p.d_mm) * s),
        tuple(float(v) for v in np.asarray(p.a_mm) * s),
        float(p.l_mm * s[-1]),
    )


def scaled_arm(a: Arm, s: np.ndarray) -> Arm:
    joints = tuple(
        Joint(j.convention, j.theta_offset_rad, j.alpha_rad, j.d_mm * f, j.a_mm * f, j.beta_rad)
        for j, f in zip(a.joints, s, strict=True)
    )
    tip = tuple(float(t * s[-1]) for t in a.tip_mm)
    return Arm(joints=joints, tip=a.tip, tip_mm=(tip[0], tip[1], tip[2]))


def test_materials_of_the_paper_arm_and_random_profiles() -> None:
    assert default_materials(Params()) == PAPER_MATERIALS  # upper arm and forearm: tubes
    assert nominal_profile(PAPER_MATERIALS).cte_per_k == tuple(
        DOCUMENTED[m][0] for m in PAPER_MATERIALS
    )
    seen: dict[str, list[float]] = {m: [] for m in DOCUMENTED}
    for seed in range(100):
        t = random_truth(seed, thermal=True)
        plain = random_truth(seed)
        # drawn last: the same arm, encoders and errors as without it
        assert (t.params, t.encoders, t.errors) == (plain.params, plain.encoders, plain.errors)
        assert t.thermal is not None and plain.thermal is None
        assert t.thermal.material == PAPER_MATERIALS and t.thermal.tref_c == (20.0,) * 6
        for m, a in zip(t.thermal.material, t.thermal.cte_per_k, strict=True):
            lo, hi = DOCUMENTED[m][1]
            assert lo <= a <= hi
            seen[m].append(a)
    for m in ("aluminium", "carbon-fibre"):
        lo, hi = DOCUMENTED[m][1]
        assert min(seen[m]) < lo + 0.05 * (hi - lo) and max(seen[m]) > hi - 0.05 * (hi - lo)
    assert "thermal" not in random_truth(3).dumps()


def test_points_at_temperatures_are_the_scaled_arm() -> None:
    t = random_truth(4, thermal=True)
    assert t.thermal is not None
    rng = np.random.default_rng(8)
    theta = rng.uniform(-3, 3, (200, 6))
    cold = t.model().points(theta)
    assert np.array_equal(true_points(t, theta), cold)
    assert np.array_equal(true_points(t, theta, [20.0] * 6), cold)  # the reference: unchanged
    temps = np.array([27.0, 31.5, 24.0, 29.0, 22.5, 35.0])
    s = 1.0 + np.asarray(t.thermal.cte_per_k) * (temps - 20.0)
    assert isinstance(t.params, Params)
    want = Model(scaled_params(t.params, s)).points(theta)
    got = true_points(t, theta, temps)
    assert np.max(np.abs(got - want)) < 1e-9
    moved = np.linalg.norm(got - cold, axis=1)
    assert moved.max() > 0.02  # mm: the aluminium links at +4..15 K move the tip tens of um
    # one temperature set per pose
    per_pose = np.tile(temps, (200, 1))
    per_pose[::2] = 20.0
    got2 = true_points(t, theta, per_pose)
    assert np.max(np.abs(got2[1::2] - want[1::2])) < 1e-9
    assert np.max(np.abs(got2[::2] - cold[::2])) < 1e-9


def test_one_cte_everywhere_scales_the_point_about_the_base() -> None:
    t = replace(
        random_truth(5),
        thermal=ThermalProfile(("aluminium",) * 6, (23e-6,) * 6, (20.0,) * 6),
    )
    theta = np.random.default_rng(1).uniform(-3, 3, (100, 6))
    got = true_points(t, theta, [30.0] * 6)
    want = (1 + 23e-6 * 10.0) * t.model().points(theta)
    assert np.max(np.abs(got - want)) < 1e-9


def test_any_arm_thermal_truth() -> None:
    model = load_model("commercial7")
    t = model_truth(2, model)
    t = replace(t, thermal=nominal_profile(default_materials(model.arm)))
    assert t.thermal is not None
    theta = np.random.default_rng(2).uniform(-2, 2, (50, 7))
    temps = np.linspace(15.0, 35.0, 7)
    s = 1.0 + np.asarray(t.thermal.cte_per_k) * (temps - 20.0)
    want = Model(scaled_arm(t.params, s)).points(theta)
    assert np.max(np.abs(true_points(t, theta, temps) - want)) < 1e-9
    with pytest.raises(ValueError, match="thermal profile"):
        replace(t, thermal=nominal_profile(PAPER_MATERIALS))  # 6 links on a 7-joint arm


def test_thermal_table_round_trip(tmp_path: Path) -> None:
    t = random_truth(6, thermal=True)
    path = tmp_path / "t.toml"
    path.write_text(t.dumps())
    back = load_truth(path)
    assert back == t and back.thermal == t.thermal
    assert back.device_serial == t.device_serial != random_truth(6).device_serial


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda th: th.update(material=["aluminium"] * 5), "thermal.material"),
        (lambda th: th.update(material=[1] * 6), "thermal.material"),
        (lambda th: th["cte_per_k"].__setitem__(0, 0.01), "cte must be finite"),
        (lambda th: th["tref_c"].__setitem__(2, 120.0), "tref must be within"),
        (lambda th: th.pop("tref_c"), "thermal.tref_c"),
        (lambda th: th.update(gradient=1), "unknown key thermal.gradient"),
    ],
)
def test_bad_thermal_tables_name_the_key(tmp_path: Path, edit: Any, needle: str) -> None:
    data = random_truth(2, thermal=True).to_mapping()
    edit(data["thermal"])
    path = tmp_path / "bad.toml"
    path.write_text(tomli_w.dumps(data))
    with pytest.raises(TruthError, match=needle) as info:
        load_truth(path)
    assert str(path) in str(info.value)


def test_unknown_material_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown link material 'wood'"):
        nominal_profile(("wood",) * 6)
    assert math.isclose(DOCUMENTED["steel"][0], nominal_profile(("steel",)).cte_per_k[0])
