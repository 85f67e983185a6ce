# The project's tooling (issue 14 item 7): `make help` lists every target,
# `make test`'s runner (scripts/run-suites.sh: one line per suite, logs under
# build/test-logs/), `make check-format`, and the format check of the whole tree;
# the host package's import structure (issue 25, tests/tooling/test_host_imports.py
# on tests/tooling/hostimports.py): no re-export-only module, no library importing
# aacmm.commands, no import cycle between modules or packages.

TOOLING_PY_FILES := tests/tooling

.PHONY: test-tooling
test-tooling:
	$(PYTHON) -m pytest -q -p no:cacheprovider -ra -c host/pyproject.toml --rootdir=. tests/tooling
	$(VENV)/bin/ruff check --config host/pyproject.toml $(TOOLING_PY_FILES)
	$(VENV)/bin/mypy --config-file host/pyproject.toml $(TOOLING_PY_FILES)

TEST_SUITES += test-tooling
