# Board ports (firmware/boards/): Cortex-M4F (QEMU mps2-an386) and Cortex-M0
# (BBC micro:bit, nRF51) images, run under qemu-system-arm. See docs/boards.md.
#
# Per board, under build/boards/<board>/:
#   echo.elf      boot check: banner, UART echo, clock
#   selftest.elf  semihosting self-test: golden vectors + instruction counts
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
BOARD_KIN_F32 := firmware/src/status.c firmware/src/encoder.c firmware/src/kinematics_f32.c
BOARD_KIN_Q   := firmware/src/kinematics_q.c firmware/src/fixed_sincos.c
BOARD_DEFS_mps2-an386 := -DSELFTEST_F32 -DSELFTEST_Q -DBOARD_KIN_PRIMARY='"f32"'
BOARD_DEFS_microbit   := -DSELFTEST_F32 -DSELFTEST_Q -DBOARD_KIN_PRIMARY='"q"'

BOARD_CFLAGS  = $(ARM_CFLAGS) -fcallgraph-info=su -I$(BOARD_COMMON) -Ifirmware/src -I$(BOARD_OUT)
BOARD_LDFLAGS := -nostartfiles -Wl,--gc-sections -L$(BOARD_COMMON)
BOARD_HDRS := $(wildcard $(BOARD_COMMON)/*.h) $(wildcard firmware/include/aacmm/*.h) \
              $(wildcard firmware/src/*.h) $(BOARD_COMMON)/sections.ld

# Golden vectors from the host's double-precision core (needs the venv).
$(BOARD_OUT)/golden.h: tests/boards/gen_golden.py firmware/src/kinematics_f64.c firmware/src/kinematics_impl.h | setup
	@mkdir -p $(@D)
	$(PYTHON) tests/boards/gen_golden.py $@

# obj/<source path>.o per board; -fcallgraph-info leaves <obj>.ci beside it.
define BOARD_RULES
$(BOARD_OUT)/$(1)/obj/%.o: %.c $(BOARD_HDRS)
	@mkdir -p $$(@D)
	$(ARM_CC) $(BOARD_CFLAGS) $(BOARD_FLAGS_$(1)) $(BOARD_DEFS_$(1)) -c $$< -o $$@

$(BOARD_OUT)/$(1)/obj/$(BOARD_COMMON)/selftest.o: $(BOARD_OUT)/golden.h

BOARD_BASE_OBJS_$(1) := $(BOARD_OUT)/$(1)/obj/$(BOARD_COMMON)/startup.o \
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
endef
$(foreach b,$(BOARDS),$(eval $(call BOARD_RULES,$(b))))

BOARD_ECHO_ELFS := $(foreach b,$(BOARDS),$(BOARD_OUT)/$(b)/echo.elf)
BOARD_SELF_ELFS := $(foreach b,$(BOARDS),$(BOARD_OUT)/$(b)/selftest.elf)

.PHONY: firmware-boards test-boards-selftest test-boards-boot bench-boards
firmware-boards: $(BOARD_ECHO_ELFS) $(BOARD_SELF_ELFS)
	@for b in $(BOARDS); do \
	  echo "board $$b:"; \
	  $(ARM_SIZE) $(BOARD_OUT)/$$b/echo.elf $(BOARD_OUT)/$$b/selftest.elf; \
	  /usr/bin/python3 scripts/stack_usage.py $(BOARD_OUT)/$$b/obj main aacmm_point_jacobian_f32 aacmm_point_jacobian_q \
	    | sed "s/^/  /"; \
	done
FIRMWARE_TARGETS += firmware-boards

TEST_SUITES += test-boards-selftest test-boards-boot
test-boards-selftest: $(BOARD_SELF_ELFS) | setup
	$(PYTHON) tests/boards/run_selftest.py $(BOARD_SELF_ELFS)

test-boards-boot: $(BOARD_ECHO_ELFS) | setup
	$(PYTHON) tests/boards/run_boot.py $(BOARD_ECHO_ELFS)

bench-boards: $(BOARD_SELF_ELFS)
	@$(PYTHON) bench/bench_boards.py $(BOARD_SELF_ELFS)
BENCH_TARGETS += bench-boards
