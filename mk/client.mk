# Host client (issue 5, host half): the aacmm.client API and its transports.
#   test-client        unit tests against an in-process fake device (pyserial
#                      socket:// and python-can's virtual bus), ruff, mypy --strict
#   test-loopback-pty  the client against the real simulator over a pty
# The SocketCAN tests (tests/host/vcan) run in the shared vcan VM session
# (mk/vcan.mk, make test-vcan).

CLIENT_PY_FILES := host/src/aacmm/client host/src/aacmm/transport bench/bench_host_rx.py \
                   tests/host/test_client.py tests/host/test_client_transport.py \
                   tests/host/fakedevice.py
CLIENT_PYTEST   := $(PYTHON) -m pytest -q -p no:cacheprovider -ra --timeout=300

.PHONY: test-client
test-client:
	$(CLIENT_PYTEST) tests/host/test_client.py tests/host/test_client_transport.py
	$(call py_lint,$(CLIENT_PY_FILES))

TEST_SUITES += test-client

# ---- loopback over a pty against the real simulator (builds it first) ----
LOOPBACK_PY_FILES := tests/host/test_loopback_pty.py tests/host/test_loopback_arms.py tests/host/test_loopback_errmodel.py tests/host/simproc.py tests/host/hostref.py \
                     tests/host/streamclock.py tests/device/sim_smoke.py \
                     tests/host/vcan/test_socketcan_client.py

.PHONY: test-loopback-pty
test-loopback-pty: export AACMM_SIM = $(abspath $(SIM_BIN))
test-loopback-pty: sim
	$(CLIENT_PYTEST) -s tests/host/test_loopback_pty.py tests/host/test_loopback_arms.py \
	    tests/host/test_loopback_errmodel.py
	$(call py_lint,$(LOOPBACK_PY_FILES))

TEST_SUITES += test-loopback-pty

# ---- the client over SocketCAN + ISO-TP against the simulator (vcan VM session) ----
VCAN_TESTS += tests/host/vcan
test-vcan-suite: export AACMM_SIM = $(abspath $(SIM_BIN))
test-vcan-suite: sim

# ---- benchmark: the host's receive cost per serial frame (JSON lines) ----
.PHONY: bench-host-rx
bench-host-rx:
	@$(PYTHON) bench/bench_host_rx.py
BENCH_TARGETS += bench-host-rx
