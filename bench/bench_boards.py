#!/usr/bin/env python3
"""Instruction counts of the kinematics on the emulated ARM boards.

Usage: bench_boards.py build/boards/<board>/selftest.elf...

Runs each board's self-test image under QEMU with -icount shift=0, where
every guest instruction advances the virtual clock by 1 ns, so the board's
timer counts instructions: one tick is 40 instructions on mps2-an386
(SysTick, 25 MHz) and 62.5 on the micro:bit (nRF51 TIMER0, 16 MHz). The
image calibrates that ratio itself against a loop of known length and
reports instructions per call (best of 5 runs of 32 calls, loop cost
subtracted) for: point only, point + full 3x25 Jacobian from joint angles,
and encoder counts -> point + Jacobian; and (boards.arm rows) point and
point + Jacobian of the general arm model for 5, 6 and 7 joints on both
paths.

Output: one JSON object per board and path, with the target for the
board's own path (float on the Cortex-M4F: at most 1,300 instructions per
point + Jacobian; fixed on the Cortex-M0: at most 10,000, issue 17) and
whether it is met. Exit status 1 if an image failed or a target was missed.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from aacmm.boards import run_semihosted

TARGETS = {("mps2-an386", "f32"): 1300, ("microbit", "q"): 10000}


def main(argv: list[str]) -> int:
    status = 0
    for arg in argv:
        elf = Path(arg)
        board = elf.parent.name
        rc, out = run_semihosted(board, elf, timeout=60.0)
        if rc != 0:
            print(out, file=sys.stderr)
            print(f"bench-boards: {board} self-test exited {rc}", file=sys.stderr)
            status = 1
        for line in out.splitlines():
            if not line.startswith("{"):
                continue
            row = json.loads(line)
            row["qemu"] = "-icount shift=0"
            # the targets are the paper's arm's (its own rows); the general
            # model's rows (boards.arm, N = 5..7) are reported as measured
            target = TARGETS.get((board, row.get("path", "")))
            if target is not None:
                row["target_insn_point_jacobian"] = target
                row["within_target"] = row["insn_point_jacobian"] <= target
                if not row["within_target"]:
                    status = 1
            print(json.dumps(row))
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
