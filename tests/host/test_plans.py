"""Plans (aacmm.plans): schema, errors naming file/line/field, presets, slots, shipped plans."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from aacmm.plans import (
    PlanError,
    Slot,
    Sphere,
    Target,
    load_plan,
    loads_plan,
    presets,
    shipped_plan_path,
    shipped_plans,
)
from aacmm.tomlsource import format_path, key_lines
from hypothesis import given, settings
from hypothesis import strategies as st

pytestmark = pytest.mark.timeout(60)

GOOD = """\
format = "aacmm-plan-1"
title = "t"

[probe]
ball_diameter_mm = 6.0

[artefacts.seat1]
type = "cone"
location_mm = [700.0, 0.0, -200.0]

[artefacts.s1]
type = "sphere"
diameter_mm = 25.4
diameter_uncertainty_mm = 0.0005
location_mm = [600.0, 100.0, -100.0]

[artefacts.bar]
type = "ballbar"
length_mm = 500.0
ends = "cone"

[[steps]]
procedure = "cone"
artefact = "seat1"
articulations = 3

[[steps]]
id = "bar"
procedure = "length"
artefact = "bar"
positions = [
  { centre_mm = [800, 0, -100], direction = [1, 0, 0] },
  { centre_mm = [700, 100, -100], direction = [0, 0, 2] },
]

[[steps]]
id = "probing"
procedure = "sphere"
artefact = "s1"
preset = "iso10360-12"
"""


def write(tmp_path: Path, text: str, name: str = "plan.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def tgt(slot: Slot) -> Target:
    assert slot.target is not None
    return slot.target


def error_of(tmp_path: Path, text: str) -> PlanError:
    p = write(tmp_path, text)
    with pytest.raises(PlanError) as ei:
        load_plan(p)
    return ei.value


def line_no(text: str, needle: str) -> int:
    """1-based line of the first line containing ``needle``."""
    for i, line in enumerate(text.splitlines(), start=1):
        if needle in line:
            return i
    raise AssertionError(needle)


# ------------------------------------------------------------------ good plans


def test_good_plan_slots_and_labels(tmp_path: Path) -> None:
    plan = load_plan(write(tmp_path, GOOD))
    assert [s.id for s in plan.steps] == ["cone1", "bar", "probing"]
    assert len(plan.slots) == 3 + 2 * 2 + 25
    assert [s.index for s in plan.slots] == list(range(len(plan.slots)))
    bar = plan.step_slots("bar")
    assert [(s.position_index, s.end, s.point_index) for s in bar] == [
        (0, "A", 0),
        (0, "B", 1),
        (1, "A", 2),
        (1, "B", 3),
    ]
    assert bar[3].text == "step 2/3, ball bar bar, position 2 of 2: probe end B"
    # ends are length apart along the normalised direction
    a, b = np.array(tgt(bar[2]).tip_mm), np.array(tgt(bar[3]).tip_mm)
    assert np.allclose(b - a, [0, 0, 500.0])
    cone = plan.step_slots(0)
    assert [s.articulation_index for s in cone] == [0, 1, 2]
    assert tgt(cone[0]).tip_mm == (700.0, 0.0, -200.0)


def test_sphere_targets_sit_at_radius_plus_ball(tmp_path: Path) -> None:
    plan = load_plan(write(tmp_path, GOOD))
    s1 = plan.artefacts["s1"]
    assert isinstance(s1, Sphere)
    centre = np.array(s1.location_mm)
    for slot in plan.step_slots("probing"):
        tip = np.array(tgt(slot).tip_mm)
        assert np.linalg.norm(tip - centre) == pytest.approx(25.4 / 2 + 3.0, abs=1e-12)
        assert np.allclose(
            (tip - centre) / np.linalg.norm(tip - centre), np.array(tgt(slot).normal, dtype=float)
        )
    assert s1.standard_uncertainty(s1.diameter_uncertainty_mm) == pytest.approx(0.00025)


def test_iso_25_point_arrangement() -> None:
    d = presets.iso10360_sphere_25()
    assert d.shape == (25, 3)
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    polar = np.degrees(np.arccos(np.clip(d[:, 2], -1, 1)))
    counts = {p: int(np.sum(np.isclose(polar, p))) for p in (0, 22.5, 45, 67.5, 90)}
    assert counts == {0: 1, 22.5: 4, 45: 8, 67.5: 4, 90: 8}
    # no two points coincide; every ring is turned against the one before
    dist = np.linalg.norm(d[:, None] - d[None], axis=2) + np.eye(25) * 9
    assert dist.min() > 0.3
    az = np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 360
    assert az[1] == pytest.approx(0) and az[5] == pytest.approx(22.5)
    # another pole: the same pattern rotated
    tilted = presets.iso10360_sphere_25((1.0, 0.0, 0.0))
    assert np.allclose(tilted @ [1.0, 0.0, 0.0], d[:, 2])


def test_articulation_preset_is_5x5_on_a_sphere(tmp_path: Path) -> None:
    text = GOOD + '\n[[steps]]\nid = "loc"\nprocedure = "articulation"\nartefact = "s1"\n'
    text += 'preset = "iso10360-12"\n'
    plan = load_plan(write(tmp_path, text))
    loc = plan.step_slots("loc")
    assert len(loc) == 25
    assert [s.articulation_index for s in loc] == [a for a in range(5) for _ in range(5)]
    assert [s.point_index for s in loc] == list(range(25))
    assert loc[6].text.endswith("articulation 2 of 5, point 2 of 5")


@pytest.mark.parametrize(
    "name", ["arm-verification", "iso10360-12", "kinematic-calibration", "probe-calibration"]
)
def test_shipped_plans_load(name: str) -> None:
    assert name in shipped_plans()
    plan = load_plan(name)
    assert load_plan(f"{name}.toml").sha256 == plan.sha256
    assert plan.path == shipped_plan_path(name)
    assert all(s.target is not None for s in plan.slots)  # the simulator can perform them
    tomllib.loads(plan.source)


def test_kinematic_calibration_plan_contents() -> None:
    plan = load_plan("kinematic-calibration")
    cones = [s for s in plan.steps if s.procedure == "cone"]
    lengths = [s for s in plan.steps if s.procedure == "length"]
    assert len(cones) == 3 and all(s.points == 25 for s in cones)
    assert sum(s.position_count or 0 for s in lengths) == 30
    bar_lengths = {plan.artefacts[s.artefact or ""].length_mm for s in lengths}  # type: ignore[attr-defined]
    assert min(bar_lengths) >= 500 - 1 and max(bar_lengths) <= 1000 + 1


def test_arm_verification_is_the_iso_plan_plus_spat() -> None:
    """The demo's verification plan: the ISO 10360-12 plan point for point, then the
    B89.4.22 single-point articulation test on three seats the calibration plan has not."""
    iso, arm = load_plan("iso10360-12"), load_plan("arm-verification")
    n = len(iso.slots)
    assert [(s.step_id, s.text.split(",", 1)[1], s.target) for s in arm.slots[:n]] == [
        (s.step_id, s.text.split(",", 1)[1], s.target) for s in iso.slots
    ]
    seats = arm.steps[len(iso.steps) :]
    assert [(s.procedure, s.points) for s in seats] == [("cone", 10)] * 3
    kin = load_plan("kinematic-calibration")
    used = {tuple(a.location_mm or ()) for a in kin.artefacts.values()}
    assert not used & {tuple(arm.artefacts[s.artefact or ""].location_mm or ()) for s in seats}
    for key in ("p_size_mm", "p_form_mm", "l_dia_mm", "e_uni"):
        assert getattr(arm.mpe, key) == getattr(iso.mpe, key)
    assert arm.mpe.spat_2sigma_mm and arm.mpe.spat_range_mm and arm.mpe.volumetric_mm


def test_iso_plan_mpe() -> None:
    plan = load_plan("iso10360-12")
    assert plan.mpe.p_size_mm == 0.020
    assert plan.mpe.e_uni is not None
    assert plan.mpe.e_uni.at(1000.0) == pytest.approx(0.030 + 0.020)
    assert plan.mpe.e_uni.at(5000.0) == pytest.approx(0.080)
    assert plan.verification.decision_rule == "simple"


# ------------------------------------------------------------------ bad plans


def test_unknown_artefact_names_file_line_field(tmp_path: Path) -> None:
    text = GOOD.replace('artefact = "seat1"', 'artefact = "seat9"')
    err = error_of(tmp_path, text)
    line = line_no(text, 'artefact = "seat9"')
    assert str(err).startswith(f"{tmp_path / 'plan.toml'}:{line}: steps[0].artefact: ")
    assert "unknown artefact 'seat9'" in str(err) and "seat1" in str(err)
    assert (err.line, err.field) == (line, "steps[0].artefact")


def test_negative_length_names_file_line_field(tmp_path: Path) -> None:
    text = GOOD.replace("length_mm = 500.0", "length_mm = -500.0")
    err = error_of(tmp_path, text)
    line = line_no(text, "length_mm = -500.0")
    assert f"plan.toml:{line}: artefacts.bar.length_mm: must be positive, got -500" in str(err)


def test_missing_field_points_at_its_table(tmp_path: Path) -> None:
    text = GOOD.replace("articulations = 3\n", "")
    err = error_of(tmp_path, text)
    # reported at the [[steps]] header of the first step
    assert err.line == line_no(text, "[[steps]]")
    assert err.field == "steps[0].articulations"
    assert str(err).endswith("steps[0].articulations: missing field")
    err = error_of(tmp_path, GOOD.replace("diameter_mm = 25.4\n", ""))
    assert err.field == "artefacts.s1.diameter_mm" and err.line == line_no(GOOD, "[artefacts.s1]")


@pytest.mark.parametrize(
    ("old", "new", "field", "words"),
    [
        ('type = "cone"', 'type = "cube"', "artefacts.seat1.type", "unknown value 'cube'"),
        ("ball_diameter_mm = 6.0", "ball_diameter_mm = -1", "probe.ball_diameter_mm", "negative"),
        ('"aacmm-plan-1"', '"aacmm-plan-7"', "format", "does not know"),
        ("articulations = 3", "articulations = 0", "steps[0].articulations", "1.."),
        ("articulations = 3", 'articulations = "3"', "steps[0].articulations", "whole number"),
        (
            "direction = [0, 0, 2]",
            "direction = [0, 0, 0]",
            "steps[1].positions[1].direction",
            "zero",
        ),
        ("direction = [1, 0, 0]", "direction = [1, 0]", "steps[1].positions[0].direction", "3"),
        ('procedure = "cone"', 'procedure = "sphere"', "steps[0].artefact", "is a cone"),
        ('id = "bar"', 'id = "probing"', "steps[2].id", "already step 2"),
        ('title = "t"', 'title = "t"\ncolour = 1', "colour", "unknown field"),
        ('preset = "iso10360-12"', 'preset = "iso10360-12"\npoints = 24', "steps[2].points", "25"),
        (
            'ends = "cone"',
            'ends = "cone"\nend_diameter_mm = 3',
            "artefacts.bar.end_diameter_mm",
            "",
        ),
        ("diameter_uncertainty_mm = 0.0005", "location_uncertainty_mm = 0.1", "", "reference"),
    ],
)
def test_bad_plans(tmp_path: Path, old: str, new: str, field: str, words: str) -> None:
    assert old in GOOD
    text = GOOD.replace(old, new, 1)
    err = error_of(tmp_path, text)
    assert field in err.field and words in err.problem, str(err)
    assert err.line is not None and err.file == str(tmp_path / "plan.toml")
    # the line named holds the field (or its table)
    assert err.line >= 1
    assert "\n" not in str(err)


def test_missing_probe_for_a_sphere_step(tmp_path: Path) -> None:
    err = error_of(tmp_path, GOOD.replace("[probe]\nball_diameter_mm = 6.0\n", ""))
    assert err.field == "probe.ball_diameter_mm" and "missing field" in err.problem


def test_toml_syntax_error_has_its_line(tmp_path: Path) -> None:
    text = GOOD.replace("articulations = 3", "articulations = = 3")
    err = error_of(tmp_path, text)
    assert err.line == line_no(text, "articulations = = 3")
    assert "bad TOML" in str(err)


def test_unreadable_and_unknown_names(tmp_path: Path) -> None:
    with pytest.raises(PlanError, match="no such file, nor a shipped plan"):
        load_plan("no-such-plan")
    with pytest.raises(PlanError, match="cannot read"):
        load_plan(tmp_path / "missing.toml")
    (tmp_path / "bin.toml").write_bytes(b"\xff\xfe\x00")
    with pytest.raises(PlanError, match="not UTF-8"):
        load_plan(tmp_path / "bin.toml")
    deep = "format = " + "[" * 2000 + "]" * 2000 + "\n"
    with pytest.raises(PlanError):
        loads_plan(deep, "deep.toml")


# ------------------------------------------------------------------ the line locator


def test_key_lines_of_a_mixed_document() -> None:
    text = """\
a = 1  # comment with key = 2
"quoted key".b = 'x'
s = \"\"\"
not = a key
\"\"\"
[t]
arr = [
  1,
  { k = 2, m.n = 3 },
]
[[aot]]
x = 1
[[aot]]
y = 2
[aot.sub]
z = 3
"""
    tomllib.loads(text)
    lines = key_lines(text)
    assert lines[("a",)] == 1
    assert lines[("quoted key", "b")] == 2
    assert lines[("s",)] == 3
    assert ("not",) not in lines
    assert lines[("t", "arr", 1, "k")] == 9
    assert lines[("t", "arr", 1, "m", "n")] == 9
    assert lines[("aot", 0, "x")] == 12
    assert lines[("aot", 1)] == 13
    assert lines[("aot", 1, "sub", "z")] == 16
    assert (
        format_path(("steps", 2, "positions", 0, "centre_mm")) == "steps[2].positions[0].centre_mm"
    )


_key = st.text("abcxyz_-", min_size=1, max_size=6)
_scalar = st.one_of(
    st.integers(-1000, 1000),
    st.floats(allow_nan=False, allow_infinity=False, width=32),
    st.text("ab =#[]{}\"'\\,", max_size=8),
    st.booleans(),
)


@settings(max_examples=150, deadline=None)
@given(st.dictionaries(_key, st.one_of(_scalar, st.lists(_scalar, max_size=3)), min_size=1))
def test_key_lines_agree_with_tomllib(table: dict[str, object]) -> None:
    """Every top-level key of a generated document is found on its own line."""
    import tomli_w

    text = tomli_w.dumps({"t": table, "z": 1})
    doc = tomllib.loads(text)
    lines = key_lines(text)
    src = text.splitlines()
    for k in doc["t"]:
        line = lines[("t", k)]
        assert "=" in src[line - 1]
    assert ("z",) in lines


def test_spiral_and_ring_patterns() -> None:
    d = presets.spiral_cap(40, (0, 0, 1), 90.0)
    assert np.allclose(np.linalg.norm(d, axis=1), 1)
    assert d[:, 2].min() >= -1e-12
    r = presets.ring_pattern(5, (0, 1, 0))
    assert np.allclose(r[0], [0, 1, 0])
    assert np.allclose(r[1:] @ [0, 1, 0], math.cos(math.radians(60)))
    offs, n = presets.plane_grid(9, (0, 0, 1), (90.0, 60.0))
    assert np.allclose(offs @ n, 0) and np.allclose(offs.mean(axis=0), 0)


def test_plan_cli(tmp_path: Path) -> None:
    import subprocess
    import sys

    aacmm = str(Path(sys.executable).with_name("aacmm"))
    bad = write(tmp_path, GOOD.replace("length_mm = 500.0", "length_mm = -5"))
    r = subprocess.run([aacmm, "plan", "check", str(bad)], capture_output=True, text=True)
    assert r.returncode == 2 and r.stdout == ""
    line = line_no(GOOD, "length_mm = 500.0")
    assert r.stderr == (
        f"aacmm plan: error: {bad}:{line}: artefacts.bar.length_mm: must be positive, got -5\n"
    )
    r = subprocess.run([aacmm, "plan", "list"], capture_output=True, text=True)
    assert r.returncode == 0 and "iso10360-12" in r.stdout
    out = tmp_path / "mine.toml"
    r = subprocess.run([aacmm, "plan", "example", "iso10360-12", "-o", str(out)], text=True)
    assert r.returncode == 0 and load_plan(out).sha256 == load_plan("iso10360-12").sha256
    r = subprocess.run(
        [aacmm, "plan", "example", "iso10360-12", "-o", str(out)], capture_output=True, text=True
    )
    assert r.returncode == 2 and "exists" in r.stderr


@pytest.mark.parametrize(
    ("old", "new", "field", "words"),
    [
        ("diameter_mm = 25.4", "diameter_mm = 1e308", "artefacts.s1.diameter_mm", "beyond any arm"),
        ("length_mm = 500.0", "length_mm = 20000.0", "artefacts.bar.length_mm", "at most 10000"),
        (
            "location_mm = [700.0, 0.0, -200.0]",
            "location_mm = [7e5, 0.0, -200.0]",
            "artefacts.seat1.location_mm[0]",
            "beyond any arm",
        ),
        (
            "ball_diameter_mm = 6.0",
            "ball_diameter_mm = 30.0",
            "probe.ball_diameter_mm",
            "cannot probe the 25.4 mm s1 (artefacts.s1.diameter_mm) of step 'probing'",
        ),
        ("ball_diameter_mm = 6.0", "ball_diameter_mm = 500", "probe.ball_diameter_mm", "plausible"),
        (
            'preset = "iso10360-12"\n',
            'preset = "iso10360-12"\n[verification]\ntemperature_c = 1e6\n',
            "verification.temperature_c",
            "outside -20..60 deg C",
        ),
        (
            'preset = "iso10360-12"\n',
            'preset = "iso10360-12"\n[verification]\ntemperature_band_c = 0\n',
            "verification.temperature_band_c",
            "a stability band of 0 deg C: it must be above 0 and at most 20 deg C",
        ),
        (
            'preset = "iso10360-12"\n',
            'preset = "iso10360-12"\n[verification]\ntemperature_band_c = 25\n',
            "verification.temperature_band_c",
            "at most 20 deg C",
        ),
    ],
)
def test_implausible_plans(tmp_path: Path, old: str, new: str, field: str, words: str) -> None:
    """Issue 29.7: `plan check` accepted a 1e308 mm sphere, a 30 mm probe ball on a
    25 mm sphere and 10^6 deg C. Each is one line: FILE:LINE: FIELD: problem."""
    assert old in GOOD
    text = GOOD.replace(old, new, 1)
    err = error_of(tmp_path, text)
    assert err.field == field and words in err.problem, str(err)
    assert err.line is not None and "\n" not in str(err)
    load_plan(write(tmp_path, GOOD.replace(old, old, 1), "ok.toml"))  # the original is fine
