"""``aacmm model list|show|check`` end to end (issue 26 items 1-2): the real
command in a subprocess, its output against the model files read here with
tomllib, and its exit statuses (docs/cli.md)."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import pytest
from aacmm.commands import exitcodes
from aacmm.models import shipped_model_path, shipped_models
from clihelp import one_error_line, run

pytestmark = pytest.mark.timeout(120)
MODELS = shipped_models()


def test_list_one_model_a_line_name_first() -> None:
    p = run("model", "list")
    assert p.returncode == exitcodes.OK, p.stderr
    lines = p.stdout.strip().splitlines()
    assert [ln.split()[0] for ln in lines] == list(MODELS)
    for ln in lines:
        data = tomllib.loads(shipped_model_path(ln.split()[0]).read_text(encoding="utf-8"))
        assert f"{len(data['joints'])} joints" in ln
        assert data["description"] in ln
    assert "(default)" in next(ln for ln in lines if ln.startswith("gao2013 "))
    assert sum("(default)" in ln for ln in lines) == 1


@pytest.mark.parametrize("name", MODELS)
def test_show_json_has_joints_and_every_parameter(name: str) -> None:
    p = run("model", "show", name, "--json")
    assert p.returncode == exitcodes.OK, p.stderr
    d = json.loads(p.stdout)
    data = tomllib.loads(shipped_model_path(name).read_text(encoding="utf-8"))
    js = data["joints"]
    n = len(js)
    assert d["name"] == name and d["joints"] == n and len(d["joint"]) == n
    betas = [i + 1 for i, j in enumerate(js) if "beta_deg" in j or "beta_rad" in j]
    tip = ["tx", "ty", "tz"] if data["tip"]["kind"] == "xyz" else ["l"]
    names = [
        *(f"{k}{i}" for k in ("theta", "alpha", "d", "a") for i in range(1, n + 1)),
        *(f"beta{i}" for i in betas),
        *tip,
    ]
    params = d["parameters"]
    assert [q["name"] for q in params] == names and d["n_params"] == len(names)
    by = {q["name"]: q for q in params}
    for i, j in enumerate(js, start=1):
        assert by[f"d{i}"] == {**by[f"d{i}"], "value": j["d_mm"], "unit": "mm"}
        assert by[f"a{i}"]["value"] == j["a_mm"] and by[f"a{i}"]["unit"] == "mm"
        assert by[f"alpha{i}"]["unit"] == "rad"
        assert by[f"alpha{i}"]["value"] == pytest.approx(math.radians(j["alpha_deg"]), abs=1e-15)
        assert d["joint"][i - 1]["convention"] == j["convention"]
        lim = j["limits_deg"]
        if math.isinf(lim[0]):
            assert d["joint"][i - 1]["limits_deg"] is None
        else:
            assert d["joint"][i - 1]["limits_deg"] == pytest.approx(lim, abs=1e-9)
            assert d["joint"][i - 1]["limits_rad"] == [math.radians(x) for x in lim]
    vec = data["tip"]["vector_mm"]
    assert [by[t]["value"] for t in tip] == (vec if len(tip) == 3 else vec[2:])
    assert all(by[t]["unit"] == "mm" for t in tip)
    assert d["source"] == data["source"]


def test_show_text_marks_assumed_figures() -> None:
    p = run("model", "show", "mpe2018")
    assert p.returncode == exitcodes.OK, p.stderr
    out = p.stdout
    assert "6 joints, 25 parameters" in out
    d2 = next(ln for ln in out.splitlines() if ln.strip().startswith("d3 "))
    assert "750.7422 mm" in d2 and "(assumed)" not in d2  # a published figure
    j2 = next(ln for ln in out.splitlines() if ln.strip().startswith("joint 2:"))
    assert "standard (assumed)" in j2 and "60 .. 300 deg (assumed)" in j2
    p = run("model", "show", "commercial7")
    d1 = next(ln for ln in p.stdout.splitlines() if ln.strip().startswith("d1 "))
    assert d1.endswith("(assumed)")


def test_check_a_good_file_and_a_shipped_name(tmp_path: Path) -> None:
    f = tmp_path / "mine.toml"
    text = shipped_model_path("microscribe5").read_text(encoding="utf-8")
    f.write_text(text.replace('name = "microscribe5"', 'name = "mine"'), encoding="utf-8")
    p = run("model", "check", str(f))
    assert p.returncode == exitcodes.OK, p.stderr
    assert p.stdout.startswith(f"{f}: ok, model mine, 5 joints, 24 parameters")
    p = run("model", "check", "gao2013")
    assert p.returncode == exitcodes.OK and "6 joints, 25 parameters" in p.stdout


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (("d_mm = 300.0", "d_mm = 300.0\nbeta_deg = 0.5"), ("joint 1 beta_deg", "cannot have")),
        (("d_mm = 792.7", "d_mm = nan"), ("joint 3 d_mm", "nan")),
        (("[60.0, 300.0]", "[300.0, 60.0]"), ("joint 2 limits_deg", "inverted")),
        (("[tip]", "[tipp]"), ("tipp", "unknown field")),
        (("aacmm-model-1", "aacmm-model-9"), ("format", "unsupported")),
    ],
)
def test_check_a_bad_file_one_line_exit_2(
    tmp_path: Path, edit: tuple[str, str], words: tuple[str, ...]
) -> None:
    f = tmp_path / "bad.toml"
    text = shipped_model_path("gao2013").read_text(encoding="utf-8").replace(*edit, 1)
    f.write_text(text, encoding="utf-8")
    p = run("model", "check", str(f))
    line = one_error_line(p, exitcodes.USAGE, f"{f}:", *words)
    assert line.startswith("aacmm model: error: ") and "Traceback" not in p.stderr
    assert p.stdout == ""


def test_missing_file_unknown_name_and_usage(tmp_path: Path) -> None:
    one_error_line(
        run("model", "check", str(tmp_path / "no.toml")), exitcodes.USAGE, "no such file"
    )
    one_error_line(
        run("model", "show", "nosuchmodel"), exitcodes.USAGE, "shipped: commercial7, desk4"
    )
    p = run("model")
    assert p.returncode == exitcodes.USAGE and "ACTION" in p.stderr
    p = run("model", "show")
    assert p.returncode == exitcodes.USAGE


def test_example_copies_a_shipped_model_to_edit(tmp_path: Path) -> None:
    out = tmp_path / "mine.toml"
    p = run("model", "example", "microscribe5", "-o", str(out))
    assert p.returncode == exitcodes.OK, p.stderr
    assert out.read_bytes() == shipped_model_path("microscribe5").read_bytes()
    one_error_line(run("model", "example", "gao2013", "-o", str(out)), exitcodes.USAGE, "exists")
    assert out.read_bytes() == shipped_model_path("microscribe5").read_bytes()
    p = run("model", "example", "gao2013", "-o", str(out), "--force")
    assert (
        p.returncode == exitcodes.OK
        and out.read_bytes() == shipped_model_path("gao2013").read_bytes()
    )
    one_error_line(
        run("model", "example", "nosuch", "-o", str(tmp_path / "x.toml")),
        exitcodes.USAGE,
        "no such shipped model",
    )
    assert not (tmp_path / "x.toml").exists()
