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

help:
	@echo "aacmm make targets:"
	@echo "  make demo      the main job: build, run, print results (does all set-up)"
	@echo "  make test      every test suite (does all set-up); ends with a pass/fail line"
	@echo "  make bench     benchmarks, one JSON object per line on stdout"
	@echo "  make firmware  cross builds for the ARM targets"
	@echo "  make setup     Debian packages and the Python venv only"
	@echo "  make clean     remove build outputs"
	@echo "test suites: $(TEST_SUITES)"

setup:
	@sh scripts/setup.sh

# Suites run one after another; a failing suite does not hide the others.
test: setup
	@sh scripts/run-suites.sh $(TEST_SUITES)

bench: setup $(BENCH_TARGETS)

firmware: $(FIRMWARE_TARGETS)

clean:
	rm -rf $(BUILD)
