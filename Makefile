# aacmm: the single entry point. `make help` lists the targets.
#
# Each area of the project (kinematics core, fixed-point path, protocol, device,
# host, ...) has its own fragment under mk/. A fragment adds its test suites to
# TEST_SUITES, its benchmarks to BENCH_TARGETS and its cross builds to
# FIRMWARE_TARGETS; the targets below run them all.

.DEFAULT_GOAL := help
include mk/00-common.mk
include $(filter-out mk/00-common.mk,$(sort $(wildcard mk/*.mk)))

.PHONY: help setup test bench firmware demo clean check-format

# `make help` prints every "#> NAME  TEXT" line of this file and of mk/*.mk
# (scripts/make-help.sh): a new target gets one there, and test-tooling checks
# that every phony target is listed.
#> demo          the main job: build, run, print results (does all set-up)
#> test          every test suite (does all set-up); one line per suite, logs in build/test-logs/
#> bench         benchmarks, one JSON object per line on stdout
#> firmware      cross builds for the ARM targets
#> setup         Debian packages and the Python venv only
#> clean         remove build outputs
#> check-format  Python as `ruff format` writes it; LF, no trailing blanks or tabs in the sources
#> help          this list
help:
	@sh scripts/make-help.sh "$(TEST_SUITES)" "$(BENCH_TARGETS)" "$(FIRMWARE_TARGETS)" \
	    "$(DEMO_STEPS)" Makefile $(filter-out mk/00-common.mk,$(sort $(wildcard mk/*.mk)))

setup:
	@sh scripts/setup.sh

# Suites run two at a time (TEST_JOBS; the TEST_ALONE ones after the others,
# alone); a failing suite does not hide the others.
# Each suite's output goes to build/test-logs/<suite>.log; the terminal gets
# one line per suite (name, result, seconds) and, for a failure, the log's
# tail (scripts/run-suites.sh; TEST_VERBOSE=1 streams everything).
test:
	@sh scripts/run-suites.sh --prepare setup --alone "$(TEST_ALONE)" $(TEST_SUITES)

bench: setup $(BENCH_TARGETS)

firmware: $(FIRMWARE_TARGETS)

clean:
	rm -rf $(BUILD)

check-format:
	@test -x $(VENV)/bin/ruff || $(MAKE) --no-print-directory setup
	@sh scripts/check-format.sh $(VENV)/bin/ruff host/pyproject.toml
