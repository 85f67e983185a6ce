#!/usr/bin/env python3
"""Run the on-target self-test images under QEMU with semihosting.

Usage: run_selftest.py build/boards/<board>/selftest.elf...
       run_selftest.py --expect-fail build/boards/<board>/selftest-canary.elf...

Each image checks its kinematics paths against golden vectors from the
host's double-precision core and exits 0 (pass), 1 (a check failed) or 2
(fault); see firmware/boards/common/selftest.c. This runner prints each
image's output and fails unless every image exited 0, said "self-test
passed", and printed one well-formed JSON benchmark line per path (float
and fixed) with the primary path flagged, and one per general arm model
(5, 6 and 7 joints: issue 26). With --expect-fail, each image
(a canary build whose checks are rigged to fail) must exit with status 1
and report its failures.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from aacmm.boards import run_semihosted


def check_one(elf: Path) -> list[str]:
    board = elf.parent.name
    status, out = run_semihosted(board, elf, timeout=60.0)
    print(f"--- {board}: {elf} (exit {status})")
    print(out.rstrip())
    problems: list[str] = []
    if status != 0:
        problems.append(f"{board}: exit status {status}")
    if "self-test passed" not in out:
        problems.append(f"{board}: no 'self-test passed' line")
    lines = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
    rows = [r for r in lines if r.get("bench") == "boards"]
    arms = [r for r in lines if r.get("bench") == "boards.arm"]
    paths = {r.get("path") for r in rows}
    if paths != {"f32", "q"}:
        problems.append(f"{board}: benchmark lines for {sorted(map(str, paths))}, want f32 and q")
    if sum(1 for r in rows if r.get("primary")) != 1:
        problems.append(f"{board}: not exactly one primary path")
    for r in rows:
        if not 0 < r.get("insn_point_jacobian", 0) < 10**6:
            problems.append(f"{board}: implausible instruction count {r}")
    # the general arm model's rows (issue 26): one per joint count 5..7
    if sorted(r.get("joints", 0) for r in arms) != [5, 6, 7]:
        problems.append(
            f"{board}: general-model lines for joints {[r.get('joints') for r in arms]}"
        )
    for r in arms:
        if not all(
            0 < r.get(k, 0) < 10**6 for k in ("insn_point_jacobian_f32", "insn_point_jacobian_q")
        ):
            problems.append(f"{board}: implausible instruction count {r}")
    return problems


def check_canary(elf: Path) -> list[str]:
    board = elf.parent.name
    status, out = run_semihosted(board, elf, timeout=60.0)
    print(f"--- {board}: {elf} (canary, exit {status})")
    fails = out.count(": FAIL")
    print(f"    {fails} check(s) reported FAIL")
    # 2 checks per path (point, Jacobian) and one per general arm (5, 6, 7 joints)
    if status != 1 or fails != 7 or "self-test FAILED: 7 failure(s)" not in out:
        return [f"{board}: canary image did not fail as rigged (exit {status}, {fails} FAIL)"]
    return []


def main(argv: list[str]) -> int:
    expect_fail = bool(argv) and argv[0] == "--expect-fail"
    if expect_fail:
        argv = argv[1:]
    if not argv:
        print(__doc__, file=sys.stderr)
        return 2
    problems: list[str] = []
    for arg in argv:
        problems += check_canary(Path(arg)) if expect_fail else check_one(Path(arg))
    for p in problems:
        print(f"FAIL {p}")
    print(f"board self-tests: {len(argv)} image(s), {'FAILED' if problems else 'passed'}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
