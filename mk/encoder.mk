# Absolute-encoder frames (issue 16): the decoder (firmware/src/encoder_frame.c)
# and the simulated encoders (firmware/src/sim/sim_encoder.c) as a test-only
# shared library, checked by pytest against frames built in Python from the
# published BiSS-C / SSI layouts (tests/host/test_encoder_frames.py). The C
# side's own tests are in tests/device (test-device-*); the libFuzzer target is
# mode 4 of tests/protocol/fuzz_protocol.c (test-protocol-fuzz).

ENC_LIB_SRCS := firmware/src/encoder_frame.c firmware/src/sim/sim_encoder.c
ENC_LIB      := $(BUILD)/encoder/libaacmm_encoder.so
ENC_PY_FILES := tests/host/test_encoder_frames.py

$(ENC_LIB): $(ENC_LIB_SRCS) firmware/include/aacmm/encoder_frame.h firmware/include/aacmm/proto.h \
            firmware/src/sim/aacmm_sim.h | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) -O2 -fPIC -shared -I$(FW_INC) -Ifirmware/src/sim $(ENC_LIB_SRCS) -o $@

.PHONY: encoder-lib test-encoder-frames
#> encoder-lib          the test-only encoder-frame library the Python frame tests load
encoder-lib: $(ENC_LIB)

test-encoder-frames: $(ENC_LIB) | setup
	AACMM_ENC_LIB=$(abspath $(ENC_LIB)) $(PYTHON) -m pytest -q -p no:cacheprovider --timeout=300 \
	    $(ENC_PY_FILES)
	$(call py_lint,$(ENC_PY_FILES))

TEST_SUITES += test-encoder-frames
