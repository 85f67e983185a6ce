# Board ports (firmware/boards/): Cortex-M4F (QEMU mps2-an386) and Cortex-M0
# (BBC micro:bit, nRF51) images, run under qemu-system-arm. See docs/boards.md.
#
# Per board, under build/boards/<board>/:
#   fw.elf        the device application (firmware/src/device) on the board:
#                 UART link, board clock, the simulated arm's joints as BiSS-C
#                 frames, parameters in flash (micro:bit) or retained RAM
#                 (mps2-an386), watchdog, reset cause
#   fw-test.elf   the same with test hooks (cut saves, hang, fault, corrupt
#                 frames on request: tests/boards/test_board_resets.py)
#   fw.bin        the same as a raw image from address 0 (for flashing)
#   fw.hex        the same in Intel hex (micro:bit drag-and-drop, pyOCD, ...)
#   echo.elf      boot check: banner, UART echo, clock
#   selftest.elf  semihosting self-test: golden vectors + instruction counts
#   selftest-canary.elf  the same with its checks rigged to fail (must fail)
#
#   make firmware-boards          build them, print size and worst-case stack
#   make test-boards-selftest     run the self-tests (exit status via semihosting)
#   make test-boards-boot         boot + UART + clock check over the emulated UART
#   make bench-boards             instructions per point + Jacobian (JSON lines)

BOARDS       := mps2-an386 microbit
BOARD_OUT    := $(BUILD)/boards
BOARD_COMMON := firmware/boards/common
QEMU_ARM     := qemu-system-arm

BOARD_FLAGS_mps2-an386 := $(M4F_FLAGS)
BOARD_FLAGS_microbit   := -mcpu=cortex-m0 -mthumb -mfloat-abi=soft

# Kinematics in the self-test images: the float core everywhere; the
# fixed-point core too. The board's own path ("primary": what its device
# image uses) is float on the M4F, fixed on the M0.
BOARD_KIN_F32 := firmware/src/status.c firmware/src/encoder.c firmware/src/shape.c \
                 firmware/src/kinematics_f32.c
BOARD_KIN_Q   := firmware/src/kinematics_q.c firmware/src/fixed_sincos.c
BOARD_DEFS_mps2-an386 := -DSELFTEST_F32 -DSELFTEST_Q -DBOARD_KIN_PRIMARY='"f32"'
BOARD_DEFS_microbit   := -DSELFTEST_F32 -DSELFTEST_Q -DBOARD_KIN_PRIMARY='"q"'

# Buffers: the micro:bit has 16 KiB of RAM for the ~7 KiB device state, the
# device's serial output queue, the UART rings, the storage and the stack.
# (The defaults, which the MPS2 uses: UART rings 1 KiB RX + 2 KiB TX
# (common/uart.c), a 4 KiB serial queue (common/device_main.c).)
BOARD_DEFS_microbit += -DBOARD_UART_RX_BYTES=256u -DBOARD_UART_TX_BYTES=256u \
                       -DBOARD_SERIAL_TXQ_BYTES=2048u
# The device application with its kinematics backend (as mk/device.mk).
BOARD_DEVICE_SRCS := firmware/src/device/device.c firmware/src/device/param_store.c \
                     firmware/src/sim/sim_motion.c firmware/src/sim/sim_encoder.c \
                     $(sort $(wildcard firmware/src/protocol/*.c)) \
                     firmware/src/status.c firmware/src/encoder.c firmware/src/shape.c \
                     firmware/src/kinematics_f32.c \
                     firmware/src/kinematics_f64.c firmware/src/encoder_frame.c \
                     $(BOARD_COMMON)/device_main.c
BOARD_DEVKIN_mps2-an386 := firmware/src/device/device_kin_f32.c
BOARD_DEVKIN_microbit   := firmware/src/device/device_kin_q.c $(BOARD_KIN_Q) \
                           firmware/src/kinematics_q_convert.c
BOARD_DEVFLAGS_microbit := -DAACMM_DEVICE_KIN_FIXED

# (and -Ifirmware/boards/<board>: its uart_hw.h, which common/uart.c includes)
BOARD_CFLAGS  = $(ARM_CFLAGS) -fcallgraph-info=su -I$(BOARD_COMMON) -Ifirmware/src \
                -Ifirmware/src/device -Ifirmware/src/sim -I$(BOARD_OUT)
BOARD_LDFLAGS := -nostartfiles -Wl,--gc-sections -L$(BOARD_COMMON)
BOARD_HDRS := $(wildcard $(BOARD_COMMON)/*.h) $(wildcard firmware/include/aacmm/*.h) \
              $(wildcard firmware/src/*.h) $(BOARD_COMMON)/sections.ld

# Golden vectors from the host's double-precision core (needs the venv).
$(BOARD_OUT)/golden.h: tests/boards/gen_golden.py firmware/src/kinematics_f64.c firmware/src/kinematics_impl.h | setup
	@mkdir -p $(@D)
	$(PYTHON) tests/boards/gen_golden.py $@

# obj/<source path>.o per board; -fcallgraph-info leaves <obj>.ci beside it.
define BOARD_RULES
$(BOARD_OUT)/$(1)/obj/%.o: %.c $(BOARD_HDRS) $(wildcard firmware/boards/$(1)/*.h)
	@mkdir -p $$(@D)
	$(ARM_CC) $(BOARD_CFLAGS) -Ifirmware/boards/$(1) $(BOARD_FLAGS_$(1)) $(BOARD_DEFS_$(1)) -c $$< -o $$@

$(BOARD_OUT)/$(1)/obj/$(BOARD_COMMON)/selftest.o: $(BOARD_OUT)/golden.h

# The device image's objects get the backend switch too (own directory).
$(BOARD_OUT)/$(1)/dev/%.o: %.c $(BOARD_HDRS) $(wildcard firmware/boards/$(1)/*.h) \
        $(wildcard firmware/src/device/*.h firmware/src/sim/*.h)
	@mkdir -p $$(@D)
	$(ARM_CC) $(BOARD_CFLAGS) -Ifirmware/boards/$(1) $(BOARD_FLAGS_$(1)) $(BOARD_DEFS_$(1)) $(BOARD_DEVFLAGS_$(1)) -c $$< -o $$@

BOARD_FW_OBJS_$(1) := $$(patsubst %.c,$(BOARD_OUT)/$(1)/dev/%.o,$(BOARD_COMMON)/startup.c \
                        $(BOARD_COMMON)/uart.c firmware/boards/$(1)/board.c $(BOARD_DEVICE_SRCS) \
                        $(BOARD_DEVKIN_$(1)))

$(BOARD_OUT)/$(1)/fw.elf: $$(BOARD_FW_OBJS_$(1)) firmware/boards/$(1)/memory.ld $(BOARD_COMMON)/sections.ld
	$(ARM_CC) $(BOARD_FLAGS_$(1)) $(BOARD_LDFLAGS) --specs=nano.specs --specs=nosys.specs \
	    -Tfirmware/boards/$(1)/memory.ld -Wl,-Map=$$@.map $$(BOARD_FW_OBJS_$(1)) -o $$@

# fw-test.elf: the same image with the test hooks (device_main.c,
# BOARD_TEST_HOOKS): flash cuts, hang, fault, encoder corruption on request.
$(BOARD_OUT)/$(1)/devtest/$(BOARD_COMMON)/device_main.o: $(BOARD_COMMON)/device_main.c $(BOARD_HDRS) \
        $(wildcard firmware/src/device/*.h firmware/src/sim/*.h)
	@mkdir -p $$(@D)
	$(ARM_CC) $(BOARD_CFLAGS) -Ifirmware/boards/$(1) $(BOARD_FLAGS_$(1)) $(BOARD_DEFS_$(1)) $(BOARD_DEVFLAGS_$(1)) \
	    -DBOARD_TEST_HOOKS -c $$< -o $$@
BOARD_TEST_OBJS_$(1) := $$(filter-out %/common/device_main.o,$$(BOARD_FW_OBJS_$(1))) \
                        $(BOARD_OUT)/$(1)/devtest/$(BOARD_COMMON)/device_main.o
$(BOARD_OUT)/$(1)/fw-test.elf: $$(BOARD_TEST_OBJS_$(1)) firmware/boards/$(1)/memory.ld $(BOARD_COMMON)/sections.ld
	$(ARM_CC) $(BOARD_FLAGS_$(1)) $(BOARD_LDFLAGS) --specs=nano.specs --specs=nosys.specs \
	    -Tfirmware/boards/$(1)/memory.ld $$(BOARD_TEST_OBJS_$(1)) -o $$@

$(BOARD_OUT)/$(1)/fw.bin: $(BOARD_OUT)/$(1)/fw.elf
	arm-none-eabi-objcopy -O binary $$< $$@
$(BOARD_OUT)/$(1)/fw.hex: $(BOARD_OUT)/$(1)/fw.elf
	arm-none-eabi-objcopy -O ihex $$< $$@


BOARD_BASE_OBJS_$(1) := $(BOARD_OUT)/$(1)/obj/$(BOARD_COMMON)/startup.o \
                        $(BOARD_OUT)/$(1)/obj/$(BOARD_COMMON)/uart.o \
                        $(BOARD_OUT)/$(1)/obj/firmware/boards/$(1)/board.o
BOARD_ECHO_OBJS_$(1) := $$(BOARD_BASE_OBJS_$(1)) $(BOARD_OUT)/$(1)/obj/$(BOARD_COMMON)/echo_main.o
BOARD_SELF_OBJS_$(1) := $$(BOARD_BASE_OBJS_$(1)) $(BOARD_OUT)/$(1)/obj/$(BOARD_COMMON)/selftest.o \
                        $$(patsubst %.c,$(BOARD_OUT)/$(1)/obj/%.o,$(BOARD_KIN_F32) $(BOARD_KIN_Q))

$(BOARD_OUT)/$(1)/echo.elf: $$(BOARD_ECHO_OBJS_$(1)) firmware/boards/$(1)/memory.ld $(BOARD_COMMON)/sections.ld
	$(ARM_CC) $(BOARD_FLAGS_$(1)) $(BOARD_LDFLAGS) --specs=nano.specs --specs=nosys.specs \
	    -Tfirmware/boards/$(1)/memory.ld -Wl,-Map=$$@.map $$(BOARD_ECHO_OBJS_$(1)) -o $$@

$(BOARD_OUT)/$(1)/selftest.elf: $$(BOARD_SELF_OBJS_$(1)) firmware/boards/$(1)/memory.ld $(BOARD_COMMON)/sections.ld
	$(ARM_CC) $(BOARD_FLAGS_$(1)) $(BOARD_LDFLAGS) --specs=nano.specs --specs=rdimon.specs \
	    -Tfirmware/boards/$(1)/memory.ld -Wl,-Map=$$@.map $$(BOARD_SELF_OBJS_$(1)) -o $$@

$(BOARD_OUT)/$(1)/canary/selftest.o: $(BOARD_COMMON)/selftest.c $(BOARD_OUT)/golden.h $(BOARD_HDRS)
	@mkdir -p $$(@D)
	$(ARM_CC) $(BOARD_CFLAGS) -Ifirmware/boards/$(1) $(BOARD_FLAGS_$(1)) $(BOARD_DEFS_$(1)) -DSELFTEST_CANARY -c $$< -o $$@
$(BOARD_OUT)/$(1)/selftest-canary.elf: $$(BOARD_SELF_OBJS_$(1)) $(BOARD_OUT)/$(1)/canary/selftest.o
	$(ARM_CC) $(BOARD_FLAGS_$(1)) $(BOARD_LDFLAGS) --specs=nano.specs --specs=rdimon.specs \
	    -Tfirmware/boards/$(1)/memory.ld \
	    $$(filter-out %/common/selftest.o,$$(BOARD_SELF_OBJS_$(1))) $(BOARD_OUT)/$(1)/canary/selftest.o -o $$@
endef
$(foreach b,$(BOARDS),$(eval $(call BOARD_RULES,$(b))))

BOARD_FW_ELFS   := $(foreach b,$(BOARDS),$(BOARD_OUT)/$(b)/fw.elf)
BOARD_TEST_ELFS := $(foreach b,$(BOARDS),$(BOARD_OUT)/$(b)/fw-test.elf)
BOARD_FW_BINS   := $(foreach b,$(BOARDS),$(BOARD_OUT)/$(b)/fw.bin $(BOARD_OUT)/$(b)/fw.hex)
BOARD_CANARY_ELFS := $(foreach b,$(BOARDS),$(BOARD_OUT)/$(b)/selftest-canary.elf)
BOARD_ECHO_ELFS := $(foreach b,$(BOARDS),$(BOARD_OUT)/$(b)/echo.elf)
BOARD_SELF_ELFS := $(foreach b,$(BOARDS),$(BOARD_OUT)/$(b)/selftest.elf)

# Limits for the size report: flash, RAM, and the stack each linker script
# reserves (memory.ld).
BOARD_LIMITS_mps2-an386 := 4096 4194304 4194304
BOARD_LIMITS_microbit   := 4096 260096 16384  # flash: 254 KiB, the last 2 pages hold the parameters

.PHONY: firmware-boards test-boards-selftest test-boards-boot test-boards-loopback test-boards-resets \
        bench-boards \
        run-mps2-an386 run-microbit
firmware-boards: $(BOARD_FW_ELFS) $(BOARD_FW_BINS) $(BOARD_ECHO_ELFS) $(BOARD_SELF_ELFS) $(BOARD_TEST_ELFS)
	@for b in $(BOARDS); do \
	  case $$b in mps2-an386) lim="$(BOARD_LIMITS_mps2-an386)";; microbit) lim="$(BOARD_LIMITS_microbit)";; esac; \
	  echo "board $$b: device image (build/boards/$$b/fw.elf, fw.bin):"; \
	  /usr/bin/python3 firmware/boards/fw_report.py $$b $(BOARD_OUT)/$$b/fw.elf $(BOARD_OUT)/$$b/dev $$lim || exit 1; \
	  echo "board $$b: boot check and self-test images:"; \
	  $(ARM_SIZE) $(BOARD_OUT)/$$b/echo.elf $(BOARD_OUT)/$$b/selftest.elf | sed "s/^/  /"; \
	done
FIRMWARE_TARGETS += firmware-boards

TEST_SUITES += test-boards-selftest test-boards-boot test-boards-loopback test-boards-resets
test-boards-selftest: $(BOARD_SELF_ELFS) $(BOARD_CANARY_ELFS) | setup
	$(PYTHON) tests/boards/run_selftest.py $(BOARD_SELF_ELFS)
	$(PYTHON) tests/boards/run_selftest.py --expect-fail $(BOARD_CANARY_ELFS)

test-boards-boot: $(BOARD_ECHO_ELFS) | setup
	$(PYTHON) tests/boards/run_boot.py $(BOARD_ECHO_ELFS)

# The host loopback suite and golden vectors over each board's emulated UART.
BOARD_PY_FILES := host/src/aacmm/boards.py tests/boards bench/bench_boards.py firmware/boards/fw_report.py
test-boards-loopback: $(BOARD_FW_ELFS) | setup
	cd tests/boards && ../../$(PYTHON) -m pytest -q -p no:cacheprovider -ra --timeout=120 \
	    test_board_loopback.py
	$(VENV)/bin/ruff check --config host/pyproject.toml $(BOARD_PY_FILES)
	$(VENV)/bin/mypy --config-file host/pyproject.toml host/src/aacmm/boards.py

# Resets on each board: parameters across a system reset, 75 cut flash saves
# (micro:bit), watchdog (mps2-an386), fault, corrupt encoder frames
# (tests/boards/test_board_resets.py; the fw-test.elf images, QEMU's QMP).
test-boards-resets: $(BOARD_FW_ELFS) $(BOARD_TEST_ELFS) | setup
	cd tests/boards && ../../$(PYTHON) -m pytest -q -p no:cacheprovider -ra --timeout=240 \
	    test_board_resets.py
	$(call py_lint,tests/boards/test_board_resets.py)

#> run-<board>          a board's device image under QEMU, printing the URL: run-mps2-an386, run-microbit
# Start a board's device image and print the URL to connect to (Ctrl-C stops).
run-mps2-an386 run-microbit: run-%: $(BOARD_OUT)/%/fw.elf | setup
	$(PYTHON) -m aacmm.boards $*

bench-boards: $(BOARD_SELF_ELFS)
	@$(PYTHON) bench/bench_boards.py $(BOARD_SELF_ELFS)
BENCH_TARGETS += bench-boards
