#!/bin/sh
# Runs a command with a SocketCAN vcan interface (vcan0) up: natively when the
# host kernel supports vcan and we are root, otherwise inside a small QEMU VM
# that sees the host's root filesystem. Passes through the command's exit
# status, output, working directory and test-related environment.
#   tests/vcan/run-in-vcan.sh [--mode auto|native|vm] [--timeout S] [--verbose] CMD [ARG...]
# Details: docs/testing-vcan.md; the work is done by vcan_runner.py, which
# needs only the Python standard library.
set -eu
here=$(CDPATH= cd -- "$(dirname -- "$0")" && pwd)
py=/usr/bin/python3
[ -x "$py" ] || py=$(command -v python3 || true)
if [ -z "$py" ]; then
    echo "run-in-vcan: error: no python3 (apt-get install python3)" >&2
    exit 125
fi
exec "$py" "$here/vcan_runner.py" "$@"
