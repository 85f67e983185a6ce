# The simulated arm with a truth of its own and the simulated operator
# (issue 11 items 3-4), the simulator's control channel, the second button and
# the trigger-sample rule (issue 14 item 5), replay of aacmm logs (item 6).
# See docs/simulator.md. The CAN half of the trigger rule and aacmm capture
# against the simulated operator over CAN run in the shared vcan session
# (tests/sim/vcan).

SIMULATION_PY_FILES := host/src/aacmm/simulation host/src/aacmm/commands/simtruth.py tests/sim
SIMULATION_PYTEST   := $(PYTHON) -m pytest -q -p no:cacheprovider -ra --timeout=300 \
                       -c host/pyproject.toml --rootdir=.

# The simulator's own motion (firmware/src/sim/sim_motion.c) as a test-only
# shared library: tests/sim/test_sim_model_motion.py reads every pose of
# sweep, walk and static inside an arm model's joint limits (--joint-limits).
SIM_MOTION_LIB_SRCS := firmware/src/sim/sim_motion.c firmware/src/kinematics_f32.c \
                       firmware/src/kinematics_f64.c firmware/src/shape.c firmware/src/status.c \
                       firmware/src/encoder.c
SIM_MOTION_LIB      := $(BUILD)/sim/libaacmm_sim_motion.so

$(SIM_MOTION_LIB): $(SIM_MOTION_LIB_SRCS) firmware/src/sim/aacmm_sim.h $(wildcard $(FW_INC)/aacmm/*.h) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) -O2 -fPIC -shared -I$(FW_INC) -Ifirmware/src/sim $(SIM_MOTION_LIB_SRCS) -lm -o $@

.PHONY: sim-motion-lib
#> sim-motion-lib       the test-only library of the simulator's motion (tests/sim/test_sim_model_motion.py)
sim-motion-lib: $(SIM_MOTION_LIB)

.PHONY: test-sim-control test-simulation test-simulation-lint
#> test-sim-control     aacmm-sim --control with the host client: counts, buttons, temps (link temperatures in the sample, the thermal point, TEMP_FAULT), barriers, stream events, the trigger rule on serial, both buttons, replay of an aacmm log (the paper's arm; microscribe5 and commercial7 through aacmm sim --model: the same counts on every joint, a log of another joint count refused)
test-sim-control: export AACMM_SIM = $(abspath $(SIM_BIN))
test-sim-control: sim
	$(SIMULATION_PYTEST) tests/sim/test_sim_control.py
	@$(MAKE) --no-print-directory test-simulation-lint

#> test-simulation      truth model and file, encoder model vs the core, encoder grades (the simulator's counts = the truth file's harmonics; documented ranges; two-head = the truth of before), thermal profiles (the true point at link temperatures = the scaled arm; the operator's poses on the warm arm, the control channel's temps), IK to 1 nm, articulation spread; aacmm sim --scenario against aacmm capture (nominal and random truths, mis-probe + undo, kill -9 + resume, rendezvous); aacmm sim --model (7- and 5-axis on a pty, random truths within the joint limits, params files of any arm; the simulator's own motion within every model's limits, aacmm-sim --joint-limits)
test-simulation: export AACMM_SIM = $(abspath $(SIM_BIN))
test-simulation: export AACMM_SIM_MOTION_LIB = $(abspath $(SIM_MOTION_LIB))
test-simulation: sim $(SIM_MOTION_LIB)
	$(SIMULATION_PYTEST) tests/sim/test_truth_ik.py tests/sim/test_encoder_grades.py tests/sim/test_thermal_truth.py \
	    tests/sim/test_sim_temperatures.py \
	    tests/sim/test_scenario.py tests/sim/test_sim_models.py tests/sim/test_sim_model_motion.py

#> test-simulation-lint ruff, ruff format, mypy --strict on aacmm.simulation and its tests (part of test-sim-control)
test-simulation-lint:
	$(VENV)/bin/ruff check --config host/pyproject.toml $(SIMULATION_PY_FILES)
	$(VENV)/bin/ruff format --check --config host/pyproject.toml $(SIMULATION_PY_FILES)
	MYPYPATH=tests/sim $(VENV)/bin/mypy --config-file host/pyproject.toml host/src/aacmm/simulation \
	    host/src/aacmm/commands/simtruth.py $(wildcard tests/sim/*.py)
	MYPYPATH=tests/sim:tests/host $(VENV)/bin/mypy --config-file host/pyproject.toml tests/sim/vcan

TEST_SUITES += test-sim-control test-simulation

VCAN_TESTS += tests/sim/vcan
