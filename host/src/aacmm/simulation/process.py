"""The device simulator (``aacmm-sim``) as a child process: finding the binary,
starting it, reading the URLs of its links, stopping it; and the rendezvous
file through which a running ``aacmm sim`` publishes its URLs to other
commands of the same user.

The binary is ``$AACMM_SIM``, else ``build/sim/aacmm-sim`` in the source tree
this package runs from (an editable install), else ``aacmm-sim`` on ``PATH``
(a pip-installed package carries no simulator: the error says how to get
one); ``make sim`` builds it.

:class:`SimProcess` is used by ``aacmm sim``, the demo and the tests.

Errors: :class:`SimulatorError` (an :class:`aacmm.errors.InitError`: no
binary, or it did not start) and :class:`SimulatorUsageError` (an
:class:`aacmm.errors.AacmmError` and ``ValueError``: it refused its options).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import IO, Any

from aacmm.errors import AacmmError, InitError

ENV_SIM = "AACMM_SIM"
READY_TIMEOUT_S = 15.0
SIM_EXIT_USAGE = 2
SIM_EXIT_LINK = 3


class SimulatorError(InitError):
    """The simulator is missing or did not start (exit status 3)."""


class SimulatorUsageError(AacmmError, ValueError):
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
