# Device application (firmware/src/device), portable simulated arm
# (firmware/src/sim), the POSIX simulator aacmm-sim (firmware/ports/posix),
# and their CMocka suites (gcc, clang, ASan+UBSan) plus a smoke test of the
# real binary. See docs/architecture.md and docs/simulator.md.

# The protocol codec's sources (the protocol fragment may name them too; a
# wildcard keeps this fragment independent of its variable names).
DEV_PROTO_SRCS := $(sort $(wildcard firmware/src/protocol/*.c))
DEV_CORE_SRCS  := firmware/src/status.c firmware/src/encoder.c firmware/src/shape.c \
                  firmware/src/kinematics_f32.c \
                  firmware/src/kinematics_f64.c firmware/src/encoder_frame.c

# Kinematics backend of the device: f32 (float core, default) or q (the
# fixed-point core, -DAACMM_DEVICE_KIN_FIXED), e.g. `make sim DEVICE_KIN=q`.
# The q build goes to its own directories (build/sim-q, build/device-q).
DEVICE_KIN    ?= f32
DEV_Q_CORE    := firmware/src/kinematics_q.c firmware/src/fixed_sincos.c \
                 firmware/src/kinematics_q_convert.c
DEV_KIN_SRCS  := firmware/src/device/device_kin_$(DEVICE_KIN).c \
                 $(if $(filter q,$(DEVICE_KIN)),$(DEV_Q_CORE))
DEV_KIN_FLAGS := $(if $(filter q,$(DEVICE_KIN)),-DAACMM_DEVICE_KIN_FIXED)
DEV_SUFFIX    := $(if $(filter q,$(DEVICE_KIN)),-q)

DEVICE_SRCS := firmware/src/device/device.c firmware/src/device/param_store.c $(DEV_KIN_SRCS)
SIM_SRCS    := firmware/src/sim/sim_motion.c firmware/src/sim/sim_encoder.c
POSIX_SRCS  := firmware/ports/posix/sim_main.c firmware/ports/posix/posix_port.c \
               firmware/ports/posix/sim_control.c firmware/ports/posix/replay_file.c

DEV_ALL_SRCS := $(DEVICE_SRCS) $(SIM_SRCS) $(DEV_CORE_SRCS) $(DEV_PROTO_SRCS)
DEV_HDRS := $(wildcard firmware/include/aacmm/*.h) $(wildcard firmware/src/*.h) \
            $(wildcard firmware/src/device/*.h) \
            firmware/src/device/device_kin.h firmware/src/sim/aacmm_sim.h \
            firmware/ports/posix/posix_port.h firmware/ports/posix/sim_control.h \
            firmware/ports/posix/replay_file.h
DEV_INC  := -I$(FW_INC) -Ifirmware/src/device -Ifirmware/src/sim

# ---- the simulator -------------------------------------------------------
# SAN=1: the same simulator with AddressSanitizer + UndefinedBehaviorSanitizer
# (clang, aborts on the first report), in build/sim-san/ (build/sim-q-san/
# with DEVICE_KIN=q); every target that runs $(SIM_BIN) then uses it.
SAN     ?= 0
SIM_SAN := $(filter 1,$(SAN))
SIM_BIN := $(BUILD)/sim$(DEV_SUFFIX)$(if $(SIM_SAN),-san)/aacmm-sim

$(SIM_BIN): $(DEV_ALL_SRCS) $(POSIX_SRCS) $(DEV_HDRS) | $(BUILD)
	@mkdir -p $(@D)
	$(if $(SIM_SAN),clang,gcc) $(CSTD) $(WARN) $(if $(SIM_SAN),$(SAN_FLAGS),$(HOST_OPT)) \
	    $(DEV_KIN_FLAGS) $(DEV_INC) -Ifirmware/ports/posix $(DEV_ALL_SRCS) $(POSIX_SRCS) -lm -o $@

# The same with clang, only to keep the port warning-free there too.
$(BUILD)/sim$(DEV_SUFFIX)/aacmm-sim-clang: $(DEV_ALL_SRCS) $(POSIX_SRCS) $(DEV_HDRS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(HOST_OPT) $(DEV_KIN_FLAGS) $(DEV_INC) -Ifirmware/ports/posix \
	    $(DEV_ALL_SRCS) $(POSIX_SRCS) -lm -o $@

#> sim                  the POSIX device simulator build/sim/aacmm-sim (DEVICE_KIN=q: fixed-point build; SAN=1: ASan+UBSan build)
.PHONY: sim
sim: $(SIM_BIN)

# ---- CMocka suites -------------------------------------------------------
DEV_TEST_SRCS := tests/device/test_device.c tests/device/fake_platform.c
DEV_TEST_DEPS := $(DEV_ALL_SRCS) $(DEV_HDRS) $(DEV_TEST_SRCS) tests/device/fake_platform.h

$(BUILD)/device/test_device_gcc: $(DEV_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(HOST_OPT) $(DEV_KIN_FLAGS) $(DEV_INC) -Itests/device \
	    $(DEV_ALL_SRCS) $(DEV_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
$(BUILD)/device/test_device_clang: $(DEV_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(HOST_OPT) $(DEV_KIN_FLAGS) $(DEV_INC) -Itests/device \
	    $(DEV_ALL_SRCS) $(DEV_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
$(BUILD)/device/test_device_san: $(DEV_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(SAN_FLAGS) $(DEV_KIN_FLAGS) $(DEV_INC) -Itests/device \
	    $(DEV_ALL_SRCS) $(DEV_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@

# The same suite on the fixed-point backend (whatever DEVICE_KIN says).
DEV_Q_ALL_SRCS := firmware/src/device/device.c firmware/src/device/param_store.c \
                  firmware/src/device/device_kin_q.c $(DEV_Q_CORE) $(SIM_SRCS) $(DEV_CORE_SRCS) \
                  $(DEV_PROTO_SRCS)
$(BUILD)/device/test_device_q: $(DEV_Q_ALL_SRCS) $(DEV_HDRS) $(DEV_TEST_SRCS) tests/device/fake_platform.h | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(SAN_FLAGS) -DAACMM_DEVICE_KIN_FIXED $(DEV_INC) -Itests/device \
	    $(DEV_Q_ALL_SRCS) $(DEV_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@

.PHONY: test-device-gcc test-device-clang test-device-san test-device-q test-device-sim test-device-m4f
test-device-gcc: $(BUILD)/device/test_device_gcc
	$<
test-device-clang: $(BUILD)/device/test_device_clang
	$<
test-device-san: $(BUILD)/device/test_device_san
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 $<
test-device-q: $(BUILD)/device/test_device_q
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 $<

# The real binary: arguments, exit codes, stdout lines, a ping and a 1 kHz
# stream over the pty (tests/device/sim_smoke.py, standard library only);
# link temperatures (--temperature, --no-temperature-sensors, the control
# channel's temps, the thermal block's points: tests/device/sim_temps.py) on
# both kinematics backends.
test-device-sim: $(SIM_BIN) $(BUILD)/sim$(DEV_SUFFIX)/aacmm-sim-clang
	/usr/bin/python3 tests/device/sim_smoke.py $(SIM_BIN)
	/usr/bin/python3 tests/device/sim_temps.py $(SIM_BIN)
	@$(MAKE) --no-print-directory sim DEVICE_KIN=$(if $(filter q,$(DEVICE_KIN)),f32,q) SAN=$(SAN)
	/usr/bin/python3 tests/device/sim_temps.py \
	    $(BUILD)/sim$(if $(filter q,$(DEVICE_KIN)),,-q)$(if $(SIM_SAN),-san)/aacmm-sim

# The simulator's replay-file parser against hostile files (malformed lines,
# huge values, NaN, long lines, NUL bytes, empty and missing files): gcc, and
# clang under ASan+UBSan.
REPLAY_TEST_DEPS := tests/device/test_replay_file.c firmware/ports/posix/replay_file.c \
                    firmware/ports/posix/replay_file.h firmware/include/aacmm/kinematics.h
$(BUILD)/device/test_replay_file_gcc: $(REPLAY_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(HOST_OPT) -I$(FW_INC) -Ifirmware/ports/posix \
	    tests/device/test_replay_file.c firmware/ports/posix/replay_file.c $(CMOCKA_LIBS) -o $@
$(BUILD)/device/test_replay_file_san: $(REPLAY_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(SAN_FLAGS) -I$(FW_INC) -Ifirmware/ports/posix \
	    tests/device/test_replay_file.c firmware/ports/posix/replay_file.c $(CMOCKA_LIBS) -o $@
.PHONY: test-device-replay
test-device-replay: $(BUILD)/device/test_replay_file_gcc $(BUILD)/device/test_replay_file_san
	$(BUILD)/device/test_replay_file_gcc
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
	    $(BUILD)/device/test_replay_file_san

TEST_SUITES += test-device-gcc test-device-clang test-device-san test-device-q test-device-sim \
               test-device-m4f test-device-replay

# ---- portability: the device application and the simulated arm compile for
# Cortex-M4F (float core) and Cortex-M0+ with the ARM toolchain, warning-free,
# without POSIX or stdio.
DEV_ARM_DIR := $(BUILD)/arm-m4f/device
DEV_ARM_SRCS := $(DEVICE_SRCS) $(SIM_SRCS) firmware/src/encoder_frame.c
DEV_M4F_OBJS := $(patsubst firmware/src/%.c,$(DEV_ARM_DIR)/%.o,$(DEV_ARM_SRCS))
DEV_M0_DIR := $(BUILD)/arm-m0/device
DEV_M0_OBJS := $(patsubst firmware/src/%.c,$(DEV_M0_DIR)/%.o,$(DEV_ARM_SRCS))

DEV_M0Q_DIR := $(BUILD)/arm-m0/device-q
DEV_M0Q_OBJS := $(patsubst firmware/src/%.c,$(DEV_M0Q_DIR)/%.o,firmware/src/device/device.c \
                firmware/src/device/param_store.c firmware/src/device/device_kin_q.c)

$(DEV_M0Q_DIR)/%.o: firmware/src/%.c $(DEV_HDRS)
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M0P_FLAGS) -DAACMM_DEVICE_KIN_FIXED $(DEV_INC) -c $< -o $@
$(DEV_ARM_DIR)/%.o: firmware/src/%.c $(DEV_HDRS)
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M4F_FLAGS) $(DEV_INC) -c $< -o $@
$(DEV_M0_DIR)/%.o: firmware/src/%.c $(DEV_HDRS)
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M0P_FLAGS) $(DEV_INC) -c $< -o $@

test-device-m4f: $(DEV_M4F_OBJS) $(DEV_M0_OBJS) $(DEV_M0Q_OBJS)
	sh scripts/check-symbols.sh m4f-float $(DEV_ARM_DIR)/sim/sim_motion.o
	@for o in $(DEV_M4F_OBJS) $(DEV_M0_OBJS) $(DEV_M0Q_OBJS); do \
	    if $(ARM_NM) -u $$o | grep -Eq ' (malloc|free|calloc|realloc|printf|fprintf|puts|fopen|open|read|write|clock_gettime)$$'; then \
	        echo "$$o uses heap, stdio or POSIX:"; $(ARM_NM) -u $$o; exit 1; fi; done
	@echo "device + sim: build for Cortex-M4F (float core) and Cortex-M0+ (float and fixed-point backends), no heap/stdio/POSIX; sim_motion.o float-only on the M4F"

# ---- CAN side of the simulator on vcan0 (in the shared vcan session, see
# mk/vcan.mk): ISO-TP requests, periodic sample frames, trigger frames.
VCAN_TESTS += tests/device/test_sim_vcan.py
test-vcan-suite: $(SIM_BIN)

# Code size of the device application and the simulated arm on the two cores.
.PHONY: firmware-device
firmware-device: $(DEV_M4F_OBJS) $(DEV_M0Q_OBJS)
	@echo "device application + simulated arm, Cortex-M4F (float backend):"
	@$(ARM_SIZE) -t $(DEV_M4F_OBJS)
	@echo "device application, Cortex-M0+ (fixed-point backend):"
	@$(ARM_SIZE) -t $(DEV_M0Q_OBJS)
FIRMWARE_TARGETS += firmware-device
