# The README's main job (issue 19). `make demo` runs DEMO_STEPS in order:
#   demo-poses    points and Jacobians of a few poses with the C core
#   demo-session  `aacmm demo`: on the simulator with a random true arm, a short
#                 log and the paper's Table 2, then verification (FAIL),
#                 kinematic calibration, params set --save, verification (PASS),
#                 the before/after table, figures, one-page reports and a check
#                 against the simulator's truth, under out/demo-<UTC time>/
# Later areas may extend DEMO_STEPS with their own targets.
#   test-demo       one `aacmm demo` run (fast operator) checked against the
#                   simulator's truth: tests/host/test_demo.py, then test-demo-lint
#   test-demo-lint  ruff, ruff format, mypy --strict on the demo and its test
DEMO_STEPS := demo-poses demo-session

DEMO_PY_FILES := host/src/aacmm/commands/demo.py host/src/aacmm/commands/demo_report.py \
                 tests/host/test_demo.py
DEMO_PYTEST   := $(PYTHON) -m pytest -q -p no:cacheprovider -ra -c host/pyproject.toml --rootdir=.

$(BUILD)/examples/print_poses: examples/print_poses.c $(CORE_SRCS) $(CORE_HDRS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(HOST_OPT) -I$(FW_INC) $(CORE_SRCS) examples/print_poses.c -lm -o $@

.PHONY: demo-poses demo-session test-demo test-demo-lint
demo-poses: $(BUILD)/examples/print_poses
	@$<

demo-session: sim
	@$(VENV)/bin/aacmm demo

demo: setup
	@for step in $(DEMO_STEPS); do $(MAKE) --no-print-directory $$step || exit 1; done

#> test-demo            `aacmm demo` (fast operator) against the simulator's truth: E_Uni and SPAT fall >= 20x, PASS after
test-demo: sim
	$(DEMO_PYTEST) tests/host/test_demo.py
	@$(MAKE) --no-print-directory test-demo-lint

#> test-demo-lint       ruff, ruff format, mypy --strict on the demo (part of test-demo)
test-demo-lint:
	$(call py_lint,$(DEMO_PY_FILES))

TEST_SUITES += test-demo
