"""The README's main job, one simulated measurement session end to end.

``python -m aacmm.commands.demo [--out DIR] [--seconds S]`` (run by
``make demo`` as the step ``demo-session``):

1. starts the simulator (``aacmm-sim``) on a pseudo-terminal;
2. ``aacmm info`` and ``aacmm params get`` through the real ``aacmm`` command;
3. ``aacmm log`` for a few seconds at 200 Hz (probe button every 0.5 s);
4. ``aacmm summary``: samples, rate, lost samples, point cloud extent;
5. ``aacmm mc`` over the logged poses and over 10^4 random poses (Table 2);

and writes every output under one folder (default ``out/demo-<UTC time>``),
whose path it prints first and last. Each step's command line is printed
before it runs, so the session can be repeated by hand.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import shlex
import subprocess
import sys
from pathlib import Path

from aacmm.commands.common import write_output
from aacmm.commands.sim import SimProcess, repo_root


def _aacmm() -> list[str]:
    exe = Path(sys.executable).with_name("aacmm")
    return [str(exe)] if exe.is_file() else [sys.executable, "-m", "aacmm.cli"]


def step(
    title: str, args: list[str], out: Path, log_name: str | None = None, brief: bool = False
) -> str:
    """Run ``aacmm ARGS`` in ``out``; echo its output (``brief``: the first line only);
    keep the output in ``out/log_name``. Exit on failure."""
    cmd = [*_aacmm(), *args]
    shown = " ".join(shlex.quote(a) for a in ["aacmm", *args])
    print(f"\n== {title}\n$ {shown}", flush=True)
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=out)
    text = p.stdout + (p.stderr if p.returncode else "")
    if brief and p.returncode == 0 and log_name:
        text = text.strip().splitlines()[0] + f"\n(full output: {log_name})" if text.strip() else ""
    if text.strip():
        print(text.rstrip(), flush=True)
    if log_name:
        write_output(out / log_name, p.stdout)
    if p.returncode != 0:
        print(f"demo: step failed (exit status {p.returncode}): {shown}", file=sys.stderr)
        raise SystemExit(p.returncode)
    return p.stdout


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="aacmm-demo", description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, help="output folder (default out/demo-<UTC time>)")
    ap.add_argument("--seconds", type=float, default=3.0, help="log duration (default 3)")
    ap.add_argument("--poses", type=int, default=10_000, help="Monte Carlo poses (10^4)")
    a = ap.parse_args(argv)
    root = repo_root() or Path.cwd()
    stamp = dt.datetime.now(dt.UTC).strftime("%Y%m%d-%H%M%S")
    out = (a.out or root / "out" / f"demo-{stamp}").resolve()
    if out.is_dir() and any(out.iterdir()):  # every output is refused if it exists
        print(f"demo: {out} is not empty: give a new --out folder", file=sys.stderr)
        return 2
    out.mkdir(parents=True, exist_ok=True)
    print(f"demo: outputs go to {out}", flush=True)

    sim_args = ["--serial", "pty", "--motion", "walk", "--seed", "7"]
    sim_args += ["--noise-counts", "64", "--button-every", "0.5"]
    print("\n== simulator (its diagnostics: simulator.log)", flush=True)
    print(f"$ aacmm sim {' '.join(sim_args[2:])}", flush=True)
    with open(out / "simulator.log", "w") as sim_err:
        with SimProcess(sim_args, stderr=sim_err) as sim:
            port = sim.url
            print(f"device at {port}", flush=True)
            step("device info", ["info", "--port", port], out, "info.txt")
            step("parameter set", ["params", "get", "-o", "params.toml", "--port", port], out)
            step(
                f"log a {a.seconds:g} s measurement session (200 Hz)",
                ["log", "session.csv", "--port", port, "-r", "200", "-d", f"{a.seconds:g}"],
                out,
                "log.txt",
            )
    step("summary", ["summary", "session.csv"], out, "summary.txt")
    summary_json = subprocess.run(
        [*_aacmm(), "summary", "session.csv", "--json"],
        cwd=out,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    write_output(out / "summary.json", summary_json)
    step(
        "Monte Carlo over the logged poses",
        ["mc", "--log", "session.csv", "--json", "mc_log.json", "--csv", "mc_log.csv"],
        out,
        "mc_log.txt",
        brief=True,
    )
    step(
        f"Monte Carlo over {a.poses} random poses (the paper's Table 2)",
        [
            "mc",
            "-n",
            str(a.poses),
            "--seed",
            "1",
            "--json",
            "mc.json",
            "--csv",
            "mc.csv",
            "--png",
            "mc.png",
        ],
        out,
        "mc.txt",
    )
    from aacmm.commands.log import format_summary

    summary = json.loads((out / "summary.json").read_text())
    print("\ndemo: session " + format_summary(summary).replace("\n", "\n              "))
    print("demo: files:")
    for f in sorted(out.iterdir()):
        print(f"  {f.name:<22} {f.stat().st_size:>9} bytes")
    print(f"demo: outputs in {out}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
