# Host I/O (issue 15 items 2, 3, 9; issue 14 items 2, 4): aacmm.fileio (one
# output-file rule: refuse unless --force, temporary file + fsync + rename;
# TOML/JSON readers with bounded nesting), the CLI's file and argument rules
# end to end against the simulator, the serial port lock, the DBC per CAN node
# (aacmm dbc).
#   test-host-io   those tests, ruff, ruff format, mypy --strict

HOST_IO_PY_FILES := host/src/aacmm/fileio.py tests/host/test_fileio.py tests/host/test_cli_files.py \
                    tests/host/clihelp.py tests/host/test_port_lock.py tests/host/test_dbc.py \
                    host/src/aacmm/commands/dbc.py host/src/aacmm/protocol/can.py \
                    tests/vcan/test_dbc_capture.py

.PHONY: test-host-io
test-host-io: sim
	$(PYTHON) -m pytest -q -p no:cacheprovider -ra -c host/pyproject.toml --rootdir=. \
	    tests/host/test_fileio.py tests/host/test_cli_files.py tests/host/test_port_lock.py \
	    tests/host/test_dbc.py
	$(call py_lint,$(HOST_IO_PY_FILES))

TEST_SUITES += test-host-io

# A real capture decoded with the node's DBC (#14.4): in the shared vcan session.
VCAN_TESTS += tests/vcan/test_dbc_capture.py
