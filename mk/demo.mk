# The README's main job. Later areas extend DEMO_STEPS with their own targets
# (simulator, logging, Monte Carlo); each step runs in order.
DEMO_STEPS := demo-poses

$(BUILD)/examples/print_poses: examples/print_poses.c $(CORE_SRCS) $(CORE_HDRS) | $(BUILD)
	@mkdir -p $(@D)
	gcc $(CSTD) $(WARN) $(HOST_OPT) -I$(FW_INC) $(CORE_SRCS) examples/print_poses.c -lm -o $@

.PHONY: demo-poses
demo-poses: $(BUILD)/examples/print_poses
	@$<

demo: setup
	@for step in $(DEMO_STEPS); do $(MAKE) --no-print-directory $$step || exit 1; done
