# Fixed-point kinematics (integer only, for FPU-less controllers): host tests
# (gcc, clang, ASan+UBSan), a Cortex-M0+ cross build with a symbol check, and
# the benchmark (host ns/pose + callgrind instruction counts vs the f32 path).

# The integer-only path: what runs on the M0+.
FIXED_SRCS := firmware/src/kinematics_q.c firmware/src/fixed_sincos.c
# Host / load-time conversion from double parameters (uses double: never in
# the M0+ build).
FIXED_CONVERT_SRCS := firmware/src/kinematics_q_convert.c
FIXED_HDRS := firmware/include/aacmm/kinematics_q.h firmware/src/fixed_sincos.h firmware/src/chain_q_impl.h \
              firmware/src/errmodel_q_impl.h
FIXED_TEST_SRCS := tests/fixed/test_fixed.c
# The general arm model through the fixed path (tests/fixed/test_fixed_arm.c).
FIXED_ARM_TEST_SRCS := tests/fixed/test_fixed_arm.c
FIXED_TEST_DEPS := $(CORE_SRCS) $(CORE_HDRS) $(FIXED_SRCS) $(FIXED_CONVERT_SRCS) $(FIXED_HDRS) \
                   $(FIXED_TEST_SRCS) tests/core/reference.h tests/core/legacy_paths.h \
                   tests/core/legacy_golden.h
FIXED_ARM_TEST_DEPS := $(CORE_SRCS) $(CORE_HDRS) $(FIXED_SRCS) $(FIXED_CONVERT_SRCS) $(FIXED_HDRS) \
                       $(FIXED_ARM_TEST_SRCS) tests/core/reference.h tests/core/reference_arm.h
FIXED_ALL_SRCS := $(CORE_SRCS) $(FIXED_SRCS) $(FIXED_CONVERT_SRCS)
FIXED_TEST_INC := -I$(FW_INC) -Ifirmware/src -Itests/core -Itests/fixed

# The sanitizer build runs 10^5 random poses instead of 10^6 (about 10x slower),
# and uses the split 32x32->64 multiply of the M0+ build (AACMM_Q_SPLIT_MUL) so
# that the library code of that path runs under ASan/UBSan too.
$(BUILD)/fixed/test_fixed_gcc: $(FIXED_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(HOST_OPT) $(FIXED_TEST_INC) $(FIXED_ALL_SRCS) $(FIXED_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
$(BUILD)/fixed/test_fixed_clang: $(FIXED_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(HOST_OPT) $(FIXED_TEST_INC) $(FIXED_ALL_SRCS) $(FIXED_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
$(BUILD)/fixed/test_fixed_san: $(FIXED_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(SAN_FLAGS) -DFIXED_TEST_POSES=100000L -DAACMM_Q_SPLIT_MUL $(FIXED_TEST_INC) $(FIXED_ALL_SRCS) $(FIXED_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@

$(BUILD)/fixed/test_fixed_arm_gcc: $(FIXED_ARM_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(HOST_OPT) $(FIXED_TEST_INC) $(FIXED_ALL_SRCS) $(FIXED_ARM_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
$(BUILD)/fixed/test_fixed_arm_clang: $(FIXED_ARM_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(HOST_OPT) $(FIXED_TEST_INC) $(FIXED_ALL_SRCS) $(FIXED_ARM_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
$(BUILD)/fixed/test_fixed_arm_san: $(FIXED_ARM_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(SAN_FLAGS) -DFIXED_TEST_POSES=100000L -DAACMM_Q_SPLIT_MUL $(FIXED_TEST_INC) $(FIXED_ALL_SRCS) $(FIXED_ARM_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@

.PHONY: test-fixed-gcc test-fixed-clang test-fixed-san test-fixed-m0p test-fixed-icount \
        firmware-fixed-m0p bench-fixed bench-fixed-m0
test-fixed-gcc: $(BUILD)/fixed/test_fixed_gcc $(BUILD)/fixed/test_fixed_arm_gcc
	$(BUILD)/fixed/test_fixed_gcc
	$(BUILD)/fixed/test_fixed_arm_gcc
test-fixed-clang: $(BUILD)/fixed/test_fixed_clang $(BUILD)/fixed/test_fixed_arm_clang
	$(BUILD)/fixed/test_fixed_clang
	$(BUILD)/fixed/test_fixed_arm_clang
test-fixed-san: $(BUILD)/fixed/test_fixed_san $(BUILD)/fixed/test_fixed_arm_san
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 $(BUILD)/fixed/test_fixed_san
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 $(BUILD)/fixed/test_fixed_arm_san
TEST_SUITES += test-fixed-gcc test-fixed-clang test-fixed-san test-fixed-m0p test-fixed-icount

# ---- Cortex-M0+ cross build (soft-float ABI, integer only) ----
M0P_DIR := $(BUILD)/arm-m0p/fixed
# encoder.c (shared core, integer only) supplies aacmm_encoder_to_bam; shape.c
# (integer only) the arm shapes.
M0P_FIXED_SRCS := $(FIXED_SRCS) firmware/src/encoder.c firmware/src/shape.c
M0P_FIXED_OBJS := $(patsubst firmware/src/%.c,$(M0P_DIR)/%.o,$(M0P_FIXED_SRCS))

$(M0P_DIR)/%.o: firmware/src/%.c $(CORE_HDRS) $(FIXED_HDRS)
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M0P_FLAGS) -fcallgraph-info=su -c $< -o $@

$(M0P_DIR)/libaacmm_fixed.a: $(M0P_FIXED_OBJS)
	rm -f $@ && arm-none-eabi-ar rcs $@ $^

firmware-fixed-m0p: $(M0P_DIR)/libaacmm_fixed.a
	@echo "fixed-point kinematics for Cortex-M0+ ($(M0P_FLAGS)):"
	@$(ARM_SIZE) -t $(M0P_FIXED_OBJS)
	@/usr/bin/python3 scripts/stack_usage.py $(M0P_DIR) aacmm_point_q aacmm_point_jacobian_q aacmm_batch_bam_q aacmm_batch_counts_q aacmm_model_q_init aacmm_sincos_q aacmm_point_em_q aacmm_point_jacobian_em_q aacmm_point_jacobian_corrected_q
FIRMWARE_TARGETS += firmware-fixed-m0p

# No floating point of any kind in the M0+ objects:
#  1. scripts/check-symbols.sh m0-fixed (__aeabi_f*, __aeabi_d*, __aeabi_*2f,
#     __*sf*/__*df* libgcc helpers, sinf and every other libm name);
#  2. the libgcc conversion helpers that profile's patterns let through
#     (__fixdfsi, __fixunssfdi, ... end in si/di, not in a digit);
#  3. no `float` or `double` token in the integer-only sources once comments
#     are stripped (the preprocessor is not run, so headers do not count).
FIXED_FLOAT_EXTRA := ^__(fix|fixuns|float|floatun)[a-z]*[sdtx]f[a-z]*$$
test-fixed-m0p: $(M0P_DIR)/libaacmm_fixed.a $(M0P_DIR)/float_canary.o
	sh scripts/check-symbols.sh m0-fixed $(M0P_FIXED_OBJS)
	@bad=$$(for o in $(M0P_FIXED_OBJS); do $(ARM_NM) -u $$o; done | awk '{print $$2}' | grep -E '$(FIXED_FLOAT_EXTRA)' || true); \
	 if [ -n "$$bad" ]; then echo "test-fixed-m0p: float conversion helpers referenced: $$bad" >&2; exit 1; fi
	@for f in $(FIXED_SRCS) firmware/src/shape.c firmware/src/fixed_sincos.h firmware/src/chain_q_impl.h \
	         firmware/src/errmodel_q_impl.h; do \
	   if gcc -fpreprocessed -dD -E -P -x c $$f 2>/dev/null | grep -nwE 'float|double|long double'; then \
	     echo "test-fixed-m0p: $$f uses a floating type" >&2; exit 1; fi; \
	 done
	@if sh scripts/check-symbols.sh m0-fixed $(M0P_DIR)/float_canary.o 2>/dev/null; then \
	   echo "test-fixed-m0p: the symbol check accepted a floating-point object" >&2; exit 1; fi
	@echo "m0p: $(notdir $(M0P_FIXED_OBJS)) reference no floating-point helper; sources use no float/double"
	@echo "m0p: the check rejects a floating-point canary object (it can fail)"

$(M0P_DIR)/float_canary.o: tests/fixed/float_canary.c
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M0P_FLAGS) -c $< -o $@

# ---- benchmark ----
$(BUILD)/fixed/bench_fixed: bench/bench_fixed.c $(FIXED_ALL_SRCS) $(CORE_HDRS) $(FIXED_HDRS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) -D_POSIX_C_SOURCE=199309L $(HOST_OPT) -g -I$(FW_INC) $(FIXED_ALL_SRCS) bench/bench_fixed.c -lm -o $@
bench-fixed: $(BUILD)/fixed/bench_fixed
	@$<
	@sh bench/callgrind_count.sh $<
BENCH_TARGETS += bench-fixed

# The issue's speed target as a test: point + Jacobian in at most 1.5x the
# instructions of the f32 path on the host build (callgrind, deterministic).
test-fixed-icount: $(BUILD)/fixed/bench_fixed
	sh bench/callgrind_count.sh $< 10240 --check

# ---- Cortex-M0 instruction counts under QEMU (fixed vs soft-float f32) ----
# The -Os M0+ objects of `make firmware` plus the f32 core built the same way
# (soft-float), linked bare metal for QEMU's micro:bit (Cortex-M0) and run with
# -icount shift=0 (see bench/bench_fixed_m0.c). Skipped, with a note, when
# qemu-system-arm is missing.
M0_BENCH_DIR := $(BUILD)/arm-m0p/bench
$(M0_BENCH_DIR)/kinematics_f32.o: firmware/src/kinematics_f32.c $(CORE_HDRS)
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M0P_FLAGS) -c $< -o $@
$(M0_BENCH_DIR)/bench_fixed_m0.elf: bench/bench_fixed_m0.c bench/bare_metal.h bench/m0_microbit.ld $(M0P_FIXED_OBJS) $(M0_BENCH_DIR)/kinematics_f32.o
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M0P_FLAGS) -nostartfiles --specs=nano.specs -Wl,--gc-sections \
	  -T bench/m0_microbit.ld bench/bench_fixed_m0.c $(M0P_FIXED_OBJS) $(M0_BENCH_DIR)/kinematics_f32.o -lm -lc -lgcc -o $@
bench-fixed-m0: $(M0_BENCH_DIR)/bench_fixed_m0.elf
	@if command -v qemu-system-arm >/dev/null 2>&1; then \
	   timeout 120 qemu-system-arm -M microbit -nographic -monitor none -serial none \
	     -semihosting-config enable=on,target=native -icount shift=0 -kernel $<; \
	 else echo '{"bench": "fixed.m0", "skipped": "qemu-system-arm not installed"}'; fi
BENCH_TARGETS += bench-fixed-m0

# The ARMv6-M formulation (per-product rounding in 32-bit arithmetic, the
# sine's narrow products: AACMM_Q_SPLIT_MUL) through the whole suite at full
# size on the host: the arithmetic the Cortex-M0 runs, with every accuracy
# bound of the plain builds.
$(BUILD)/fixed/test_fixed_split: $(FIXED_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(HOST_OPT) -DAACMM_Q_SPLIT_MUL $(FIXED_TEST_INC) $(FIXED_ALL_SRCS) $(FIXED_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
$(BUILD)/fixed/test_fixed_arm_split: $(FIXED_ARM_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(HOST_OPT) -DAACMM_Q_SPLIT_MUL $(FIXED_TEST_INC) $(FIXED_ALL_SRCS) $(FIXED_ARM_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
.PHONY: test-fixed-split
test-fixed-split: $(BUILD)/fixed/test_fixed_split $(BUILD)/fixed/test_fixed_arm_split
	$(BUILD)/fixed/test_fixed_split
	$(BUILD)/fixed/test_fixed_arm_split
TEST_SUITES += test-fixed-split

# ---- the error model's instructions on the Cortex-M0 (issue 27) ----
# bench/bench_em_cm.c on the -Os M0+ objects, as bench-fixed-m0.
$(M0_BENCH_DIR)/bench_em_m0.elf: bench/bench_em_cm.c bench/bare_metal.h bench/m0_microbit.ld $(M0P_FIXED_OBJS)
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M0P_FLAGS) -nostartfiles --specs=nano.specs -Wl,--gc-sections \
	  -T bench/m0_microbit.ld bench/bench_em_cm.c $(M0P_FIXED_OBJS) -lc -lgcc -o $@
.PHONY: bench-em-m0
bench-em-m0: $(M0_BENCH_DIR)/bench_em_m0.elf
	@if command -v qemu-system-arm >/dev/null 2>&1; then \
	   timeout 120 qemu-system-arm -M microbit -nographic -monitor none -serial none \
	     -semihosting-config enable=on,target=native -icount shift=0 -kernel $<; \
	 else echo '{"bench": "em.m0", "skipped": "qemu-system-arm not installed"}'; fi
BENCH_TARGETS += bench-em-m0
