#!/usr/bin/env python3
"""Code size and worst-case stack of a board's device image (``make firmware``).

Usage: fw_report.py BOARD ELF OBJ_DIR STACK_RESERVE_BYTES FLASH_BYTES RAM_BYTES

Size: text/data/bss (arm-none-eabi-size -A), flash = text + data (the .data
image lives in flash), RAM = data + bss + .noinit (the reset record, and the
parameter store where it is RAM) + the reserved stack, each against the
board's limits (on the micro:bit the flash limit is the 254 KiB the image may
use: its last two pages hold the parameters).

Worst-case stack of the device loop, from GCC's -fcallgraph-info=su call
graph (scripts/stack_usage.py), as the sum of

* main's deepest static call path (the device loop: aacmm_device_init and
  aacmm_device_poll with everything they call);
* the deepest platform function (pf_*), because the device calls them
  through the platform table, which the static graph cannot follow, from
  any depth of its own;
* the deepest interrupt handler plus the hardware exception frame (32
  bytes; 104 with the FPU context on the Cortex-M4F); the handlers run at one
  priority, so they do not nest;
* an allowance of 256 bytes for library routines without stack figures
  (libgcc's soft-float and 64-bit helpers, memcpy/memset), listed as
  "external" by stack_usage.py.

Prints two lines and one JSON object; exit status 1 if the stack or the
memory do not fit.
"""

from __future__ import annotations

import importlib.util
import json
import re
import subprocess
import sys
from pathlib import Path

LIB_ALLOWANCE = 256


def _stack_module():  # type: ignore[no-untyped-def]
    path = Path(__file__).resolve().parents[2] / "scripts" / "stack_usage.py"
    spec = importlib.util.spec_from_file_location("stack_usage", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def sections(elf: str) -> dict[str, int]:
    out = subprocess.run(
        ["arm-none-eabi-size", "-A", elf], capture_output=True, text=True, check=True
    ).stdout
    sizes: dict[str, int] = {}
    for line in out.splitlines():
        m = re.match(r"^(\.\S+)\s+(\d+)\s+\d+", line)
        if m:
            sizes[m.group(1)] = int(m.group(2))
    return sizes


def main(argv: list[str]) -> int:
    board, elf, obj_dir, reserve_s, flash_s, ram_s = argv
    reserve, flash_max, ram_max = int(reserve_s), int(flash_s), int(ram_s)
    sec = sections(elf)
    text = sec.get(".text", 0) + sec.get(".ARM.exidx", 0)
    data = sec.get(".data", 0)
    bss = sec.get(".bss", 0)
    noinit = sec.get(".noinit", 0)
    flash = text + data
    ram = data + bss + noinit + reserve

    su = _stack_module()
    frames, calls = su.load(sorted(Path(obj_dir).rglob("*.ci")))

    def depth(fn: str) -> tuple[int, list[str], set[str]]:
        if fn not in frames:
            return 0, [], set()
        total, path, ext, _exact = su.worst(fn, frames, calls)
        return total, path, ext

    main_b, main_path, main_ext = depth("main")

    def short(f: str) -> str:
        return f.split(":")[-1]

    pf = {short(f): depth(f)[0] for f in frames if short(f).startswith("pf_")}
    isr_names = [
        f
        for f in frames
        if short(f).endswith("_Handler") and short(f) not in ("Reset_Handler", "default_handler")
    ]
    isr = {f: depth(f)[0] for f in isr_names}
    # Exception entry pushes 8 words, plus 18 FPU words when the interrupted
    # code used the FPU (lazy stacking reserves the space).
    fpu = any(short(f).endswith("_f32") for f in frames) and board == "mps2-an386"
    exc_frame = 104 if fpu else 32
    pf_max = max(pf.values(), default=0)
    isr_max = max(isr.values(), default=0)
    total = main_b + pf_max + isr_max + exc_frame + LIB_ALLOWANCE
    ok = total <= reserve and flash <= flash_max and ram <= ram_max
    print(
        f"  {Path(elf).name}: text {text} data {data} bss {bss} noinit {noinit}: "
        f"flash {flash} of {flash_max} ({100 * flash / flash_max:.1f}%), "
        f"RAM {ram} of {ram_max} ({100 * ram / ram_max:.1f}%, incl. {reserve} B stack)"
    )
    print(
        f"  worst-case stack of the device loop: {total} B of {reserve} B reserved "
        f"(main {main_b} [{' > '.join(main_path[:4])} ...] + platform call {pf_max} "
        f"+ interrupt {isr_max} + exception frame {exc_frame} + library allowance "
        f"{LIB_ALLOWANCE})"
    )
    print(
        json.dumps(
            {
                "firmware": "boards",
                "board": board,
                "image": Path(elf).name,
                "text": text,
                "data": data,
                "bss": bss,
                "noinit": noinit,
                "flash_bytes": flash,
                "flash_max": flash_max,
                "ram_bytes": ram,
                "ram_max": ram_max,
                "stack_reserved": reserve,
                "stack_worst_bytes": total,
                "stack_main_static": main_b,
                "stack_platform_call": pf_max,
                "stack_interrupt": isr_max,
                "stack_exception_frame": exc_frame,
                "stack_library_allowance": LIB_ALLOWANCE,
                "platform_calls": pf,
                "main_path": main_path,
                "external_calls": sorted(main_ext),
                "fits": ok,
            }
        )
    )
    if not ok:
        print(f"fw_report: {board}: does not fit", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
