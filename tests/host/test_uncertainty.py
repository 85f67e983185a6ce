"""aacmm.uncertainty and `aacmm uncertainty`: MC (JCGM 101) vs linear (GUM)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from aacmm import uncertainty as unc
from aacmm.core import PARAM_NAMES, Params, perturbed_points
from interrupt import run_then_interrupt
from test_core_oracle import numpy_point_jacobian

pytestmark = pytest.mark.timeout(120)
AACMM = [sys.executable, "-m", "aacmm.cli"]
ARCSEC = math.pi / 648000.0
POSES = unc.pose_list(
    [[0, 90, 0, 90, 0, 0], [30, 45, 20, -60, 10, 90], [-120, 120, 45, 30, -90, 0]]
)


def _spec(u: dict[str, float], distribution: str = "normal") -> unc.UncertaintySpec:
    s = unc.UncertaintySpec.from_u(u, distribution=distribution)
    return unc.UncertaintySpec(s.params, s.items, POSES)


def test_linear_propagation_matches_numpy() -> None:
    spec = _spec({"theta": 2 * ARCSEC, "alpha": 3 * ARCSEC, "d": 0.005, "a": 0.004, "l": 0.003})
    res = unc.propagate(spec, trials=2000, workspace=5, seed=1)
    _, j = numpy_point_jacobian(Params(), np.array([p.theta_rad for p in res.poses]))
    u = spec.u_vector()
    ref = np.sqrt((j**2 * u**2).sum(axis=2))
    got = np.array([p.u_lin for p in res.poses])
    assert np.allclose(got, ref, rtol=1e-9)
    for p in res.poses:
        assert np.allclose(p.ci_lin[:, 1], unc.K95 * p.u_lin)


def test_small_uncertainties_agree() -> None:
    # Small errors: the model is linear over their range, so MC and J Sigma J^T
    # must agree to MC noise. With M draws the relative standard error of a
    # standard deviation is 1/sqrt(2M) (0.22 % at M = 10^5): allow 5 of them.
    m = 100_000
    spec = _spec({"theta": 2 * ARCSEC, "alpha": 3 * ARCSEC, "d": 0.005, "a": 0.005, "l": 0.005})
    res = unc.propagate(spec, trials=m, workspace=20, seed=3)
    lo, hi = res.ratio_range()
    tol = 5.0 / math.sqrt(2 * m)
    assert 1 - tol < lo <= hi < 1 + tol, (lo, hi)
    assert res.valid_fraction() == 1.0  # JCGM 101 sec. 8 check, 1 significant digit
    for p in res.poses:
        # no bias: |mean deviation| within 5 standard errors of 0
        assert np.all(np.abs(p.bias_mc) < 5 * p.u_mc / math.sqrt(m))
        # the 95 % radius lies between the largest axis u and 3 u_3D
        assert p.u_mc.max() < p.r95_mc < 3 * p.u3_mc


def test_large_angle_errors_part_ways() -> None:
    # Large joint-angle errors (u = 0.3 rad, 17 deg): the probe moves on circles
    # about the joint axes, p(eps) = r (sin eps, cos eps - 1) in the joint's
    # plane. The linear model keeps only r eps. The neglected second-order term
    # -r eps^2 / 2 always points toward the axis, so the Monte Carlo mean is
    # biased (by ~ r u^2 / 2, hundreds of mm here) and |sin eps| < |eps| shrinks
    # the tangential spread: the MC distribution is skewed and offset, its 95 %
    # interval no longer matches +-1.96 u_lin, and the JCGM 101 sec. 8
    # validation of the linear result fails. The same file with u = 1e-5 rad
    # agrees (the control below).
    big = _spec({"theta": 0.3})
    res = unc.propagate(big, trials=20_000, workspace=0, seed=2)
    assert res.valid_fraction() == 0.0
    for p in res.poses:
        sem = p.u_mc / math.sqrt(res.trials)
        assert np.max(np.abs(p.bias_mc) / sem) > 20  # a real bias, not noise
        assert np.max(np.abs(p.bias_mc)) > 10.0  # mm
        assert np.max(np.abs(p.u_mc / p.u_lin - 1)) > 0.05
    small = unc.propagate(_spec({"theta": 1e-5}), trials=20_000, workspace=0, seed=2)
    assert small.valid_fraction() == 1.0
    lo, hi = small.ratio_range()
    assert 0.97 < lo <= hi < 1.03


@pytest.mark.parametrize("dist", unc.DISTRIBUTIONS)
def test_distributions_have_the_stated_u(dist: str) -> None:
    rng = np.random.default_rng(4)
    x = unc.ParamUncertainty("d2", 0.01, dist).sample(rng, 400_000)
    assert abs(x.mean()) < 1e-4
    assert x.std() == pytest.approx(0.01, rel=0.01)
    half = {"uniform": math.sqrt(3), "triangular": math.sqrt(6), "arcsine": math.sqrt(2)}
    if dist in half:
        assert np.max(np.abs(x)) <= 0.01 * half[dist] * (1 + 1e-12)


def test_tolerances_convert_to_standard_uncertainties() -> None:
    spec = unc.parse_spec(
        {
            "angle_unit": "arcsec",
            "length_unit": "um",
            "parameters": {
                "alpha": {"tolerance": 6.0, "distribution": "uniform"},
                "alpha3": {"tolerance": 6.0, "distribution": "triangular"},
                "d": {"tolerance": 10.0, "distribution": "normal", "k": 3.0},
                "a": {"tolerance": 10.0},  # uniform by default
                "l": {"tolerance": 4.0, "distribution": "arcsine"},
                "theta2": {"u": 1.5},
            },
        }
    )
    u = dict(zip(PARAM_NAMES, spec.u_vector(), strict=True))
    assert u["alpha1"] == pytest.approx(6 * ARCSEC / math.sqrt(3))
    assert u["alpha3"] == pytest.approx(6 * ARCSEC / math.sqrt(6))
    assert u["d4"] == pytest.approx(10e-3 / 3)
    assert u["a6"] == pytest.approx(10e-3 / math.sqrt(3))
    assert u["l"] == pytest.approx(4e-3 / math.sqrt(2))
    assert u["theta2"] == pytest.approx(1.5 * ARCSEC) and u["theta1"] == 0.0
    items = dict(zip(PARAM_NAMES, spec.items, strict=True))
    assert items["theta2"].distribution == "normal" and items["a1"].distribution == "uniform"


def test_budget_angles_dominate_as_the_paper_says() -> None:
    # The packaged example: 2-3 arcsec on the angles, 5-8 um on the lengths.
    example = Path(unc.__file__).parent.parent / "data" / "example_uncertainty.toml"
    res = unc.propagate(unc.load_spec(example), trials=20_000, workspace=100, seed=0)
    g = res.group_shares
    assert sum(g.values()) == pytest.approx(1.0)
    assert g["theta"] + g["alpha"] > 0.6
    shares = [e.share for e in res.budget]
    assert shares == sorted(shares, reverse=True)
    assert res.budget[0].name.startswith(("alpha", "theta"))
    # per unit: an angle error moves the probe hundreds of mm per rad, a length
    # error exactly 1 mm per mm (Eq. 11-13), whatever the pose
    sens = {e.name: e.sensitivity for e in res.budget}
    assert min(sens[n] for n in PARAM_NAMES[:12] if n not in ("theta6", "alpha6")) > 50
    for n in PARAM_NAMES[12:]:
        assert sens[n] == pytest.approx(1.0, abs=1e-12)
    # the paper's argument (Eq. 11-13 vs Table 2): the same error in the
    # model's units, 0.1 mm on every length and 0.1 mrad on every angle, and
    # the angles carry more than 99 % of the variance
    eq = unc.propagate(
        _spec({"theta": 1e-4, "alpha": 1e-4, "d": 1e-4, "a": 1e-4, "l": 1e-4}),
        trials=5000,
        workspace=50,
        seed=0,
    )
    assert eq.group_shares["theta"] + eq.group_shares["alpha"] > 0.99
    # break-even: angles stop dominating only once u(angle) in rad is several
    # hundred times smaller than u(length) in mm (here 10 urad vs 10 um)
    even = unc.propagate(
        _spec({"theta": 1e-5, "alpha": 1e-5, "d": 0.01, "a": 0.01, "l": 0.01}),
        trials=5000,
        workspace=50,
        seed=0,
    )
    assert even.group_shares["theta"] + even.group_shares["alpha"] < 0.5


def test_only_lengths_give_a_length_budget() -> None:
    res = unc.propagate(_spec({"d3": 0.01}), trials=5000, workspace=10, seed=1)
    assert res.budget[0].name == "d3" and res.budget[0].share == pytest.approx(1.0)
    # d3 moves the probe along z_2 by exactly its error: u_3D = u(d3) everywhere
    for p in res.poses:
        assert p.u3_lin == pytest.approx(0.01, rel=1e-12)


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ({"parameters": {"beta1": {"u": 1.0}}}, "unknown parameter name 'beta1'"),
        ({"parameters": {"theta7": {"u": 1.0}}}, "parameter 'theta7' is not one of this arm's"),
        ({"parameters": {"d": {"u": -1.0}}}, "must be finite and >= 0"),
        ({"parameters": {"d": {"tolerance": -0.1}}}, "must be finite and >= 0"),
        ({"parameters": {"d": {"u": 1.0, "tolerance": 1.0}}}, "exactly one of u"),
        ({"parameters": {"d": {}}}, "exactly one of u"),
        ({"parameters": {"d": {"u": 1.0, "distribution": "cauchy"}}}, "unknown distribution"),
        ({"parameters": {"d": {"u": 1.0, "sigma": 2}}}, "unknown key"),
        ({"parameters": {"d": 1.0}}, "expected a table"),
        ({"angle_unit": "grad", "parameters": {"d": {"u": 1.0}}}, "unknown angle_unit"),
        ({"parameters": {}}, "no [parameters]"),
        ({"paramters": {"d": {"u": 1.0}}}, "unknown key(s) paramters"),
        ({"parameters": {"d": {"u": 1.0}}, "poses": [[1, 2, 3]]}, "6"),
        ({"nominal": {"l_mm": 1e9}, "parameters": {"d": {"u": 1.0}}}, "out of range"),
    ],
)
def test_bad_specs(doc: dict[str, object], message: str) -> None:
    with pytest.raises(unc.SpecError) as ei:
        unc.parse_spec(doc)
    assert message in str(ei.value)
    assert isinstance(ei.value, ValueError)


def test_bad_files_and_arguments(tmp_path: Path) -> None:
    with pytest.raises(unc.SpecError, match="cannot read"):
        unc.load_spec(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("parameters = [unclosed\n")
    with pytest.raises(unc.SpecError, match="not valid TOML"):
        unc.load_spec(bad)
    with pytest.raises(ValueError, match="unknown parameter name"):
        unc.ParamUncertainty("x", 1.0)
    with pytest.raises(ValueError, match=">= 0"):
        unc.ParamUncertainty("d1", -1.0)
    spec = _spec({"d": 0.01})
    with pytest.raises(ValueError, match="trials"):
        unc.propagate(spec, trials=0)
    with pytest.raises(ValueError, match="workspace"):
        unc.propagate(spec, workspace=-1)
    with pytest.raises(ValueError, match="no poses"):
        unc.propagate(unc.UncertaintySpec.from_u({"d": 0.01}), workspace=0)
    with pytest.raises(ValueError, match="out of range"):  # alpha pushed beyond 2 pi
        unc.propagate(_spec({"alpha": 20.0}), trials=100, workspace=1)


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*AACMM, *args],
        capture_output=True,
        text=True,
        timeout=90,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
    )


def test_cli_example_and_json(tmp_path: Path) -> None:
    out = _cli(
        "uncertainty",
        "example",
        "--trials",
        "5000",
        "--workspace",
        "20",
        "--pose",
        "0,0,0,0,0,0",
        "--json",
        str(tmp_path / "u.json"),
    )
    assert out.returncode == 0, out.stderr
    assert "budget" in out.stdout and "alpha and theta dominate" in out.stdout
    assert "u_mc/u_lin" in out.stdout
    doc = json.loads((tmp_path / "u.json").read_text())
    assert len(doc["given_poses"]) == 4 and len(doc["workspace_poses"]) == 20
    assert doc["group_shares"]["alpha"] > doc["group_shares"]["l"]
    # issue 29.7: the sensitivities were labelled "mm/unit" while u is shown in
    # arcsec: they are mm per rad (angles) and mm per mm (lengths)
    assert "mm/unit" not in out.stdout
    rows = {ln.split()[0]: ln for ln in out.stdout.splitlines() if ln.startswith("  ")}
    budget = {e["name"]: e for e in doc["budget"]}
    for name, line in rows.items():
        if name in budget:
            e = budget[name]
            want = "mm/rad" if e["unit"] == "rad" else "mm/mm"
            assert e["sensitivity_unit"] == want
            assert f"{e['sensitivity']:.3f} {want}" in line, line
    assert {e["sensitivity_unit"] for e in doc["budget"]} == {"mm/rad", "mm/mm"}


@pytest.mark.parametrize(
    ("content", "args", "message"),
    [
        ("[parameters]\nfoo = { u = 1 }\n", [], "unknown parameter name 'foo'"),
        ("[parameters]\nd = { u = -1 }\n", [], ">= 0"),
        ("[parameters]\nd = { u = 1 }\n", ["--trials", "0"], "trials"),
        ("[parameters]\nd = { u = 1 }\n", ["--pose", "1,2,x"], "--pose"),
        (None, [], "cannot read"),
    ],
)
def test_cli_bad_inputs(tmp_path: Path, content: str | None, args: list[str], message: str) -> None:
    f = tmp_path / "s.toml"
    if content is not None:
        f.write_text(content)
    out = _cli("uncertainty", str(f), *args)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("aacmm uncertainty: error:"), out.stderr
    assert message in lines[0]


# ------------------------------------------- issue 15.4 and 14.8 -----------


def test_histogram_mode_agrees_with_exact_mode() -> None:
    """Beyond the memory budget the quantiles come from histograms of the same
    draws: the moments equal the exact ones, the quantiles are within a bin."""
    spec = _spec({"theta": 2 * ARCSEC, "alpha": 3 * ARCSEC, "d": 0.005, "l": 0.003})
    exact = unc.propagate(spec, trials=30_000, workspace=5, seed=7, threads=2)
    hist = unc.propagate(spec, trials=30_000, workspace=5, seed=7, threads=2, memory_budget=1000)
    assert exact.quantiles == "exact" and hist.quantiles.startswith("histogram")
    for e, h in zip(exact.poses, hist.poses, strict=True):
        assert np.allclose(h.u_mc, e.u_mc, rtol=1e-9, atol=0)
        assert np.allclose(h.bias_mc, e.bias_mc, rtol=1e-6, atol=1e-15)
        # a bin is (max - min) / HIST_BINS; max - min < 12 u_mc for these draws
        width = 12 * e.u_mc.max() / unc.HIST_BINS
        assert np.all(np.abs(h.ci_mc - e.ci_mc) <= width)
        assert abs(h.r95_mc - e.r95_mc) <= 12 * e.u3_mc / unc.HIST_BINS


def test_result_independent_of_threads_and_the_draws_are_draw_deltas() -> None:
    spec = _spec({"theta": 2 * ARCSEC, "d": 0.005})
    one = unc.propagate(spec, trials=20_000, workspace=3, seed=4, threads=1)
    two = unc.propagate(spec, trials=20_000, workspace=3, seed=4, threads=2)
    for a, b in zip(one.poses, two.poses, strict=True):
        assert np.array_equal(a.u_mc, b.u_mc) and np.array_equal(a.ci_mc, b.ci_mc)
        assert a.r95_mc == b.r95_mc
    # the Monte Carlo points are perturbed_points of draw_deltas: an independent
    # numpy evaluation of the statistics on them gives the same numbers
    pts = perturbed_points(Params(), unc.draw_deltas(spec, 20_000, 4), POSES[:1])[:, 0, :]
    dev = pts - one.poses[0].point_mm
    assert np.allclose(one.poses[0].u_mc, dev.std(axis=0, ddof=1), rtol=1e-12)
    assert np.allclose(one.poses[0].ci_mc.T, np.quantile(dev, [0.025, 0.975], axis=0))
    assert np.isclose(one.poses[0].r95_mc, np.quantile(np.linalg.norm(dev, axis=1), 0.95))


def test_progress_and_memory_refusal() -> None:
    spec = _spec({"d": 0.005})
    seen: list[tuple[int, int]] = []
    unc.propagate(
        spec, trials=20_000, workspace=2, seed=1, progress=lambda n, t: seen.append((n, t))
    )
    assert sum(n for n, _ in seen) == 20_000 * 5 and {t for _, t in seen} == {20_000 * 5}
    with pytest.raises(unc.MemoryLimitError, match=r"poses need about .* GiB"):
        unc.propagate(spec, trials=100, workspace=10**12)


def test_cli_outputs_log_and_progress(tmp_path: Path) -> None:
    log = tmp_path / "run.csv"
    rows = ["seq," + ",".join(f"theta{i}" for i in range(1, 7))]
    rows += [f"{k}," + ",".join(f"{0.1 * k + 0.01 * i:.4f}" for i in range(6)) for k in range(30)]
    log.write_text("\n".join(rows) + "\n")
    out = _cli(
        "uncertainty",
        "example",
        "--trials",
        "3000",
        "--log",
        str(log),
        "--every",
        "3",
        "--csv",
        str(tmp_path / "u.csv"),
        "--png",
        str(tmp_path / "u.png"),
        "--json",
        str(tmp_path / "u.json"),
        "--progress",
    )
    assert out.returncode == 0, out.stderr
    doc = json.loads((tmp_path / "u.json").read_text())
    n_spec = len(unc.load_spec("example").poses_rad)
    assert len(doc["given_poses"]) == n_spec + 10 and doc["workspace_poses"] == []
    assert doc["mc_quantiles"] == "exact"
    lines = (tmp_path / "u.csv").read_text().splitlines()
    assert lines[0].startswith("pose,kind,theta1_deg") and len(lines) == 1 + 3 * (n_spec + 10)
    assert (tmp_path / "u.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "uncertainty" in out.stderr  # the progress bar, forced off a terminal
    out = _cli("uncertainty", "example", "--every", "2")
    assert out.returncode == 2 and "--every needs --log" in out.stderr


def test_figure_contents() -> None:
    res = unc.propagate(_spec({"theta": 2 * ARCSEC, "d": 0.005}), trials=2000, workspace=10)
    fig = unc.figure(res)
    titles = [ax.get_title() for ax in fig.axes]
    assert titles[0].startswith("per pose and axis: $u_{MC}/u_{lin}$ in [")
    assert "budget:" in titles[2] and r"$\theta$" in titles[2]
    assert "2000 trials" in fig.get_suptitle()


def test_cli_bounded_memory_refusal_and_clean_interrupt() -> None:
    """Issue 15.4: --trials 1e8 allocated 18.6 GiB at once; under a memory limit
    it ended in a traceback. Now it runs in bounded memory until Ctrl-C, which
    stops it with one line and status 130; poses that cannot fit are refused."""
    status, err, _ = run_then_interrupt(
        ["uncertainty", "example", "--trials", "100000000", "--threads", "2", "--max-hours",
         "1e4"], after_s=4.0,
    )  # fmt: skip
    assert status == 130, err
    estimate, last = err.strip().splitlines()  # issue 29.3: the estimate first
    assert estimate.startswith("aacmm uncertainty: estimated time about "), err
    assert "trial-poses at" in estimate and estimate.endswith("; Ctrl-C stops it"), err
    assert last == "aacmm uncertainty: interrupted", err
    out = _cli("uncertainty", "example", "--trials", "100", "--workspace", "1000000000000")
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "poses need about" in lines[0] and "GiB" in lines[0]


def test_cli_run_beyond_the_limit_is_refused_at_once(tmp_path: Path) -> None:
    """Issue 29.3: `uncertainty example --trials 10^12` ran silently for hours; it is
    refused with the estimate after its first half second, and writes nothing."""
    out = subprocess.run(
        [*AACMM, "uncertainty", "example", "--trials", "1000000000000", "--threads", "2",
         "--json", "u.json"],
        capture_output=True, text=True, timeout=90, cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
    assert lines[0].startswith("aacmm uncertainty: error: --trials 10^12 would take about ")
    assert "more than the limit of 24 h: use fewer --trials or poses" in lines[0]
    assert list(tmp_path.iterdir()) == []
