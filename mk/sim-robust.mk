# The simulator under hostile conditions (issue 15, items 7, 8 and 10):
#   test-sim-storage  the storage file: start-up report for every state, stale
#                     FILE.tmp, planted symlink, fsync of file and directory
#                     (tests/host/test_sim_storage.py, strace)

SIM_ROBUST_PY := tests/host/test_sim_storage.py
SIM_ROBUST_PYTEST := $(PYTHON) -m pytest -q -p no:cacheprovider -ra --timeout=300

.PHONY: test-sim-storage
test-sim-storage: export AACMM_SIM = $(abspath $(SIM_BIN))
test-sim-storage: sim | setup
	cd tests/host && ../../$(SIM_ROBUST_PYTEST) $(notdir $(SIM_ROBUST_PY))
	$(VENV)/bin/ruff check --config host/pyproject.toml $(SIM_ROBUST_PY)
	$(VENV)/bin/ruff format --config host/pyproject.toml --check $(SIM_ROBUST_PY)
	$(VENV)/bin/mypy --config-file host/pyproject.toml $(SIM_ROBUST_PY)

TEST_SUITES += test-sim-storage
