# Arm models (issue 26, items 1-2): aacmm.models (the schema aacmm-model-1,
# the shipped model files), `aacmm model`, and their tests (docs/models.md).
#   test-models       tests/host/test_models.py, test_models_cli.py: every shipped
#                     model's point and Jacobian (double, single, fixed point)
#                     against an independent 4x4 / complex-step computation; bad
#                     models; the CLI; the models' plans ([plans], test_models_plans.py)
#                     and whether an arm reaches a plan (check_reach, aacmm plan check
#                     --model: test_plan_reach.py); then ruff, ruff format, mypy --strict

MODELS_PY_FILES := host/src/aacmm/models host/src/aacmm/commands/model.py host/src/aacmm/errors.py \
                   tests/host/test_models.py tests/host/test_models_cli.py \
                   tests/host/test_models_plans.py tests/host/test_plan_reach.py
# The fixed-point path over stdin/stdout for the host tests (a test tool).
MODELS_FIXED_TOOL := $(BUILD)/models/fixed_arm_stdio
MODELS_FIXED_SRCS := $(CORE_SRCS) $(FIXED_SRCS) $(FIXED_CONVERT_SRCS) tests/fixed/fixed_arm_stdio.c

$(MODELS_FIXED_TOOL): $(MODELS_FIXED_SRCS) $(CORE_HDRS) $(FIXED_HDRS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(HOST_OPT) -I$(FW_INC) -Ifirmware/src $(MODELS_FIXED_SRCS) -lm -o $@

.PHONY: test-models test-models-lint models-fixed-tool
#> models-fixed-tool    the fixed-point path over stdin/stdout that test-models drives (a test tool)
models-fixed-tool: $(MODELS_FIXED_TOOL)

test-models: $(MODELS_FIXED_TOOL)
	AACMM_FIXED_ARM_TOOL=$(MODELS_FIXED_TOOL) $(PYTHON) -m pytest -q -p no:cacheprovider \
	    -c host/pyproject.toml --rootdir=. tests/host/test_models.py tests/host/test_models_cli.py \
	    tests/host/test_models_plans.py tests/host/test_plan_reach.py
	@$(MAKE) --no-print-directory test-models-lint

#> test-models-lint     ruff, ruff format, mypy --strict on aacmm.models and its tests (part of test-models)
test-models-lint:
	$(call py_lint,$(MODELS_PY_FILES))

TEST_SUITES += test-models
