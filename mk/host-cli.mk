# Host CLI (issue 6): the aacmm device commands (info, params, measure,
# compute, log, summary, sim), their end-to-end tests against the real
# simulator over a pty, lint, and the demo's measurement session.
#   test-cli       tests/host/test_cli.py (real `aacmm` command + aacmm-sim), ruff, mypy --strict
#   demo-session   make demo's step: simulator, aacmm log (3 s), summary, Monte Carlo,
#                  outputs under out/demo-<UTC time>/ (path printed)
# The SocketCAN CLI tests (tests/host/vcan_cli) run in the shared vcan VM session.
# (Named host-cli.mk, not cli.mk, so that it is read after mk/demo.mk, which
# sets DEMO_STEPS with :=; fragments are read in name order.)

CLI_PY_FILES := host/src/aacmm/cli.py host/src/aacmm/commands tests/host/test_cli.py \
                tests/host/vcan_cli
CLI_PYTEST   := $(PYTHON) -m pytest -q -p no:cacheprovider -ra -c host/pyproject.toml --rootdir=.

.PHONY: test-cli test-cli-lint demo-session
test-cli: sim $(BUILD)/boards/mps2-an386/fw.elf
	$(CLI_PYTEST) tests/host/test_cli.py
	@$(MAKE) --no-print-directory test-cli-lint

#> test-cli-lint        ruff, ruff format, mypy --strict on the CLI (part of test-cli)
test-cli-lint:
	$(VENV)/bin/ruff check --config host/pyproject.toml $(CLI_PY_FILES)
	$(VENV)/bin/ruff format --check --config host/pyproject.toml $(CLI_PY_FILES)
	$(VENV)/bin/mypy --config-file host/pyproject.toml $(CLI_PY_FILES)

demo-session: sim
	@$(PYTHON) -m aacmm.commands.demo

DEMO_STEPS += demo-session
TEST_SUITES += test-cli

# SocketCAN: aacmm log --raw (.blf/.asc/.log) and --reconnect on vcan0, in
# the shared vcan session (one VM boot; mk/vcan.mk).
VCAN_TESTS += tests/host/vcan_cli
