# Tolerance allocation (issue 18): aacmm.analysis.tolerance, `aacmm tolerance`,
# docs/tolerance.md. The suite checks the allocation against the Lagrange
# closed form, direct solves and brute force over encoder catalogues, the
# Monte Carlo check (10^5 arms) against a numpy forward model, the calibrated
# arm against an explicit least-squares calibration, and the CLI's outputs and
# exit statuses; and any arm (issue 26): the 7-axis commercial7 allocation checked
# by a Monte Carlo written in the test, `aacmm tolerance --model` and its refusals.

TOLERANCE_PY_FILES := host/src/aacmm/analysis/tolerance host/src/aacmm/commands/tolerance.py \
                      bench/bench_tolerance.py \
                      tests/host/test_tolerance.py tests/host/test_tolerance_arms.py

.PHONY: test-tolerance
#> test-tolerance  tolerance allocation: closed form, encoders, Monte Carlo check, CLI, lint
test-tolerance:
	$(PYTHON) -m pytest -q -p no:cacheprovider -c host/pyproject.toml --rootdir=. \
	    tests/host/test_tolerance.py tests/host/test_tolerance_arms.py
	$(call py_lint,$(TOLERANCE_PY_FILES))

TEST_SUITES += test-tolerance

.PHONY: bench-tolerance
bench-tolerance:
	@$(PYTHON) bench/bench_tolerance.py
BENCH_TARGETS += bench-tolerance
