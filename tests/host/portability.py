"""Which functions of a compiled object use instructions beyond baseline x86-64.

The Python extension must run on any x86-64 CPU: only the AVX2/AVX-512 batch
kernels, chosen after a CPU check, may use VEX or EVEX encoded instructions
(mnemonics starting with 'v', ymm/zmm registers, xmm16-31).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from collections import defaultdict

_VECTOR_INSN = re.compile(r"%[xyz]mm(1[6-9]|2\d|3[01])|%[yz]mm|\tv[a-z]")


def vector_instruction_functions(path: str) -> tuple[list[str], list[str]]:
    """(wide kernels, other functions) of the object at ``path`` that use
    VEX/EVEX instructions, by objdump; the second list must be empty."""
    objdump = shutil.which("objdump")
    assert objdump, "objdump (binutils) is needed for this check"
    text = subprocess.run(
        [objdump, "-d", "--no-show-raw-insn", path],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout
    per_function: dict[str, int] = defaultdict(int)
    fn = "?"
    for line in text.splitlines():
        m = re.match(r"^[0-9a-f]+ <(.+)>:$", line)
        if m:
            fn = m.group(1)
        elif _VECTOR_INSN.search(line):
            per_function[fn] += 1
    wide = sorted(f for f in per_function if "_avx2_" in f or "_avx512_" in f)
    other = sorted(f for f in per_function if f not in wide)
    return wide, other
