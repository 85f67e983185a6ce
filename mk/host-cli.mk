# Host CLI (issue 6): the aacmm device commands (info, params, measure,
# compute, log, summary, sim), their end-to-end tests against the real
# simulator over a pty, and lint. (make demo's session: mk/demo.mk.)
#   test-cli       tests/host/test_cli.py, test_cli_errmodel.py (real `aacmm` command + aacmm-sim), ruff, mypy --strict
# The SocketCAN CLI tests (tests/host/vcan_cli) run in the shared vcan VM session.

CLI_PY_FILES := host/src/aacmm/cli.py host/src/aacmm/commands tests/host/test_cli.py \
                tests/host/test_cli_errmodel.py \
                tests/host/vcan_cli
CLI_PYTEST   := $(PYTHON) -m pytest -q -p no:cacheprovider -ra -c host/pyproject.toml --rootdir=.

.PHONY: test-cli test-cli-lint
test-cli: sim $(BUILD)/boards/mps2-an386/fw.elf
	$(CLI_PYTEST) tests/host/test_cli.py tests/host/test_cli_errmodel.py
	@$(MAKE) --no-print-directory test-cli-lint

#> test-cli-lint        ruff, ruff format, mypy --strict on the CLI (part of test-cli)
test-cli-lint:
	$(call py_lint,$(CLI_PY_FILES))

TEST_SUITES += test-cli

# SocketCAN: aacmm log --raw (.blf/.asc/.log) and --reconnect on vcan0, in
# the shared vcan session (one VM boot; mk/vcan.mk).
VCAN_TESTS += tests/host/vcan_cli
