"""Reports, figures and the propagated point uncertainty of a calibration."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from aacmm import uncertainty as unc
from aacmm.calibration import calibrate, plots, report
from aacmm.calibration.validation import compare
from aacmm.core import Model, Params
from aacmm.fileio import save_figure
from calib_synth import synthetic
from test_calibration import SIGMA, observations

pytestmark = pytest.mark.timeout(300)


def test_covariance_spec_equals_independent_spec() -> None:
    u = {"theta": 1e-5, "alpha": 2e-5, "d": 0.004, "a": 0.003, "l": 0.002}
    ind = unc.UncertaintySpec.from_u(u)
    cor = unc.UncertaintySpec.from_covariance(np.diag(ind.u_vector() ** 2), ind.params)
    r1 = unc.propagate(ind, trials=200, workspace=5, seed=1)
    r2 = unc.propagate(cor, trials=200, workspace=5, seed=1)
    for a, b in zip(r1.poses, r2.poses, strict=True):
        assert np.allclose(a.u_lin, b.u_lin, rtol=1e-12)
    assert [e.name for e in r1.budget] == [e.name for e in r2.budget]
    with pytest.raises(ValueError, match="symmetric"):
        unc.UncertaintySpec.from_covariance(np.triu(np.ones((25, 25))), Params())
    with pytest.raises(ValueError, match="semi-definite"):
        unc.UncertaintySpec.from_covariance(-np.eye(25), Params())


def test_point_uncertainty_after_calibration() -> None:
    s = synthetic(21, noise_mm=SIGMA)
    res = calibrate(observations(s))
    ur = report.point_uncertainty(res, workspace=20, trials=20_000, seed=3)
    q = np.array([p.theta_rad for p in ur.poses])
    _, j = Model(res.params).points_jacobians(q)
    ref = np.sqrt(np.einsum("nak,kl,nal->na", j, res.covariance, j))
    assert np.allclose([p.u_lin for p in ur.poses], ref, rtol=1e-10)
    lo, hi = ur.ratio_range()
    assert 0.95 < lo <= hi < 1.05  # correlated normal draws agree with J Sigma J^T
    # a few um: the calibration's own contribution to a probed point
    assert 0.0005 < np.median([p.u3_lin for p in ur.workspace]) < 0.02


def test_report_json_and_figures(tmp_path: Path) -> None:
    s = synthetic(22, noise_mm=SIGMA)
    obs = observations(s)
    res = calibrate(obs)
    cmp_ = compare(obs, res.start, res.params)
    text = report.format_result(res, cmp_)
    for needle in (
        "rank 21 of 25",
        "held at their start values",
        "[theta1]",
        "[tip]",
        "chi^2 =",
        "Before / after",
        "Outliers: none",
        "held (unobservable)",
    ):
        assert needle in text
    data = json.loads(json.dumps(report.to_json(res, cmp_)))
    assert data["identifiability"]["rank"] == 21
    assert len(data["covariance"]) == 25 and data["held"] == ["theta1", "theta6", "alpha6", "d1"]
    assert {d["kind"] for d in data["identifiability"]["null_space"]} == {"theta1", "d1", "tip"}
    figs = plots.residual_figures(res)
    assert sorted(figs) == [0, 1, 2, 3]  # 3 seats and the lengths
    # a person reads the steps numbered from 1, as the capture prompts (issue 29.1)
    titles = [figs[k].get_suptitle() for k in sorted(figs)]
    assert [t.split()[:2] for t in titles] == [["step", str(k + 1)] for k in range(4)], titles
    others = [
        plots.spectrum_figure(res.identifiability),
        plots.correlation_figure(res),
        plots.convergence_figure(res),
        plots.uncertainty_figure(report.point_uncertainty(res, workspace=5, trials=500)),
    ]
    for i, f in enumerate([*figs.values(), *others]):
        path = tmp_path / f"f{i}.png"
        save_figure(f, path)
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    u = report.unit_residuals(res.problem, res.after)
    assert u.size_mm.size == res.problem.n_units
    assert np.all(np.isfinite(u.signed_mm[u.kind == "length"]))
