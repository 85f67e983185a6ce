"""``aacmm sim``: start the device simulator (``aacmm-sim``) and print its URLs.

The binary is ``$AACMM_SIM``, else ``build/sim/aacmm-sim`` in the source tree
this package runs from (an editable install), else ``aacmm-sim`` on ``PATH``
(a pip-installed package carries no simulator: the error says how to get
one); ``make sim`` builds
it. The command prints one URL per link on stdout (``serial:///dev/pts/N``,
``socketcan://vcan0?node=1``) as soon as the simulator is ready, then runs
until Ctrl-C or SIGTERM, which stop the simulator cleanly.

``--model NAME|FILE`` (issue 26): the simulated device starts with an arm
model's nominal parameter set (``aacmm-sim --param-set``, written to a
temporary file from ``ParamSet.from_arm(model.arm, model.encoder_config())``)
and the model's encoder resolution and interface; the default, the paper's
``gao2013``, runs exactly as without the option. The command says which model
it runs (name, N, P) on stderr.

:class:`aacmm.simulation.process.SimProcess` is the same as a Python API (used
by the tests and the demo).
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any

from aacmm.commands.exitcodes import INTERRUPTED, OK, PORT, USAGE, UsageError
from aacmm.commands.simtruth import note_others
from aacmm.errors import AacmmError, InitError
from aacmm.simulation.process import (
    SIM_EXIT_LINK,
    SIM_EXIT_USAGE,
    SimProcess,
    publish_urls,
    unpublish_urls,
)

if TYPE_CHECKING:
    from aacmm.models import ArmModel


def register(sub: Any) -> None:
    p = sub.add_parser(
        "sim",
        help="start the device simulator and print the URL to connect to",
        description="Start aacmm-sim (see docs/simulator.md), print one device URL per line "
        "on stdout once it is ready, run until Ctrl-C. Without --serial or --can it opens "
        "a pseudo-terminal.",
    )
    p.add_argument(
        "--serial",
        metavar="pty|PATH",
        help="serial link: 'pty' (a new pseudo-terminal) or a tty path",
    )
    p.add_argument(
        "--model",
        metavar="NAME|FILE",
        help="the arm model the device starts with: a shipped model (aacmm model list) or "
        "a model file (default gao2013, the paper's arm)",
    )
    p.add_argument("--can", metavar="IFACE", help="SocketCAN interface (e.g. vcan0)")
    p.add_argument("--node", type=int, metavar="N", help="CAN node id 0..15 (default 1)")
    p.add_argument("--storage", metavar="FILE", help="parameter storage file")
    p.add_argument("--motion", metavar="KIND", help="sweep, walk, static or replay:FILE")
    p.add_argument("--seed", type=int, metavar="N", help="random seed of the motion")
    p.add_argument("--noise-counts", type=int, metavar="N", help="encoder noise in counts")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--encoder-bits", type=int, metavar="B", help="encoder resolution in bits")
    g.add_argument("--cpr", type=int, metavar="N", help="encoder counts per revolution")
    p.add_argument(
        "--encoder",
        metavar="KIND",
        help="joints as biss (default), ssi or ssi-gray frames, or counts",
    )
    p.add_argument("--encoder-faults", type=int, metavar="N", help="corrupt one encoder frame in N")
    p.add_argument(
        "--button-every", type=float, metavar="S", help="press/release the probe button every S s"
    )
    p.add_argument("--serial-number", type=int, metavar="N", help="device serial number")
    p.add_argument(
        "--temperature",
        metavar="C[,C...]",
        help="the links' temperatures, degC (-40 .. 85): one for every link or one per link "
        "(default: every link at 20); with --truth the true arm's lengths at them (its "
        "thermal profile) and the device's sensors read them (control channel 'temps'), "
        "or a profile START:END:MINUTES (START and END each C[,C...], linear, followed at "
        "every probe)",
    )
    p.add_argument(
        "--no-temperature-sensors",
        action="store_true",
        help="a device without link temperature sensors (aacmm-sim --no-temperature-sensors)",
    )
    p.add_argument("--quiet", action="store_true", help="less simulator output on stderr")
    p.add_argument(
        "--board",
        metavar="NAME",
        help="run the device firmware image on an emulated ARM board under QEMU instead "
        "(mps2-an386: Cortex-M4F float path; microbit: Cortex-M0 fixed path; built by "
        "'make firmware'); prints the board UART's socket:// URL",
    )
    p.add_argument(
        "--link",
        metavar="PATH",
        help="also make PATH a symlink to the pty and print serial://PATH "
        "(a stable port name across restarts)",
    )
    from aacmm.commands import simtruth

    simtruth.add_options(p)
    p.set_defaults(func=cmd_sim)


def sim_args(args: argparse.Namespace) -> list[str]:
    """Simulator options from the parsed ``aacmm sim`` arguments."""
    out: list[str] = []
    serial = args.serial
    if serial is None and args.can is None:
        serial = "pty"
    if serial is not None:
        out += ["--serial", serial]
    for opt, val in (
        ("--can", args.can),
        ("--node", args.node),
        ("--storage", args.storage),
        ("--motion", args.motion),
        ("--seed", args.seed),
        ("--noise-counts", args.noise_counts),
        ("--encoder-bits", args.encoder_bits),
        ("--cpr", args.cpr),
        ("--encoder", args.encoder),
        ("--encoder-faults", args.encoder_faults),
        ("--button-every", args.button_every),
        ("--serial-number", args.serial_number),
        ("--temperature", getattr(args, "temperature", None)),
    ):
        if val is not None:
            out += [opt, str(val)]
    if getattr(args, "no_temperature_sensors", False):
        out.append("--no-temperature-sensors")
    if args.quiet:
        out.append("--quiet")
    return out


def sim_model(args: argparse.Namespace) -> ArmModel | None:
    """The ``--model`` of ``aacmm sim``: None for the paper's shipped ``gao2013``
    (the simulator's built-in defaults, today's behaviour), else the model.

    Raises:
        ModelError: no such model, or an invalid model file (exit status 2).
        UsageError: a model the simulator cannot run (encoders of several
            resolutions), or ``--cpr``/``--encoder-bits``/``--board`` against it.
    """
    from aacmm.models import DEFAULT_MODEL, load_model

    if args.model is None:
        return None
    model = load_model(args.model)
    if args.board is not None:
        raise UsageError(
            "--board runs the board's own firmware: no --model (give the board a model "
            "with `aacmm params set MODEL.toml`)"
        )
    if model.name == DEFAULT_MODEL and model.file is None:  # the shipped paper's arm
        return None
    cprs = sorted({e.counts_per_rev for e in model.encoders})
    if len(cprs) != 1:
        raise UsageError(
            f"model {model.name}: the simulator has one encoder resolution for every "
            f"joint, the model has {', '.join(str(c) for c in cprs)} counts per revolution"
        )
    cpr = args.cpr if args.cpr is not None else None
    if args.encoder_bits is not None:
        cpr = 1 << int(args.encoder_bits)
    if cpr is not None and cpr != cprs[0]:
        raise UsageError(
            f"model {model.name} has {cprs[0]} counts per revolution, --cpr/--encoder-bits "
            f"say {cpr}"
        )
    return model


def model_sim_args(args: argparse.Namespace, model: ArmModel, param_file: Path) -> list[str]:
    """The simulator options of a model: its set (``param_file``, written here in the
    set's wire encoding), its resolution and (one for every joint) its interface."""
    from aacmm.protocol import ParamSet, encode_param_set

    param_file.write_bytes(encode_param_set(ParamSet.from_arm(model.arm, model.encoder_config())))
    out = ["--param-set", str(param_file)]
    if args.cpr is None and args.encoder_bits is None:
        out += ["--cpr", str(model.encoders[0].counts_per_rev)]
    interfaces = {e.interface for e in model.encoders}
    if args.encoder is None and len(interfaces) == 1:
        out += ["--encoder", interfaces.pop()]
    from aacmm.commands import simtruth

    motion = args.motion or ""
    if not simtruth.wants_truth(args) and not motion.startswith("replay:"):
        # the simulator's own motion (sweep, walk, static) inside the model's joint limits
        out += ["--joint-limits", joint_limits_arg(model)]
    return out


def joint_limits_arg(model: ArmModel) -> str:
    """``aacmm-sim --joint-limits`` of a model: ``LO:HI`` in degrees per joint
    (``-``: a joint without limits), comma-separated."""
    items = []
    for lo, hi in model.joint_limits_rad:
        if math.isinf(lo):
            items.append("-")
        else:
            items.append(f"{math.degrees(lo):.12g}:{math.degrees(hi):.12g}")
    return ",".join(items)


def model_text(model: ArmModel | None) -> str:
    """What ``aacmm sim`` says it runs: the model's name, N and P."""
    if model is None:
        return "model gao2013 (the paper's arm): 6 joints, 25 parameters"
    where = f", from {model.file}" if model.file else ""
    return f"model {model.name}{where}: {model.n_joints} joints, {model.n_params} parameters"


def check_sim_files(args: argparse.Namespace) -> None:
    """The files ``aacmm sim`` makes (``--link``, ``--storage``) checked before the
    simulator starts: a place that takes no file is one line, exit status 2.

    Raises:
        OutputFileError: the folder of either takes no new file, or the storage
            is not a regular file.
    """
    from aacmm.fileio import OutputFileError, check_writable_dir

    if getattr(args, "link", None):
        link = Path(args.link)
        if link.is_dir() and not link.is_symlink():
            raise OutputFileError(f"--link {link}: is a directory")
        check_writable_dir(link.resolve().parent if not link.is_symlink() else link.parent,
                           f"--link {link}")  # fmt: skip
    if getattr(args, "storage", None):
        st = Path(args.storage)
        if st.exists() and not st.is_file():
            raise OutputFileError(f"--storage {st}: not a regular file")
        # the simulator replaces the file through FILE.tmp beside it
        check_writable_dir(st.resolve().parent, f"--storage {st}")
        if st.exists() and not os.access(st, os.R_OK | os.W_OK):
            raise OutputFileError(f"--storage {st}: cannot read and write it")


def _wait_for_signal(stop: threading.Event, alive: Any) -> None:
    while not stop.is_set() and alive():
        stop.wait(0.2)


def cmd_board(args: argparse.Namespace) -> int:
    """``aacmm sim --board NAME``: the board's device image under QEMU until Ctrl-C."""
    from aacmm import boards

    if args.board not in boards.BOARDS:
        raise UsageError(
            f"unknown board {args.board!r} (known: {', '.join(sorted(boards.BOARDS))})"
        )
    if sim_args(args) != ["--serial", "pty"] or args.link is not None:
        raise UsageError("--board takes no simulator options (the board's firmware has its own)")
    try:
        proc, url = boards.start_board(args.board)
    except FileNotFoundError as exc:
        raise InitError(str(exc)) from exc
    except (OSError, RuntimeError, TimeoutError) as exc:
        raise InitError(f"cannot start the {args.board} board: {exc}") from exc
    stop = threading.Event()
    old = {
        s: signal.signal(s, lambda signum, frame: stop.set())
        for s in (signal.SIGINT, signal.SIGTERM)
    }
    try:
        print(url, flush=True)
        note_others(publish_urls([url]))
        print(
            f"aacmm sim: {args.board} under QEMU (pid {proc.pid}); the board starts when a "
            "client connects (one client); Ctrl-C to stop",
            file=sys.stderr,
            flush=True,
        )
        _wait_for_signal(stop, lambda: proc.poll() is None)
    finally:
        boards.stop_board(proc)
        unpublish_urls()
        for s, h in old.items():
            signal.signal(s, h)
    return OK


def cmd_sim(args: argparse.Namespace) -> int:
    import tempfile

    from aacmm.commands import simtruth

    simtruth.check_args(args)
    if args.temperature is not None and args.no_temperature_sensors:
        raise UsageError(
            "--temperature is what the sensors read: not with --no-temperature-sensors"
        )
    if args.temperature is not None and ":" in args.temperature:
        if not simtruth.wants_truth(args):
            raise UsageError("a --temperature profile START:END:MINUTES needs --truth")
        simtruth.temperature_profile(args.temperature)  # refused before anything starts
    elif args.temperature is not None:  # numbers within -40 .. 85, before anything starts
        from aacmm.commands.common import link_temperature

        for part in args.temperature.split(","):
            link_temperature(part.strip())
    check_sim_files(args)
    model = sim_model(args)
    if args.model is not None:
        print(f"aacmm sim: {model_text(model)}", file=sys.stderr, flush=True)
    if model is None:
        return _cmd_sim(args, sim_args(args), None)
    with tempfile.TemporaryDirectory(prefix="aacmm-sim-model-") as tmp:
        extra = model_sim_args(args, model, Path(tmp) / "param-set.bin")
        return _cmd_sim(args, sim_args(args) + extra, model)


def _cmd_sim(args: argparse.Namespace, argv: list[str], model: ArmModel | None) -> int:
    from aacmm.commands import simtruth

    if simtruth.wants_truth(args):
        if args.link is not None and args.serial is None and args.can is not None:
            raise UsageError("--link needs a serial link (--serial pty)")
        return simtruth.run(args, argv, model)
    if args.board is not None:
        return cmd_board(args)
    if args.link is not None and args.serial is None and args.can is not None:
        raise UsageError("--link needs a serial link (--serial pty)")
    stop = threading.Event()
    received: list[int] = []

    def on_signal(signum: int, frame: FrameType | None) -> None:
        received.append(signum)
        stop.set()

    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        sim = SimProcess(argv, link=args.link)
        try:
            for url in sim.urls:
                print(url, flush=True)
            others = publish_urls(sim.urls)
            print(
                f"aacmm sim: {sim.binary} running (pid {sim.proc.pid}); Ctrl-C to stop",
                file=sys.stderr,
                flush=True,
            )
            note_others(others)
            _wait_for_signal(stop, sim.running)
        finally:
            rc = sim.stop()
            unpublish_urls()
    except AacmmError:
        raise
    finally:
        for s, h in old.items():
            signal.signal(s, h)
    if received:
        return OK if rc in (0, -signal.SIGTERM) else INTERRUPTED
    # the simulator ended by itself
    if rc == SIM_EXIT_USAGE:
        return USAGE
    if rc == SIM_EXIT_LINK:
        return PORT
    print(f"aacmm sim: simulator ended (exit status {rc})", file=sys.stderr)
    return OK if rc == 0 else 1
