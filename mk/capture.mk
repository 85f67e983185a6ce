# Plans, recorded data and guided capture (issue 11 items 1, 2, 5; 15.1, 15.5):
# aacmm.plans (TOML plans, presets, slots), aacmm.records (sessions, logs,
# parameter set per row), aacmm capture; their tests and lint.
#   test-capture   plans (bad plans: file, line, field), sessions (undo, resume
#                  after a cut row, per-row parameter sets), aacmm capture against
#                  the simulator (kill -9 + resume, undo, Ctrl-C), logs through
#                  aacmm.records (15.1 repro, 15.5 reconnect to another set, 14.2
#                  lost samples, 14.7 rate while connected, --from-log), whole
#                  plans against the simulated operator (labels, joint spreads
#                  per step); the device's link temperatures in logs and capture; lint

CAPTURE_PY_FILES := host/src/aacmm/plans host/src/aacmm/records \
                    host/src/aacmm/commands/capture.py host/src/aacmm/commands/plan.py \
                    host/src/aacmm/analysis/poselog.py \
                    tests/host/test_plans.py tests/host/test_records.py tests/host/test_capture.py \
                    tests/host/test_logs.py tests/host/test_records_arms.py \
                    tests/host/test_capture_scenario.py tests/host/test_device_temps_capture.py \
                    bench/bench_capture.py
CAPTURE_PYTEST   := $(PYTHON) -m pytest -q -p no:cacheprovider -ra -c host/pyproject.toml --rootdir=.

.PHONY: test-capture test-capture-lint
#> test-capture         plans, sessions, aacmm capture against the simulator
test-capture: sim
	$(CAPTURE_PYTEST) tests/host/test_plans.py tests/host/test_records.py tests/host/test_capture.py \
	    tests/host/test_logs.py tests/host/test_records_arms.py tests/host/test_device_temps_capture.py
	$(CAPTURE_PYTEST) -s tests/host/test_capture_scenario.py  # -s: its "measured:" joint spreads
	@$(MAKE) --no-print-directory test-capture-lint

#> test-capture-lint    ruff, ruff format, mypy --strict on plans, records, capture (part of test-capture)
test-capture-lint:
	$(call py_lint,$(CAPTURE_PY_FILES))

TEST_SUITES += test-capture

# ---- benchmark: a press's cost in aacmm capture, queueing apart (JSON lines) ----
.PHONY: bench-capture
bench-capture: sim
	@$(PYTHON) bench/bench_capture.py
BENCH_TARGETS += bench-capture
