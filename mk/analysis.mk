# Monte Carlo error-transfer analysis and uncertainty propagation (host):
# the cffi binding of the core (aacmm._core, built by scripts/setup.sh through
# host/setup.py), the analysis helpers in firmware/src/analysis.c, their tests,
# lint, and the benchmark.

ANALYSIS_PY_FILES := host/setup.py host/src/aacmm/_build_core.py host/src/aacmm/_core.pyi \
                     host/src/aacmm/core.py host/src/aacmm/arm.py host/src/aacmm/analysis host/src/aacmm/uncertainty \
                     tests/host/test_core.py tests/host/test_core_oracle.py \
                     tests/host/test_core_kernels.py tests/host/test_core_encoder.py \
                     tests/host/test_core_arm.py tests/host/test_core_binding.py tests/host/test_mc.py \
                     host/src/aacmm/errmodel.py tests/host/test_core_errmodel.py \
                     tests/host/test_mc_arms.py \
                     tests/host/test_uncertainty.py tests/host/test_analysis_api.py \
                     tests/host/test_uncertainty_arms.py tests/host/test_mc_arms_cli.py \
                     tests/host/test_analysis_model_limits.py \
                     tests/host/interrupt.py tests/host/portability.py \
                     tests/host/test_packaging.py host/src/aacmm/commands/mc.py \
                     host/src/aacmm/commands/uncertainty.py bench/bench_analysis.py
ANALYSIS_C := firmware/src/analysis.c firmware/src/simd/simd_dispatch.c \
              firmware/src/simd/simd_f64.c firmware/src/simd/simd_f32.c

.PHONY: test-analysis test-analysis-scalar test-analysis-c test-analysis-lint bench-analysis

# Python suite: core binding vs numpy oracle, Table 2, adaptive MC, logs,
# uncertainty propagation, CLI.
test-analysis:
	$(PYTHON) -m pytest -q -p no:cacheprovider -c host/pyproject.toml --rootdir=. \
	    tests/host/test_core.py tests/host/test_core_oracle.py tests/host/test_core_kernels.py \
	    tests/host/test_core_encoder.py tests/host/test_core_arm.py tests/host/test_core_binding.py \
	    tests/host/test_core_errmodel.py tests/host/test_mc*.py tests/host/test_analysis_api.py tests/host/test_uncertainty*.py \
	    tests/host/test_analysis_model_limits.py

# The core suite again on the scalar kernel, forced as a user on a CPU without
# the wide kernels would have it (issue 17: the wheel runs without AVX2).
test-analysis-scalar:
	AACMM_KERNEL=scalar $(PYTHON) -m pytest -q -p no:cacheprovider -c host/pyproject.toml \
	    --rootdir=. tests/host/test_core.py tests/host/test_core_oracle.py \
	    tests/host/test_core_encoder.py tests/host/test_core_arm.py tests/host/test_core_errmodel.py

# analysis.c and the batch kernels pass the project's warning set with gcc and
# clang, for this machine and for baseline x86-64 (the wheel's target).
test-analysis-c:
	gcc $(CSTD) $(WARN) $(HOST_OPT) -I$(FW_INC) -fsyntax-only $(ANALYSIS_C)
	clang $(CSTD) $(WARN) $(HOST_OPT) -I$(FW_INC) -fsyntax-only $(ANALYSIS_C)
	gcc $(CSTD) $(WARN) -O2 -I$(FW_INC) -fsyntax-only $(ANALYSIS_C)
	clang $(CSTD) $(WARN) -O2 -I$(FW_INC) -fsyntax-only $(ANALYSIS_C)
	@echo "analysis.c, simd/*.c: clean with gcc and clang"

test-analysis-lint:
	$(call py_lint,$(ANALYSIS_PY_FILES))

TEST_SUITES += test-analysis test-analysis-scalar test-analysis-c test-analysis-lint

bench-analysis:
	@$(PYTHON) bench/bench_analysis.py
BENCH_TARGETS += bench-analysis

# The host package as a user installs it (#14.10): an sdist of host/ alone
# (with the C sources), a wheel built from it far from the repository,
# installed and run; no setuptools warning; sim's messages when pip-installed.
test-packaging:
	$(PYTHON) -m pytest -q -p no:cacheprovider -c host/pyproject.toml --rootdir=. \
	    tests/host/test_packaging.py
.PHONY: test-packaging
TEST_SUITES += test-packaging
