#!/bin/sh
# One-time (and re-runnable) set-up for a fresh Debian 12 machine:
#   1. Debian packages the build and tests need (installed when run as root;
#      otherwise the missing ones are listed and the script stops).
#   2. A Python virtual environment under .venv with the host package and its
#      development extras.
# It is idempotent: packages already present and an up-to-date venv are skipped.
set -eu
cd "$(dirname "$0")/.."

APT_PACKAGES="make gcc clang libclang-rt-14-dev libcmocka-dev pkg-config \
python3 python3-venv python3-dev \
gcc-arm-none-eabi libnewlib-arm-none-eabi binutils-arm-none-eabi \
qemu-system-arm qemu-system-x86 linux-image-amd64 busybox-static \
valgrind socat can-utils iproute2 kmod cpio strace poppler-utils \
chromium chromium-driver"

missing=""
for p in $APT_PACKAGES; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
    if [ "$(id -u)" = 0 ]; then
        echo "setup: installing Debian packages:$missing"
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq
        # shellcheck disable=SC2086
        apt-get install -y -qq --no-install-recommends $missing >/dev/null
    else
        echo "setup: missing Debian packages:$missing" >&2
        echo "setup: run as root, or: sudo apt-get install$missing" >&2
        exit 1
    fi
fi

# The venv uses Debian's interpreter so the result does not depend on whatever
# else is on PATH.
PY=/usr/bin/python3
stamp=.venv/.aacmm-setup-stamp
# Rebuild also when the C extension aacmm._core (host/setup.py, built from the
# firmware sources by host/src/aacmm/_build_core.py) is missing or older than
# any of its inputs.
core_stale() {
    ls host/src/aacmm/_core*.so >/dev/null 2>&1 || return 0
    [ -n "$(find host/setup.py host/src/aacmm/_build_core.py firmware/src firmware/include \
        -newer "$stamp" \( -name '*.c' -o -name '*.h' -o -name '*.py' \) 2>/dev/null | head -n 1)" ]
}
if [ ! -x .venv/bin/python ] || [ ! -f "$stamp" ] || [ host/pyproject.toml -nt "$stamp" ] || core_stale; then
    echo "setup: creating Python environment in .venv"
    [ -x .venv/bin/python ] || "$PY" -m venv .venv
    .venv/bin/python -m pip install -q --upgrade pip setuptools wheel
    .venv/bin/python -m pip install -q -e "host[dev]"
    touch "$stamp"
fi
