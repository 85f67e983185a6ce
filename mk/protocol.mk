# Link protocol (issue 4): C codec tests (gcc, clang, ASan+UBSan), libFuzzer
# harness, Python codec tests (pytest + Hypothesis + interop with the C codec
# through a test-only shared library), mypy/ruff on the Python codec, and a
# Cortex-M build of the codec.

# encoder.c: aacmm_arm_encoders_validate, the parameter set's encoder check; shape.c:
# aacmm_shape_validate, its shape check (aacmm/proto.h; both integer only).
PROTO_SRCS := firmware/src/status.c firmware/src/encoder.c firmware/src/shape.c firmware/src/protocol/crc32.c \
              firmware/src/protocol/cobs.c firmware/src/protocol/frame.c firmware/src/protocol/proto.c \
              firmware/src/protocol/proto_can.c firmware/src/protocol/isotp.c
PROTO_HDRS := $(addprefix firmware/include/aacmm/,status.h kinematics.h crc32.h le_bytes.h cobs.h frame.h \
              proto.h proto_can.h isotp.h) firmware/src/aacmm_internal.h
PROTO_VECTORS := tests/vectors/protocol_vectors.txt
PROTO_TEST_SRCS := tests/protocol/test_protocol.c tests/protocol/vectors.c
PROTO_TEST_DEPS := $(PROTO_SRCS) $(PROTO_HDRS) $(PROTO_TEST_SRCS) tests/protocol/vectors.h
PROTO_TEST_FLAGS := -Itests/protocol -DVECTORS_PATH='"$(PROTO_VECTORS)"'
PROTO_PY_FILES := host/src/aacmm/protocol host/src/aacmm/errors.py \
                  tests/host/test_protocol.py tests/host/test_protocol_interop.py \
                  tests/host/test_protocol_vcan.py tests/vectors/gen_protocol_vectors.py
FUZZ_TIME ?= 600
PROTO_FUZZ_TEST_TIME ?= 50

$(BUILD)/protocol/test_protocol_gcc: $(PROTO_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(HOST_OPT) -I$(FW_INC) $(PROTO_TEST_FLAGS) $(PROTO_SRCS) $(PROTO_TEST_SRCS) $(CMOCKA_LIBS) -o $@
$(BUILD)/protocol/test_protocol_clang: $(PROTO_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(HOST_OPT) -I$(FW_INC) $(PROTO_TEST_FLAGS) $(PROTO_SRCS) $(PROTO_TEST_SRCS) $(CMOCKA_LIBS) -o $@
$(BUILD)/protocol/test_protocol_san: $(PROTO_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) $(SAN_FLAGS) -I$(FW_INC) $(PROTO_TEST_FLAGS) $(PROTO_SRCS) $(PROTO_TEST_SRCS) $(CMOCKA_LIBS) -o $@
$(BUILD)/protocol/test_protocol_gcc_san: $(PROTO_TEST_DEPS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(SAN_FLAGS) -I$(FW_INC) $(PROTO_TEST_FLAGS) $(PROTO_SRCS) $(PROTO_TEST_SRCS) $(CMOCKA_LIBS) -o $@

# libFuzzer harness over the deframer, the message decoder and the ISO-TP receiver.
# Mode 4 of the harness is the absolute-encoder frame decoder (mk/encoder.mk).
$(BUILD)/protocol/fuzz_protocol: $(PROTO_SRCS) $(PROTO_HDRS) tests/protocol/fuzz_protocol.c \
                                 firmware/src/encoder_frame.c firmware/include/aacmm/encoder_frame.h | $(BUILD)
	@mkdir -p $(@D)
	clang $(CSTD) $(WARN) -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
	    -I$(FW_INC) $(PROTO_SRCS) firmware/src/encoder_frame.c tests/protocol/fuzz_protocol.c -o $@

# Test-only shared library the pytest interop tests load with ctypes.
$(BUILD)/protocol/libaacmm_proto_shim.so: $(PROTO_SRCS) $(PROTO_HDRS) tests/protocol/proto_shim.c | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) -O2 -fPIC -shared -I$(FW_INC) $(PROTO_SRCS) tests/protocol/proto_shim.c -o $@

.PHONY: test-protocol test-protocol-gcc test-protocol-clang test-protocol-san test-protocol-fuzz \
        test-protocol-py fuzz fuzz-protocol protocol-shim firmware-protocol

test-protocol-gcc: $(BUILD)/protocol/test_protocol_gcc
	$<
test-protocol-clang: $(BUILD)/protocol/test_protocol_clang
	$<
test-protocol-san: $(BUILD)/protocol/test_protocol_san $(BUILD)/protocol/test_protocol_gcc_san
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 $(BUILD)/protocol/test_protocol_san
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 $(BUILD)/protocol/test_protocol_gcc_san

# Bounded fuzzing for `make test`: the committed seed corpus is read-only
# input; new inputs go to a scratch directory under build/.
test-protocol-fuzz: $(BUILD)/protocol/fuzz_protocol
	@rm -rf $(BUILD)/protocol/fuzz-work && mkdir -p $(BUILD)/protocol/fuzz-work
	$< -max_total_time=$(PROTO_FUZZ_TEST_TIME) -max_len=1200 -timeout=10 -print_final_stats=1 \
	    $(BUILD)/protocol/fuzz-work tests/protocol/corpus

#> fuzz                 longer fuzzing of every harness (FUZZ_TIME=s, default 600); crashes in build/
#> fuzz-protocol        the protocol harness alone (part of fuzz)
# Longer fuzzing: `make fuzz FUZZ_TIME=3600`. Crashes land in build/protocol/.
# (`fuzz` only depends on fuzz-protocol so other fragments can add their harnesses.)
fuzz: fuzz-protocol
fuzz-protocol: $(BUILD)/protocol/fuzz_protocol
	@mkdir -p $(BUILD)/protocol/fuzz-corpus
	$< -max_total_time=$(FUZZ_TIME) -max_len=1200 -timeout=10 -print_final_stats=1 \
	    -artifact_prefix=$(BUILD)/protocol/ $(BUILD)/protocol/fuzz-corpus tests/protocol/corpus

#> protocol-shim        the test-only C codec library the Python interop tests load
protocol-shim: $(BUILD)/protocol/libaacmm_proto_shim.so

test-protocol-py: $(BUILD)/protocol/libaacmm_proto_shim.so
	AACMM_PROTO_SHIM=$(abspath $<) $(PYTHON) -m pytest -q -p no:cacheprovider \
	    tests/host/test_protocol.py tests/host/test_protocol_interop.py
	$(call py_lint,$(PROTO_PY_FILES))

#> test-protocol        the protocol suites together (gcc, clang, san, py, fuzz)
test-protocol: test-protocol-gcc test-protocol-clang test-protocol-san test-protocol-py test-protocol-fuzz

TEST_SUITES += test-protocol-gcc test-protocol-clang test-protocol-san test-protocol-py \
               test-protocol-fuzz test-protocol-m0p

# ---- Cortex-M builds of the codec (M4F and M0+): compile warning-free, report size ----
PROTO_ARM_SRCS := $(filter firmware/src/protocol/%,$(PROTO_SRCS))
$(BUILD)/arm-m4f/protocol/%.o: firmware/src/protocol/%.c $(PROTO_HDRS)
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M4F_FLAGS) -c $< -o $@
$(BUILD)/arm-m0p/protocol/%.o: firmware/src/protocol/%.c $(PROTO_HDRS)
	@mkdir -p $(@D)
	$(ARM_CC) $(ARM_CFLAGS) $(M0P_FLAGS) -c $< -o $@
PROTO_M4F_OBJS := $(patsubst firmware/src/protocol/%.c,$(BUILD)/arm-m4f/protocol/%.o,$(PROTO_ARM_SRCS))
PROTO_M0P_OBJS := $(patsubst firmware/src/protocol/%.c,$(BUILD)/arm-m0p/protocol/%.o,$(PROTO_ARM_SRCS))

firmware-protocol: $(PROTO_M4F_OBJS) $(PROTO_M0P_OBJS)
	@echo "protocol codec for Cortex-M4F and Cortex-M0+:"
	@$(ARM_SIZE) -t $(PROTO_M4F_OBJS) $(PROTO_M0P_OBJS)
FIRMWARE_TARGETS += firmware-protocol

# The codec builds for an FPU-less M0+ without warnings (floats are only moved
# as bits, never computed, except in aacmm_point_mm_to_wire).
test-protocol-m0p: $(PROTO_M0P_OBJS)
	@echo "protocol codec builds for Cortex-M0+ and Cortex-M4F"

# ---- benchmark: codec cost per frame on the host CPU (JSON lines) ----
$(BUILD)/protocol/bench_protocol: $(PROTO_SRCS) $(PROTO_HDRS) tests/protocol/bench_protocol.c | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) -O2 -I$(FW_INC) $(PROTO_SRCS) tests/protocol/bench_protocol.c -o $@
.PHONY: bench-protocol
bench-protocol: $(BUILD)/protocol/bench_protocol
	@$<
BENCH_TARGETS += bench-protocol

# ---- on a real SocketCAN interface: runs in the shared vcan session (mk/vcan.mk) ----
# can-isotp's threaded stack (make_isotp_stack) against the C ISO-TP endpoint,
# and C sample frames decoded with the DBC, over python-can on vcan0.
VCAN_TESTS += tests/host/test_protocol_vcan.py
test-vcan-suite: $(BUILD)/protocol/libaacmm_proto_shim.so
