# The simulator under hostile conditions (issue 15, items 7, 8 and 10):
#   tests/host/test_sim_storage.py  the storage file: start-up report for every
#       state, stale FILE.tmp, planted symlink, fsync of file and directory (strace)
#   tests/host/test_sim_latency.py  a request after a host stall is answered
#       behind the frame in progress, not the queue of stale samples
#   tests/host/test_sim_hostile.py  the ASan+UBSan builds (make sim SAN=1, both
#       kinematics backends) fed hostile link input, hostile storage files and
#       hostile `temps` lines on the control channel

SIM_ROBUST_PY := tests/host/test_sim_storage.py tests/host/test_sim_latency.py \
                 tests/host/test_sim_hostile.py
SIM_ROBUST_PYTEST := $(PYTHON) -m pytest -q -p no:cacheprovider -ra --timeout=300

.PHONY: test-sim-robust sim-san
#> sim-san              the ASan+UBSan simulators of both backends (build/sim-san, build/sim-q-san)
sim-san:
	@$(MAKE) --no-print-directory sim SAN=1 DEVICE_KIN=f32
	@$(MAKE) --no-print-directory sim SAN=1 DEVICE_KIN=q

test-sim-robust: export AACMM_SIM = $(abspath $(SIM_BIN))
test-sim-robust: export AACMM_SIM_SAN = $(abspath $(BUILD)/sim-san/aacmm-sim)
test-sim-robust: export AACMM_SIM_SAN_Q = $(abspath $(BUILD)/sim-q-san/aacmm-sim)
test-sim-robust: sim sim-san | setup
	cd tests/host && ../../$(SIM_ROBUST_PYTEST) $(notdir $(SIM_ROBUST_PY))
	$(call py_lint,$(SIM_ROBUST_PY))

TEST_SUITES += test-sim-robust
