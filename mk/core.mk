# Kinematics core: host library, tests (gcc, clang, ASan+UBSan), M4F cross
# build with a symbol check, and the benchmark.

CORE_SRCS := firmware/src/status.c firmware/src/encoder.c firmware/src/shape.c \
             firmware/src/kinematics_f32.c firmware/src/kinematics_f64.c
# Host-only batch kernels across SIMD lanes (aacmm/simd.h) and the analysis
# loops they build on: in the host test and benchmark binaries, not in the
# firmware images.
SIMD_SRCS := firmware/src/analysis.c firmware/src/simd/simd_dispatch.c \
             firmware/src/simd/simd_f64.c firmware/src/simd/simd_f32.c
CORE_HDRS := $(wildcard firmware/include/aacmm/*.h) firmware/src/aacmm_internal.h \
             firmware/src/kinematics_impl.h firmware/src/sincos_f64.h firmware/src/sincos_f32.h \
             firmware/src/template_end.h firmware/src/sincos_eval.h \
             firmware/src/chain_impl.h firmware/src/errmodel_impl.h firmware/src/errmodel_core.h $(wildcard firmware/src/simd/*.h)
CORE_TEST_SRCS := tests/core/test_kinematics.c
CORE_TEST_DEPS := $(CORE_SRCS) $(SIMD_SRCS) $(CORE_HDRS) $(CORE_TEST_SRCS) tests/core/reference.h \
                  tests/core/legacy_paths.h tests/core/legacy_golden.h
# The core tests build as the Python extension does (host/src/aacmm/_build_core.py):
# no -march (the scalar kernel is the baseline x86-64 / arm64 one a wheel runs)
# and no FMA contraction, so the batch kernels must equal it bit for bit.
# The sanitizer build runs a tenth of the poses (CORE_TEST_DIV=10): it runs
# every accuracy test once per batch kernel, about ten times slower.
CORE_TEST_OPT := -O2 -ffp-contract=off

# The general arm model's tests (tests/core/test_arm.c) build alike.
ARM_TEST_SRCS := tests/core/test_arm.c
ARM_TEST_DEPS := $(CORE_SRCS) $(SIMD_SRCS) $(CORE_HDRS) $(ARM_TEST_SRCS) tests/core/reference.h \
                 tests/core/reference_arm.h

# One test binary per compiler configuration.
$(BUILD)/core/test_kinematics_gcc: $(CORE_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(CORE_TEST_OPT) -I$(FW_INC) -Itests/core $(CORE_SRCS) $(SIMD_SRCS) $(CORE_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
$(BUILD)/core/test_kinematics_clang: $(CORE_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(CORE_TEST_OPT) -I$(FW_INC) -Itests/core $(CORE_SRCS) $(SIMD_SRCS) $(CORE_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
$(BUILD)/core/test_kinematics_san: $(CORE_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(SAN_FLAGS) -DCORE_TEST_DIV=10 -I$(FW_INC) -Itests/core $(CORE_SRCS) $(SIMD_SRCS) $(CORE_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@

$(BUILD)/core/test_arm_gcc: $(ARM_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(CORE_TEST_OPT) -I$(FW_INC) -Itests/core $(CORE_SRCS) $(SIMD_SRCS) $(ARM_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
$(BUILD)/core/test_arm_clang: $(ARM_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(CORE_TEST_OPT) -I$(FW_INC) -Itests/core $(CORE_SRCS) $(SIMD_SRCS) $(ARM_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@
$(BUILD)/core/test_arm_san: $(ARM_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(SAN_FLAGS) -DCORE_TEST_DIV=10 -I$(FW_INC) -Itests/core $(CORE_SRCS) $(SIMD_SRCS) $(ARM_TEST_SRCS) $(CMOCKA_LIBS) -lm -o $@

.PHONY: test-core-gcc test-core-clang test-core-san test-core-m4f bench-core firmware-core-m4f
test-core-gcc: $(BUILD)/core/test_kinematics_gcc $(BUILD)/core/test_arm_gcc
	$(BUILD)/core/test_kinematics_gcc
	$(BUILD)/core/test_arm_gcc
test-core-clang: $(BUILD)/core/test_kinematics_clang $(BUILD)/core/test_arm_clang
	$(BUILD)/core/test_kinematics_clang
	$(BUILD)/core/test_arm_clang
test-core-san: $(BUILD)/core/test_kinematics_san $(BUILD)/core/test_arm_san
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 $(BUILD)/core/test_kinematics_san
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 $(BUILD)/core/test_arm_san
TEST_SUITES += test-core-gcc test-core-clang test-core-san test-core-m4f

# ---- Cortex-M4F cross build of the core (float path on the FPU) ----
M4F_DIR := $(BUILD)/arm-m4f/core
M4F_CORE_SRCS := firmware/src/status.c firmware/src/encoder.c firmware/src/shape.c \
                 firmware/src/kinematics_f32.c
M4F_CORE_OBJS := $(patsubst firmware/src/%.c,$(M4F_DIR)/%.o,$(M4F_CORE_SRCS))

$(M4F_DIR)/%.o: firmware/src/%.c $(CORE_HDRS)
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M4F_FLAGS) -fcallgraph-info=su -c $< -o $@

$(M4F_DIR)/libaacmm_core.a: $(M4F_CORE_OBJS)
	rm -f $@ && arm-none-eabi-ar rcs $@ $^

firmware-core-m4f: $(M4F_DIR)/libaacmm_core.a
	@echo "core for Cortex-M4F ($(M4F_FLAGS)):"
	@$(ARM_SIZE) -t $(M4F_CORE_OBJS)
	@/usr/bin/python3 scripts/stack_usage.py $(M4F_DIR) aacmm_point_jacobian_f32 aacmm_batch_counts_f32 aacmm_encoder_to_angles_f32 aacmm_model_init_f32 aacmm_point_em_f32 aacmm_point_jacobian_em_f32
FIRMWARE_TARGETS += firmware-core-m4f

# The single-precision path must run on the FPU alone: no double-precision
# helper, no soft-float helper, no double libm function.
test-core-m4f: $(M4F_DIR)/libaacmm_core.a
	sh scripts/check-symbols.sh m4f-float $(M4F_DIR)/kinematics_f32.o
	sh scripts/check-symbols.sh m4f-float $(M4F_DIR)/encoder.o
	@echo "m4f: kinematics_f32.o and encoder.o use no double-precision or soft-float helpers"

# ---- benchmark ----
# The scalar figures use HOST_OPT (this machine's -march, as before issue 17),
# so the SIMD speed-ups are against the fastest scalar build.
#
# Issue 26: the core of commit aa8b712 (before the general arm model) is built
# into the benchmark too, from `git archive`, with the same flags, its aacmm_
# symbols renamed legacy_aacmm_ (bench/bench_legacy.c), so both cores run in
# one process, their runs alternating. Without that commit in the history
# (an export of the tree), the benchmark is built without it and says so.
LEGACY_COMMIT := aa8b712
LEGACY_DIR    := $(BUILD)/core/legacy
LEGACY_OK     := $(shell git cat-file -e $(LEGACY_COMMIT)^{commit} 2>/dev/null && echo 1)
LEGACY_SRCS   := status.c encoder.c kinematics_f32.c kinematics_f64.c analysis.c \
                 simd/simd_dispatch.c simd/simd_f64.c simd/simd_f32.c

$(LEGACY_DIR)/firmware/.extracted:
	@rm -rf $(LEGACY_DIR)/firmware && mkdir -p $(LEGACY_DIR)
	git archive $(LEGACY_COMMIT) firmware | tar -x -C $(LEGACY_DIR)
	@touch $@

# One relocatable object: the old core and bench_legacy.c, linked together
# (ld -r), every aacmm_ symbol (definitions and references) then renamed.
$(LEGACY_DIR)/legacy.o: $(LEGACY_DIR)/firmware/.extracted bench/bench_legacy.c bench/bench_legacy.h
	@rm -rf $(LEGACY_DIR)/obj && mkdir -p $(LEGACY_DIR)/obj
	@for f in $(LEGACY_SRCS); do \
	   gcc $(CSTD) $(WARN) $(HOST_OPT) -I$(LEGACY_DIR)/firmware/include -c $(LEGACY_DIR)/firmware/src/$$f \
	       -o $(LEGACY_DIR)/obj/$$(echo $$f | tr / _).o || exit 1; \
	 done
	gcc $(CSTD) $(WARN) $(HOST_OPT) -I$(LEGACY_DIR)/firmware/include -Ibench -c bench/bench_legacy.c \
	    -o $(LEGACY_DIR)/obj/bench_legacy.o
	ld -r -o $(LEGACY_DIR)/legacy_raw.o $(LEGACY_DIR)/obj/*.o
	nm $(LEGACY_DIR)/legacy_raw.o | awk '$$NF ~ /^aacmm_/ {print $$NF, "legacy_" $$NF}' | sort -u \
	    > $(LEGACY_DIR)/rename.txt
	objcopy --redefine-syms=$(LEGACY_DIR)/rename.txt $(LEGACY_DIR)/legacy_raw.o $@

BENCH_CORE_LEGACY := $(if $(LEGACY_OK),$(LEGACY_DIR)/legacy.o)
BENCH_CORE_FLAGS  := $(if $(LEGACY_OK),-DBENCH_LEGACY=1 -Ibench,-DBENCH_LEGACY=0)

$(BUILD)/core/bench_core: bench/bench_core.c $(CORE_SRCS) $(SIMD_SRCS) $(CORE_HDRS) $(BENCH_CORE_LEGACY) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) -D_POSIX_C_SOURCE=199309L $(HOST_OPT) $(BENCH_CORE_FLAGS) -I$(FW_INC) $(CORE_SRCS) $(SIMD_SRCS) bench/bench_core.c $(BENCH_CORE_LEGACY) -lm -o $@
bench-core: $(BUILD)/core/bench_core
	@$<
BENCH_TARGETS += bench-core

# ---- the error model's instructions on the Cortex-M4F (issue 27) ----
# bench/bench_em_cm.c on the -Os M4F objects under QEMU's mps2-an386.
M4F_BENCH_DIR := $(BUILD)/arm-m4f/bench
$(M4F_BENCH_DIR)/bench_em_m4f.elf: bench/bench_em_cm.c bench/bare_metal.h bench/m4f_mps2.ld $(M4F_CORE_OBJS)
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M4F_FLAGS) -nostartfiles --specs=nano.specs -Wl,--gc-sections \
	  -T bench/m4f_mps2.ld bench/bench_em_cm.c $(M4F_CORE_OBJS) -lm -lc -lgcc -o $@
.PHONY: bench-em-m4f
bench-em-m4f: $(M4F_BENCH_DIR)/bench_em_m4f.elf
	@if command -v qemu-system-arm >/dev/null 2>&1; then \
	   timeout 120 qemu-system-arm -M mps2-an386 -nographic -monitor none -serial none \
	     -semihosting-config enable=on,target=native -icount shift=0 -kernel $<; \
	 else echo '{"bench": "em.m4f", "skipped": "qemu-system-arm not installed"}'; fi
BENCH_TARGETS += bench-em-m4f
