"""aacmm.analysis.mc and `aacmm mc`: the paper's Table 2, reproduced on the C core."""

from __future__ import annotations

import csv
import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from aacmm.analysis import mc
from aacmm.analysis.mc_poses import DEFAULT_JOINTS, JointDistribution, draw_poses
from aacmm.analysis.mc_report import (
    CoefficientResult,
    compare_with_paper,
    figure,
    max_rel_deviation,
)
from aacmm.analysis.poselog import PoseLogError, read_pose_log
from aacmm.core import EncoderConfig, Params, counts_to_angles
from interrupt import run_then_interrupt
from test_core_oracle import numpy_point_jacobian

pytestmark = pytest.mark.timeout(120)
AACMM = [sys.executable, "-m", "aacmm.cli"]


@pytest.fixture(scope="module")
def table2_run() -> CoefficientResult:
    return mc.error_transfer_coefficients(100_000, seed=2013)


def test_table2_reproduced_within_5_percent(table2_run: CoefficientResult) -> None:
    r = table2_run
    assert r.n == 100_000
    for c in compare_with_paper(r):
        if c.paper == 0.0:  # df_z/dtheta_1: exactly zero, not a ratio
            assert c.ours == 0.0
        else:
            assert c.rel_dev is not None and abs(c.rel_dev) < 0.05, c
    worst, _ = max_rel_deviation(r)
    assert worst < 0.05


def test_converged_mean_within_3_1_percent() -> None:
    # The CSV's note: the converged average of |J| is within 3.1 % of every
    # entry. 10^6 poses: sampling noise < 0.5 % (3 standard errors allowed).
    r = mc.error_transfer_coefficients(1_000_000, seed=1)
    for c in compare_with_paper(r):
        if c.rel_dev is not None:
            assert abs(c.rel_dev) <= 0.031 + 3 * c.sem / c.paper, c


def test_unit_norm_and_dfz_dtheta1_zero(table2_run: CoefficientResult) -> None:
    r = table2_run
    assert r.checked_poses == mc.CHECK_POSES
    assert r.unit_norm_max_dev < 1e-14  # Eq. 11-13
    assert r.dfz_dtheta1_max == 0.0
    assert r.mean_abs[2, 0] == 0.0
    # each d, a, l column has norm 1, so the mean |component|s are below 1 and
    # their mean squares sum to 1 per column
    ms = (r.std_abs**2 * (r.n - 1) / r.n + r.mean_abs**2)[:, 12:]
    assert np.allclose(ms.sum(axis=0), 1.0, atol=1e-9)


def test_matches_numpy_oracle_on_same_poses() -> None:
    r = mc.error_transfer_coefficients(5000, seed=9, threads=1)
    th = draw_poses(5000, seed=9)
    _, j = numpy_point_jacobian(Params(), th)
    a = np.abs(j)
    assert np.allclose(r.mean_abs, a.mean(axis=0), rtol=1e-9, atol=1e-12)
    assert np.allclose(r.sem, a.std(axis=0, ddof=1) / math.sqrt(5000), rtol=1e-6, atol=1e-12)


def test_reproducible_and_independent_of_threads() -> None:
    a = mc.error_transfer_coefficients(50_000, seed=5, threads=1)
    b = mc.error_transfer_coefficients(50_000, seed=5, threads=2)
    c = mc.error_transfer_coefficients(50_000, seed=6, threads=2)
    assert np.array_equal(a.mean_abs, b.mean_abs) and np.array_equal(a.sem, b.sem)
    assert not np.array_equal(a.mean_abs, c.mean_abs)
    fresh = mc.error_transfer_coefficients(100)
    assert fresh.seed is not None
    again = mc.error_transfer_coefficients(100, seed=fresh.seed)
    assert np.array_equal(fresh.mean_abs, again.mean_abs)


def test_joint_distributions() -> None:
    js = list(DEFAULT_JOINTS)
    js[1] = JointDistribution.uniform(0.2, 0.4)
    js[4] = JointDistribution.normal(1.0, 0.0)  # joint 5 fixed at 1 rad
    th = draw_poses(20_000, js, seed=3)
    assert th[:, 1].min() >= 0.2 and th[:, 1].max() < 0.4
    assert np.all(th[:, 4] == 1.0)
    assert th[:, 0].min() >= -math.pi and th[:, 0].max() < math.pi
    r = mc.error_transfer_coefficients(20_000, js, seed=3)
    _, j = numpy_point_jacobian(Params(), th)
    assert np.allclose(r.mean_abs, np.abs(j).mean(axis=0), rtol=1e-9, atol=1e-12)


def test_adaptive_jcgm101() -> None:
    r = mc.error_transfer_coefficients_adaptive(ndig=2, seed=4)
    assert r.converged and r.runs >= 2 and r.n == r.runs * mc.DEFAULT_BLOCK
    assert r.tolerance is not None
    # the criterion held at the end: 2 s_y <= delta, with s_y ~ sem
    assert np.all(2 * r.sem <= r.tolerance * 1.5 + 1e-15)
    # the first run equals the fixed-N run with the same seed (same streams)
    first = mc.error_transfer_coefficients(mc.DEFAULT_BLOCK, seed=4)
    one = mc.error_transfer_coefficients_adaptive(ndig=2, seed=4, max_trials=mc.DEFAULT_BLOCK)
    assert one.converged is False and one.runs == 1
    assert np.array_equal(first.mean_abs, one.mean_abs)
    tight = mc.error_transfer_coefficients_adaptive(tolerance=0.5, seed=4, threads=2)
    assert tight.converged and tight.n > r.n
    serial = mc.error_transfer_coefficients_adaptive(tolerance=0.5, seed=4, threads=1)
    assert serial.runs == tight.runs and np.array_equal(serial.mean_abs, tight.mean_abs)
    with pytest.raises(ValueError, match="tolerance"):
        mc.error_transfer_coefficients_adaptive(tolerance=-1.0)
    with pytest.raises(ValueError, match="digits"):
        mc.error_transfer_coefficients_adaptive(ndig=0)


def test_jcgm_tolerance_rule() -> None:
    # JCGM 101 7.9.2 example: 1.0 (ndig 2) -> 0.05; 384.87 -> 5; 0 -> 0
    d = mc.jcgm_tolerance(np.array([1.0, 384.87, 0.0, 0.0123]), 2)
    assert np.allclose(d, [0.05, 5.0, 0.0, 0.0005])


def test_bad_arguments() -> None:
    for n in (0, -5):
        with pytest.raises(ValueError, match="positive"):
            mc.error_transfer_coefficients(n)
    with pytest.raises(ValueError, match="seed"):
        mc.error_transfer_coefficients(10, seed=-1)
    with pytest.raises(ValueError, match="threads"):
        mc.error_transfer_coefficients(10, threads=0)
    with pytest.raises(ValueError, match="unknown joint distribution"):
        JointDistribution("cauchy", 0, 1)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="low < high"):
        JointDistribution.uniform(1.0, 1.0)
    with pytest.raises(ValueError, match="6 JointDistribution"):
        mc.error_transfer_coefficients(10, joints=[JointDistribution()])
    with pytest.raises(ValueError, match="no poses"):
        mc.coefficients_over_poses(np.empty((0, 6)))


# ------------------------------------------------------------------ logs ---


def _write_log(path: Path, header: list[str], rows: list[list[object]]) -> None:
    with open(path, "w", newline="") as f:
        f.write("# aacmm log test\n")
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def test_logged_poses_counts_with_sidecar(tmp_path: Path) -> None:
    rng = np.random.default_rng(8)
    cpr = (1 << 20, 3600000, 1 << 24, 36000, 1 << 32, 1 << 18)
    counts = np.stack([rng.integers(0, c, 500) for c in cpr], axis=1)
    log = tmp_path / "run.csv"
    _write_log(
        log,
        ["t_s", "count1", "count2", "count3", "count4", "count5", "count6", "x_mm"],
        [[i * 0.01, *map(int, c), 0.0] for i, c in enumerate(counts)],
    )
    enc = {
        "counts_per_rev": list(cpr),
        "zero_offset_counts": [5, 0, 0, 7, 0, 1],
        "direction": [1, -1, 1, 1, -1, 1],
    }
    (tmp_path / "run.csv.json").write_text(json.dumps({"encoders": enc}))
    pl = read_pose_log(log)
    cfg = EncoderConfig(tuple(cpr), (5, 0, 0, 7, 0, 1), (1, -1, 1, 1, -1, 1))
    assert pl.encoders == cfg and pl.sidecar is not None
    th = counts_to_angles(counts, cfg)
    assert np.array_equal(pl.theta_rad, th)
    r = mc.coefficients_over_poses(pl.theta_rad, source="log")
    _, j = numpy_point_jacobian(Params(), th)
    assert r.n == 500
    assert np.allclose(r.mean_abs, np.abs(j).mean(axis=0), rtol=1e-9, atol=1e-12)
    assert r.unit_norm_max_dev < 1e-14 and r.dfz_dtheta1_max == 0.0


def test_logged_poses_theta_columns_and_defaults(tmp_path: Path) -> None:
    log = tmp_path / "angles.csv"
    _write_log(
        log,
        ["theta1", "theta2", "theta3", "theta4", "theta5", "theta6"],
        [[0.1, 0.2, 0.3, 0.4, 0.5, 0.6], [-1, -2, -3, 1, 2, 3]],
    )
    pl = read_pose_log(log)
    assert pl.theta_rad.shape == (2, 6) and pl.theta_rad[1, 2] == -3.0
    alias = tmp_path / "alias.csv"
    _write_log(alias, ["c1", "c2", "c3", "c4", "c5", "c6"], [[1 << 30, 0, 0, 0, 0, 0]])
    pl = read_pose_log(alias)  # no sidecar: 2^32 counts/rev, offset 0, direction +1
    assert pl.sidecar is None and pl.theta_rad[0, 0] == pytest.approx(math.pi / 2)


def test_log_sidecar_params_used_by_cli(tmp_path: Path) -> None:
    log = tmp_path / "p.csv"
    th = draw_poses(300, seed=12)
    _write_log(log, [f"theta{i}" for i in range(1, 7)], th.tolist())
    prm = Params(l_mm=250.0, a_mm=(0.0, 10.0, 0.0, 0.0, 0.0, 0.0))
    side = {"params": {"l_mm": 250.0, "a_mm": [0, 10, 0, 0, 0, 0]}}
    log.with_name("p.csv.json").write_text(json.dumps(side))
    out = _cli("mc", "--log", str(log), "-q", "--json", str(tmp_path / "p.json"))
    assert out.returncode == 0, out.stderr
    doc = json.loads((tmp_path / "p.json").read_text())
    _, j = numpy_point_jacobian(prm, th)
    want = np.abs(j).mean(axis=0)
    assert doc["coefficients"]["theta6"]["x"]["mean_abs"] == pytest.approx(want[0, 5], rel=1e-9)
    assert doc["seed"] is None and doc["n"] == 300


def test_bad_logs(tmp_path: Path) -> None:
    with pytest.raises(PoseLogError, match="cannot read"):
        read_pose_log(tmp_path / "missing.csv")
    nohead = tmp_path / "nohead.csv"
    _write_log(nohead, ["a", "b"], [[1, 2]])
    with pytest.raises(PoseLogError, match="no joint columns"):
        read_pose_log(nohead)
    bad = tmp_path / "bad.csv"
    _write_log(bad, [f"count{i}" for i in range(1, 7)], [[0] * 6, [0, 0, "x", 0, 0, 0]])
    with pytest.raises(PoseLogError, match=r"bad\.csv:4: bad joint value"):
        read_pose_log(bad)
    empty = tmp_path / "empty.csv"
    _write_log(empty, [f"count{i}" for i in range(1, 7)], [])
    with pytest.raises(PoseLogError, match="no poses"):
        read_pose_log(empty)
    big = tmp_path / "big.csv"
    _write_log(big, [f"count{i}" for i in range(1, 7)], [[0] * 6, [5000, 0, 0, 0, 0, 0]])
    big.with_name("big.csv.json").write_text(
        json.dumps({"encoders": {"counts_per_rev": [4096] * 6}})
    )
    with pytest.raises(PoseLogError, match=r"big\.csv:4:"):
        read_pose_log(big)
    side = tmp_path / "side.csv"
    _write_log(side, [f"count{i}" for i in range(1, 7)], [[0] * 6])
    side.with_name("side.json").write_text("{not json")
    with pytest.raises(PoseLogError, match="sidecar"):
        read_pose_log(side)
    binary = tmp_path / "bin.csv"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(PoseLogError, match="cannot read"):
        read_pose_log(binary)


# ------------------------------------------------------------------- CLI ---


def _cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*AACMM, *args],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=cwd,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
    )


def test_cli_outputs(tmp_path: Path) -> None:
    out = _cli(
        "mc",
        "-n",
        "20000",
        "--seed",
        "3",
        "--csv",
        str(tmp_path / "t.csv"),
        "--json",
        str(tmp_path / "t.json"),
        "--png",
        str(tmp_path / "t.png"),
    )
    assert out.returncode == 0, out.stderr
    assert "dfx/dalpha" in out.stdout and "paper" in out.stdout and "dev" in out.stdout
    assert "Eq. 11-13" in out.stdout and "df_z/dtheta_1 = 0" in out.stdout
    doc = json.loads((tmp_path / "t.json").read_text())
    assert doc["n"] == 20000 and doc["seed"] == 3 and len(doc["table2"]) == 36
    assert doc["checks"]["dfz_dtheta1_max_abs"] == 0.0
    ref = mc.error_transfer_coefficients(20000, seed=3)
    assert doc["coefficients"]["alpha2"]["x"]["mean_abs"] == ref.mean_abs[0, 7]
    rows = list(csv.DictReader(open(tmp_path / "t.csv")))
    assert len(rows) == 75 and rows[0]["parameter"] == "theta1"
    assert float(rows[0]["paper"]) == 501.61
    assert (tmp_path / "t.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_log_and_adaptive(tmp_path: Path) -> None:
    log = tmp_path / "l.csv"
    _write_log(log, [f"theta{i}" for i in range(1, 7)], [[0.1 * i] * 6 for i in range(50)])
    out = _cli("mc", "--log", str(log))
    assert out.returncode == 0, out.stderr
    assert "50 poses (log" in out.stdout
    out = _cli(
        "mc", "--adaptive", "--ndig", "1", "--seed", "1", "-q", "--json", str(tmp_path / "a.json")
    )
    assert out.returncode == 0, out.stderr
    assert json.loads((tmp_path / "a.json").read_text())["adaptive"]["converged"] is True


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["mc", "-n", "0"], "positive integer"),
        (["mc", "-n", "-3"], "positive integer"),
        (["mc", "--log", "/nonexistent/log.csv"], "cannot read log"),
        (["mc", "--range", "7", "0", "10"], "joint must be 1..6"),
        (["mc", "--range", "2", "10", "0"], "low < high"),
        (["mc", "--ndig", "2"], "need --adaptive"),
    ],
)
def test_cli_bad_inputs(args: list[str], message: str) -> None:
    out = _cli(*args)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("aacmm mc: error:"), out.stderr
    assert message in lines[0]
    assert "Traceback" not in out.stderr


def test_cli_adaptive_ndig_zero_is_refused() -> None:
    # issue 15.6: --ndig 0 was silently run as --ndig 2
    out = _cli("mc", "--adaptive", "--ndig", "0", "--seed", "1", "-q")
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == [
        "aacmm mc: error: significant digits must be a positive integer, got 0"
    ]
    with pytest.raises(ValueError, match="positive integer, got 0"):
        mc.error_transfer_coefficients_adaptive(ndig=0, seed=1)


def test_cli_refuses_existing_outputs(tmp_path: Path) -> None:
    target = tmp_path / "t.json"
    target.write_text("keep")
    out = _cli("mc", "-n", "100", "--seed", "1", "-q", "--json", str(target))
    assert out.returncode == 2 and "exists (use --force to overwrite)" in out.stderr
    assert target.read_text() == "keep"
    out = _cli("mc", "-n", "100", "--seed", "1", "-q", "--json", str(target), "--force")
    assert out.returncode == 0 and json.loads(target.read_text())["n"] == 100


def test_figure_reads_clearly() -> None:
    """Issue 14.8: paper markers unlike error bars, error bars labelled +-1
    standard error, Greek letters, the joint distribution in the title."""
    import matplotlib.collections
    import matplotlib.lines

    r = mc.error_transfer_coefficients(
        3000,
        seed=4,
        joints=[JointDistribution.normal(0.0, 0.2)] + [JointDistribution()] * 5,
    )
    fig = figure(r)
    title = fig.get_suptitle()
    assert "3000 poses" in title and "seed 4" in title
    assert "joint 1 normal(0, 11.4592) deg" in title
    assert "joints 2-6 uniform[-180, 180) deg" in title
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "error bar: $\\pm 1$ standard error" in legend and "paper, Table 2" in legend
    assert any("\\partial f_x" in t for t in legend)
    for ax, greek in zip(fig.axes, ("\\alpha", "\\theta"), strict=True):
        assert f"${greek}_i$" in ax.get_title()
        paper = [
            ln
            for ln in ax.get_lines()
            if isinstance(ln, matplotlib.lines.Line2D) and ln.get_marker() == "D"
        ]
        assert len(paper) == 3 and all(ln.get_markerfacecolor() == "white" for ln in paper)
        # error bars are plain vertical segments: no cap markers that could pass for paper values
        caps = [ln for ln in ax.get_lines() if ln.get_marker() in ("_", "|")]
        assert caps == []
        assert any(isinstance(c, matplotlib.collections.LineCollection) for c in ax.collections)


def test_cli_bounded_memory_and_clean_interrupt() -> None:
    """Issue 15.4: `mc -n 10^12` built n/16384 tasks up front (10 GB after 67 s).
    Now memory stays flat under a 2 GiB address-space limit, and Ctrl-C stops
    the run at once with one line and status 130."""
    status, err, stopped_in = run_then_interrupt(
        ["mc", "-n", "1000000000000", "--seed", "1", "--threads", "2", "--max-hours", "1e4"],
        after_s=3.0,
    )
    assert status == 130, err
    # issue 29.3: a long run says how long it will take before its bulk
    estimate, last = err.strip().splitlines()
    assert re.fullmatch(
        r"aacmm mc: estimated time about .+ \(10\^12 poses at .+ per second\); Ctrl-C stops it",
        estimate,
    ), err
    assert last == "aacmm mc: interrupted", err
    assert stopped_in < 10.0, stopped_in


def test_cli_run_beyond_the_limit_is_refused_at_once(tmp_path: Path) -> None:
    """Issue 29.3: `mc -n 10^12` ran silently for hours. A run estimated beyond
    --max-hours (default 24) is refused with the estimate, after its first half
    second; nothing is written."""
    for args, limit in ((["-n", "1000000000000000"], "24 h"), (["-n", "10000000000",
                        "--max-hours", "0.0001"], "0 s")):  # fmt: skip
        out = _cli("mc", *args, "--seed", "1", "--threads", "2", "--json", "n.json", cwd=tmp_path)
        assert out.returncode == 2, out.stderr
        lines = out.stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
        assert re.fullmatch(
            r"aacmm mc: error: -n \S+ would take about .+ \(\S+ poses at .+ per second\), "
            rf"more than the limit of {limit}: use fewer poses \(or a larger --max-hours\)",
            lines[0],
        ), lines
    assert list(tmp_path.iterdir()) == []
    out = _cli("mc", "-n", "100", "--max-hours", "0")
    assert out.returncode == 2 and "--max-hours must be a positive number" in out.stderr


def test_cli_adaptive_interrupt_is_130() -> None:
    """Issue 29.4: Ctrl-C during `mc --adaptive` ended in "did not converge", exit 1.
    Runs of 10^8 poses each: the runs in flight stop within a chunk."""
    status, err, stopped_in = run_then_interrupt(
        ["mc", "--adaptive", "--block", "100000000", "--max-trials", "1000000000",
         "--threads", "2", "--seed", "1"], after_s=2.0,
    )  # fmt: skip
    assert status == 130, err
    assert err.strip().splitlines()[-1] == "aacmm mc: interrupted", err
    assert "converge" not in err and "Traceback" not in err
    assert stopped_in < 10.0, stopped_in


def test_cli_closed_stdout_ends_quietly(tmp_path: Path) -> None:
    """Issue 29.4: `aacmm mc | head -c 10` ended in "error: [Errno 32] Broken pipe",
    exit 2; the files asked for are still written."""
    for args in (["mc", "-n", "1000", "--seed", "1", "--json", str(tmp_path / "m.json")],
                 ["mc", "--help"]):  # fmt: skip
        p = subprocess.Popen(
            [*AACMM, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        assert p.stdout is not None and p.stderr is not None
        p.stdout.close()  # the reader went away before the first byte
        err = p.stderr.read()
        assert p.wait(timeout=60) == 0, err
        assert err == "", err
    assert json.loads((tmp_path / "m.json").read_text())["n"] == 1000


def test_run_clock() -> None:
    """The estimate from the run's own progress (a fake clock): nothing before the
    warm-up, then once; beyond the limit a RunLimitError with the estimate."""
    from aacmm.uncertainty.runlimits import RunClock, RunLimitError, format_duration

    now = [0.0]
    c = RunClock(1000, "poses", limit_s=100.0, what="-n 1000", clock=lambda: now[0])
    now[0] = 0.1
    assert c.update(1) is None  # first report: the start of the rate
    now[0] = 0.3
    assert c.update(10) is None  # within the warm-up
    now[0] = 1.1
    est = c.update(9)  # 19 more poses in 1.0 s since the first report
    assert est is not None and est.rate == pytest.approx(19.0)
    assert est.seconds == pytest.approx(1.1 + (1000 - 20) / 19.0)
    now[0] = 2.0
    assert c.update(10) is None  # only once
    c2 = RunClock(1e6, "poses", limit_s=100.0, what="-n 10^6", hint="fewer", clock=lambda: now[0])
    now[0] = 3.0
    c2.update(1)
    now[0] = 4.0
    with pytest.raises(RunLimitError, match=r"-n 10\^6 would take about .* limit of 2 min: fewer"):
        c2.update(1)
    with pytest.raises(RunLimitError, match="limit of 1 min"):
        RunClock(10, "arms", limit_s=60.0).preset(61.0)
    assert [format_duration(x) for x in (59, 600, 7260, 86400, 3 * 86400)] == [
        "59 s", "10 min", "2 h 1 min", "24 h", "3.0 days"
    ]  # fmt: skip
