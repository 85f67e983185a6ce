# SocketCAN tests on a virtual CAN interface (vcan0), see docs/testing-vcan.md.
#
# tests/vcan/run-in-vcan.sh runs a command with vcan0 up: natively when the
# host kernel has vcan, else in one QEMU/TCG VM (~6 s boot) that sees the
# host's root over 9p. All vcan tests share ONE runner call (one VM boot):
# other fragments add their pytest paths or node ids with
#     VCAN_TESTS += tests/host/test_socketcan_client.py
# (use +=, never :=, the fragments are read in name order). Their tests then
# run in the same pytest session, with AACMM_VCAN set and vcan0 up.

VCAN_RUN        := tests/vcan/run-in-vcan.sh
VCAN_TESTS      += tests/vcan
VCAN_PYTEST_ARGS ?=
VCAN_PYTEST      = $(PYTHON) -m pytest -c tests/vcan/pytest.ini --rootdir=. -q $(VCAN_PYTEST_ARGS)

.PHONY: test-vcan test-vcan-suite test-vcan-runner
# Both halves run even if the first fails; the target fails if either did.
test-vcan:
	@rc=0; $(MAKE) --no-print-directory test-vcan-suite || rc=1; \
	$(MAKE) --no-print-directory test-vcan-runner || rc=1; exit $$rc

#> test-vcan-suite      the SocketCAN tests of every area in one vcan session (part of test-vcan)
# The vcan test session (smoke tests + whatever VCAN_TESTS gained).
test-vcan-suite:
	@test -x $(PYTHON) || { echo "test-vcan: no $(PYTHON); run 'make setup' first" >&2; exit 1; }
	$(VCAN_RUN) $(VCAN_PYTEST) $(VCAN_TESTS)

#> test-vcan-runner     the vcan runner's own tests on the host (part of test-vcan)
# The runner's own tests on the host: exit status, output, timeout, Ctrl-C.
test-vcan-runner:
	@test -x $(PYTHON) || { echo "test-vcan: no $(PYTHON); run 'make setup' first" >&2; exit 1; }
	$(VCAN_PYTEST) tests/vcan/test_runner.py

TEST_SUITES += test-vcan
TEST_ALONE  += test-vcan
