"""``aacmm sim``: start the device simulator (``aacmm-sim``) and print its URLs.

The binary is ``$AACMM_SIM``, else ``build/sim/aacmm-sim`` in the source tree
this package runs from (an editable install), else ``aacmm-sim`` on ``PATH``
(a pip-installed package carries no simulator: the error says how to get
one); ``make sim`` builds
it. The command prints one URL per link on stdout (``serial:///dev/pts/N``,
``socketcan://vcan0?node=1``) as soon as the simulator is ready, then runs
until Ctrl-C or SIGTERM, which stop the simulator cleanly.

:class:`SimProcess` is the same as a Python API (used by the tests and the
demo).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from types import FrameType, TracebackType
from typing import IO, Any

from aacmm.commands.exitcodes import INTERRUPTED, OK, PORT, USAGE, UsageError
from aacmm.errors import AacmmError, InitError

ENV_SIM = "AACMM_SIM"
READY_TIMEOUT_S = 15.0
SIM_EXIT_USAGE = 2
SIM_EXIT_LINK = 3


class SimulatorError(InitError):
    """The simulator is missing or did not start (exit status 3)."""


class SimulatorUsageError(UsageError):
    """The simulator refused its options (exit status 2)."""


def repo_root() -> Path | None:
    """The source tree this package runs from (an editable install), if any."""
    here = Path(__file__).resolve()
    for parent in here.parents:
        if (parent / "Makefile").is_file() and (parent / "firmware").is_dir():
            return parent
    return None


def find_simulator() -> Path:
    """The ``aacmm-sim`` binary (see the module docstring).

    Raises:
        SimulatorError: not found or not executable ("run make sim").
    """
    env = os.environ.get(ENV_SIM, "").strip()
    if env:
        p = Path(env)
        if p.is_file() and os.access(p, os.X_OK):
            return p
        raise SimulatorError(f"${ENV_SIM}={env} is not an executable file")
    root = repo_root()
    if root is not None:
        p = root / "build" / "sim" / "aacmm-sim"
        if p.is_file() and os.access(p, os.X_OK):
            return p
    found = shutil.which("aacmm-sim")
    if found:
        return Path(found)
    if root is not None:
        raise SimulatorError(
            f"simulator aacmm-sim not found: run 'make sim' in {root} or set ${ENV_SIM}"
        )
    raise SimulatorError(
        "simulator aacmm-sim not found: it is not part of the pip package; build it in the "
        "aacmm source tree with 'make sim', then set $AACMM_SIM to its build/sim/aacmm-sim "
        "or put aacmm-sim on PATH"
    )


# ---------------------------------------------------------------- rendezvous

RENDEZVOUS_WAIT_S = 15.0


def _rendezvous_dir() -> tuple[Path, str]:
    """The folder of the published URLs and the name prefix of this login session's."""
    sid = os.getsid(0)
    base = os.environ.get("XDG_RUNTIME_DIR", "")
    if base and os.path.isdir(base):
        return Path(base), f"aacmm-sim-{sid}"
    return Path(tempfile.gettempdir()), f"aacmm-sim-{os.getuid()}-{sid}"


def rendezvous_path(pid: int | None = None) -> Path:
    """Where a running ``aacmm sim`` (this process, or ``pid``) publishes its URLs
    (one per line), for the commands of the same login session (``getsid``: the
    same terminal or script): ``$XDG_RUNTIME_DIR/aacmm-sim-SID.PID.url``, else
    ``/tmp/aacmm-sim-UID-SID.PID.url``. One file per simulator, so a second
    ``aacmm sim`` takes nothing from the first: the newest running one is used,
    and when it stops the one before is found again."""
    d, prefix = _rendezvous_dir()
    return d / f"{prefix}.{os.getpid() if pid is None else pid}.url"


def publish_urls(urls: Sequence[str]) -> list[tuple[str, int]]:
    """Publish this process's simulator URLs; the other simulators of the session
    already running (``(url, pid)``, newest first), which commands without
    ``--port`` no longer use while this one runs."""
    from aacmm.fileio import write_output

    others = published_sims()
    text = "".join(f"{u}\n" for u in urls) + f"# pid {os.getpid()}\n# started {time.time():.6f}\n"
    write_output(rendezvous_path(), text, force=True)  # exclusive temp file, fsync, rename
    return others


def unpublish_urls() -> None:
    """Remove this process's published URLs."""
    with contextlib.suppress(OSError):
        rendezvous_path().unlink()


def _published(path: Path) -> tuple[list[str], int | None, float]:
    try:
        lines = path.read_text(encoding="ascii").splitlines()
    except (OSError, UnicodeDecodeError):
        return [], None, 0.0
    urls = [ln.strip() for ln in lines if ln.strip() and not ln.startswith("#")]
    pid, started = None, 0.0
    for ln in lines:
        if ln.startswith("# pid ") and ln[6:].strip().isdigit():
            pid = int(ln[6:].strip())
        elif ln.startswith("# started "):
            with contextlib.suppress(ValueError):
                started = float(ln[10:])
    return urls, pid, started


def published_sims() -> list[tuple[str, int]]:
    """``(first URL, pid)`` of every running ``aacmm sim`` of this session, newest
    first (files of simulators that died without removing theirs are skipped)."""
    d, prefix = _rendezvous_dir()
    try:
        names = [n for n in os.listdir(d) if n.startswith(prefix + ".") and n.endswith(".url")]
    except OSError:
        return []
    found = []
    for name in names:
        urls, pid, started = _published(d / name)
        if urls and pid is not None and name == f"{prefix}.{pid}.url" and _alive(pid):
            found.append((started, urls[0], pid))
    found.sort(reverse=True)
    return [(url, pid) for _, url, pid in found]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _sim_command_running() -> bool:
    """An ``aacmm sim`` of this user and session runs (perhaps still starting): /proc."""
    me, uid, sid = os.getpid(), os.getuid(), os.getsid(0)
    try:
        entries = os.listdir("/proc")
    except OSError:
        return False
    for name in entries:
        if not name.isdigit() or int(name) == me:
            continue
        try:
            if os.stat(f"/proc/{name}").st_uid != uid or os.getsid(int(name)) != sid:
                continue
            argv = Path(f"/proc/{name}/cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        for i, a in enumerate(argv[:-1]):
            if (a.endswith(b"aacmm") or a == b"aacmm.cli") and argv[i + 1] == b"sim":
                return True
    return False


def published_url(wait_s: float = RENDEZVOUS_WAIT_S) -> str | None:
    """The first URL of the newest running ``aacmm sim`` of this session, or None.

    When none is published yet but an ``aacmm sim`` is starting (``aacmm sim
    ... & aacmm capture ...``), wait up to ``wait_s`` seconds for it.
    """
    deadline = time.monotonic() + wait_s
    while True:
        sims = published_sims()
        if sims:
            return sims[0][0]
        if time.monotonic() >= deadline or not _sim_command_running():
            return None
        time.sleep(0.1)


class SimProcess:
    """A running ``aacmm-sim``: start it, wait for ``ready``, know its URLs.

    Args:
        args: simulator options (e.g. ``["--serial", "pty", "--seed", "1"]``).
        link: make ``link`` a symlink to the simulator's pty, so the port keeps
            one name across restarts (replaced atomically; removed before the
            simulator ends, by :meth:`stop` or :meth:`kill`).
        stderr: where the simulator's stderr goes (default: inherited).
        pass_fds: descriptors the simulator inherits (e.g. the end of a
            control channel given as ``--control FD``).

    Raises:
        SimulatorError: binary missing, or it ended or stayed silent before ``ready``.
        SimulatorUsageError: it refused the options (its exit status 2).
    """

    def __init__(
        self,
        args: Sequence[str] = ("--serial", "pty"),
        link: str | Path | None = None,
        stderr: int | IO[Any] | None = None,
        binary: Path | None = None,
        pass_fds: Sequence[int] = (),
    ) -> None:
        self.binary = binary or find_simulator()
        self.args = list(args)
        self.link = Path(link) if link is not None else None
        self.serial_path: str | None = None
        self.can: tuple[str, int] | None = None
        self.lines: list[str] = []
        self.proc = subprocess.Popen(
            [str(self.binary), *self.args],
            stdout=subprocess.PIPE,
            stderr=stderr,
            stdin=subprocess.DEVNULL,
            text=True,
            bufsize=1,
            pass_fds=tuple(pass_fds),
        )
        try:
            self._wait_ready()
        except BaseException:
            self.stop()
            raise
        if self.link is not None and self.serial_path is not None:
            tmp = self.link.with_name(f".{self.link.name}.{os.getpid()}.tmp")
            try:
                with contextlib.suppress(FileNotFoundError):
                    tmp.unlink()
                os.symlink(self.serial_path, tmp)
                os.replace(tmp, self.link)
            except OSError as exc:  # never leave the simulator running without its link
                self.stop()
                raise SimulatorUsageError(
                    f"--link {self.link}: cannot create the link: {exc.strerror or exc}"
                ) from None

    def _wait_ready(self) -> None:
        assert self.proc.stdout is not None
        out = self.proc.stdout
        result: list[str] = []
        done = threading.Event()

        def reader() -> None:
            for line in out:
                result.append(line.rstrip("\n"))
                if line.startswith("aacmm-sim: ready"):
                    break
            done.set()

        t = threading.Thread(target=reader, daemon=True)
        t.start()
        done.wait(READY_TIMEOUT_S)
        self.lines = list(result)
        for line in self.lines:
            parts = line.split()
            if line.startswith("aacmm-sim: serial ") and len(parts) >= 3:
                self.serial_path = parts[2]
            elif line.startswith("aacmm-sim: can ") and len(parts) >= 5:
                self.can = (parts[2], int(parts[4]))
        if any(line.startswith("aacmm-sim: ready") for line in self.lines):
            # keep draining stdout so the simulator never blocks on a full pipe
            threading.Thread(target=lambda: [None for _ in out], daemon=True).start()
            return
        if not done.is_set():
            raise SimulatorError(f"simulator not ready within {READY_TIMEOUT_S:g} s")
        rc = self.proc.wait(timeout=5)
        if rc == SIM_EXIT_USAGE:
            raise SimulatorUsageError(f"simulator refused its options {' '.join(self.args)}")
        raise SimulatorError(f"simulator ended before it was ready (exit status {rc})")

    @property
    def urls(self) -> list[str]:
        """The device URLs to connect to (serial first)."""
        out = []
        if self.serial_path is not None:
            out.append(f"serial://{self.link if self.link is not None else self.serial_path}")
        if self.can is not None:
            out.append(f"socketcan://{self.can[0]}?node={self.can[1]}")
        return out

    @property
    def url(self) -> str:
        return self.urls[0]

    def running(self) -> bool:
        return self.proc.poll() is None

    def _remove_link(self) -> None:
        """Remove the link if it still leads to this simulator's pty.

        Done before the simulator ends, never after: the kernel gives a freed
        pty number to the next pseudo-terminal opened anywhere on the machine,
        so a link that outlived its simulator would lead a reconnecting client
        to someone else's device (or terminal).
        """
        if self.link is not None and self.serial_path is not None:
            with contextlib.suppress(OSError):
                if os.readlink(self.link) == self.serial_path:
                    self.link.unlink()

    def kill(self) -> None:
        """SIGKILL: a device that vanishes, its port name with it (as a USB
        device's node goes away when it is unplugged)."""
        self._remove_link()
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()

    def stop(self, timeout: float = 5.0) -> int:
        """Remove the link, SIGTERM, wait (SIGKILL after ``timeout``); the exit status."""
        self._remove_link()
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.proc.stdout is not None:
            with contextlib.suppress(OSError):
                self.proc.stdout.close()
        return int(self.proc.returncode)

    def __enter__(self) -> SimProcess:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()


# ---------------------------------------------------------------- the command


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
    ):
        if val is not None:
            out += [opt, str(val)]
    if args.quiet:
        out.append("--quiet")
    return out


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


def note_others(others: list[tuple[str, int]]) -> None:
    """Say that commands without ``--port`` now use this simulator, not the others."""
    if others:
        urls = ", ".join(f"{u} (pid {p})" for u, p in others)
        print(
            f"aacmm sim: note: commands without --port now use this simulator; "
            f"also running: {urls}, used again when this one stops",
            file=sys.stderr,
            flush=True,
        )


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
    from aacmm.commands import simtruth

    simtruth.check_args(args)
    check_sim_files(args)
    if simtruth.wants_truth(args):
        if args.link is not None and args.serial is None and args.can is not None:
            raise UsageError("--link needs a serial link (--serial pty)")
        return simtruth.run(args, sim_args(args))
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
        sim = SimProcess(sim_args(args), link=args.link)
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
