# Host file handling (issue 15 items 2, 3, 9): aacmm.fileio (one output-file
# rule: refuse unless --force, temporary file + fsync + rename; TOML/JSON
# readers with bounded nesting) and the CLI's file and argument rules end to
# end against the simulator.
#   test-host-io   tests/host/test_fileio.py, tests/host/test_cli_files.py, ruff, mypy --strict

HOST_IO_PY_FILES := host/src/aacmm/fileio.py tests/host/test_fileio.py tests/host/test_cli_files.py \
                    tests/host/clihelp.py \
                    tests/host/test_port_lock.py

.PHONY: test-host-io
test-host-io: sim
	$(PYTHON) -m pytest -q -p no:cacheprovider -ra -c host/pyproject.toml --rootdir=. \
	    tests/host/test_fileio.py tests/host/test_cli_files.py tests/host/test_port_lock.py
	$(VENV)/bin/ruff check --config host/pyproject.toml $(HOST_IO_PY_FILES)
	$(VENV)/bin/ruff format --check --config host/pyproject.toml $(HOST_IO_PY_FILES)
	$(VENV)/bin/mypy --config-file host/pyproject.toml $(HOST_IO_PY_FILES)

TEST_SUITES += test-host-io
