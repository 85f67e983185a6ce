# Calibration (issue 12): aacmm.calibration (identification engine, identifiability,
# covariance, validation, probe calibration), its tests against synthetic truths,
# lint, and the benchmark; the quality gate and the arm's identity (issue 24:
# tests/host/test_calibration_gate.py, the 20-arm study of tests/host/gate_study.py). BLAS runs on one thread: the engine's matrices are tall
# and thin, where OpenBLAS threads only contend on a shared machine (docs/calibration.md).

CALIB_PY_FILES := host/src/aacmm/calibration tests/host/test_calibration.py \
                  tests/host/test_calibration_report.py tests/host/test_calibration_cli.py \
                  tests/host/test_calibration_e2e.py tests/host/test_calibration_gate.py \
                  tests/host/test_calibration_arms.py tests/host/test_calibration_harmonics.py \
                  tests/host/test_calibration_models_e2e.py tests/host/test_calibration_compact.py \
                  tests/host/test_calibration_harmonics_study.py tests/host/harmonics_study.py \
                  scripts/harmonics_study_figures.py tests/host/test_calibration_probe_e2e.py \
                  tests/host/gate_study.py host/src/aacmm/commands/calibrate.py \
                  host/src/aacmm/commands/calibrate_output.py \
                  tests/host/calib_synth.py bench/bench_calibration.py bench/calibration_figures.py \
                  bench/harmonics_figures.py tests/host/test_calibration_thermal.py \
                  tests/host/thermal_calib_study.py tests/host/test_calibration_recal.py
CALIB_ENV      := OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1

.PHONY: test-calibration test-calibration-lint bench-calibration harmonics-study-figures

#> test-calibration     engine vs synthetic truths (200 seeded runs), reports, aacmm calibrate, end to end on the simulator, the quality gate (20 random arms), a 5-axis parallel-hinge and a 7-axis arm end to end on the simulation library, encoder angle harmonics (issue 27; 200 one-head truths on the shipped plan), aacmm calibrate and verify on the simulator as gao2013 and commercial7, desk4 and microscribe5 with their compact plans and mpe2018 with its medium ones on the simulator, probe calibration of commercial7 on the simulator, link CTEs calibrated from sessions at 10 and 30 degC (issue 27; 20 aluminium arms verified at 28 degC), a recalibration starting from the set in force with its error model
test-calibration: sim
	$(CALIB_ENV) $(PYTHON) -m pytest -q -p no:cacheprovider -c host/pyproject.toml --rootdir=. \
	    tests/host/test_calibration.py tests/host/test_calibration_report.py \
	    tests/host/test_calibration_cli.py tests/host/test_calibration_e2e.py \
	    tests/host/test_calibration_gate.py tests/host/test_calibration_arms.py \
	    tests/host/test_calibration_harmonics.py tests/host/test_calibration_models_e2e.py \
	    tests/host/test_calibration_compact.py tests/host/test_calibration_harmonics_study.py \
	    tests/host/test_calibration_probe_e2e.py tests/host/test_calibration_thermal.py \
	    tests/host/test_calibration_recal.py
	@$(MAKE) --no-print-directory test-calibration-lint

#> harmonics-study-figures  regenerate the 200 one-head truths figure and JSON of docs/calibration.md
harmonics-study-figures:
	$(CALIB_ENV) $(PYTHON) scripts/harmonics_study_figures.py

#> test-calibration-lint  ruff, ruff format, mypy on the calibration code (part of test-calibration)
test-calibration-lint:
	$(call py_lint,$(CALIB_PY_FILES))

TEST_SUITES += test-calibration

#> bench-calibration    calibration of 1,000 and 100,000 observations, probe calibration of 50 points
bench-calibration:
	@$(CALIB_ENV) $(PYTHON) bench/bench_calibration.py
BENCH_TARGETS += bench-calibration
