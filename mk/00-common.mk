# Shared build settings for every fragment.
BUILD      := build
VENV       := .venv
PYTHON     := $(VENV)/bin/python
FW_INC     := firmware/include

# The warning set every C file in the project must pass, with gcc and clang.
WARN       := -Wall -Wextra -Wpedantic -Wconversion -Wdouble-promotion \
              -Wfloat-equal -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Werror
CSTD       := -std=c99
HOST_OPT   := -O2
SAN_FLAGS  := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all
CMOCKA_LIBS := -lcmocka

ARM_CC      := arm-none-eabi-gcc
ARM_SIZE    := arm-none-eabi-size
ARM_NM      := arm-none-eabi-nm
M4F_FLAGS   := -mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard
M0P_FLAGS   := -mcpu=cortex-m0plus -mthumb -mfloat-abi=soft
ARM_CFLAGS  := $(CSTD) $(WARN) -Os -ffunction-sections -fdata-sections -fstack-usage -I$(FW_INC)

TEST_SUITES      :=
BENCH_TARGETS    :=
FIRMWARE_TARGETS :=

$(BUILD):
	@mkdir -p $@
