# Shared build settings for every fragment.
BUILD      := build
VENV       := .venv
PYTHON     := $(VENV)/bin/python
FW_INC     := firmware/include

# Every area's Python lint, one recipe: ruff, ruff format and mypy --strict
# (host/pyproject.toml) on the files $(1). Use: $(call py_lint,$(FILES)).
define py_lint
	$(VENV)/bin/ruff check --config host/pyproject.toml $(1)
	$(VENV)/bin/ruff format --check --config host/pyproject.toml $(1)
	$(VENV)/bin/mypy --config-file host/pyproject.toml $(1)
endef

# The warning set every C file in the project must pass, with gcc and clang.
WARN       := -Wall -Wextra -Wpedantic -Wconversion -Wdouble-promotion \
              -Wfloat-equal -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Werror
CSTD       := -std=c99
# Host builds (tests, benchmarks, the Python extension) run where they are
# built, so they may use the host's FMA and AVX2 when it has them: FMA
# contraction is worth ~25 % on the kinematics. x86-64-v3 stops short of
# AVX-512, which valgrind (used for instruction counts) cannot run.
HOST_ARCH  := $(shell grep -qw fma /proc/cpuinfo 2>/dev/null && grep -qw avx2 /proc/cpuinfo 2>/dev/null && echo -march=x86-64-v3)
HOST_OPT   := -O2 $(HOST_ARCH) -ffp-contract=fast
SAN_FLAGS  := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all
CMOCKA_LIBS := -lcmocka

ARM_CC      := arm-none-eabi-gcc
ARM_SIZE    := arm-none-eabi-size
ARM_NM      := arm-none-eabi-nm
M4F_FLAGS   := -mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard
M0P_FLAGS   := -mcpu=cortex-m0plus -mthumb -mfloat-abi=soft
ARM_CFLAGS  := $(CSTD) $(WARN) -Os -ffunction-sections -fdata-sections -fstack-usage -I$(FW_INC)

TEST_SUITES      :=
# Suites that run one at a time after the others (scripts/run-suites.sh --alone):
# their tests measure time against a browser or a VM, so they get the machine.
TEST_ALONE       :=
BENCH_TARGETS    :=
FIRMWARE_TARGETS :=

$(BUILD):
	@mkdir -p $@
