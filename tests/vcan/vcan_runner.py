#!/usr/bin/python3
"""Run a command with a SocketCAN vcan interface up.

Natively when the host kernel can do it (root, AF_CAN raw + ISO-TP sockets,
vcan), otherwise inside a small QEMU (TCG) VM that boots Debian's kernel with
a busybox initramfs, mounts the host's root over virtio-9p and runs the
command chrooted there, at the same working directory and with the same
absolute paths. See docs/testing-vcan.md.

Only the Python standard library is used: this runs with Debian's
/usr/bin/python3 before any venv exists.

Exit status: the command's own; 124 hard timeout; 125 the infrastructure
failed (no QEMU/kernel, module or mount failure, VM died without reporting);
127 command not found; 130/143 interrupted by SIGINT/SIGTERM.
"""

from __future__ import annotations

import ctypes
import errno
import gzip
import hashlib
import lzma
import os
import re
import shlex
import shutil
import signal
import socket
import stat
import subprocess
import sys
import threading
import time
import zlib
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
INIT_SCRIPT = HERE / "vm-init.sh"
FORMAT_VERSION = "4"  # bump when the initramfs layout changes

EXIT_TIMEOUT = 124
EXIT_INFRA = 125
EXIT_NOTFOUND = 127

# Modules for virtio-9p root + SocketCAN, in insertion order. Dependencies
# missing from this list are added from modules.dep; built-in ones skipped.
VM_MODULES = [
    "virtio_ring",
    "virtio",
    "virtio_pci_legacy_dev",
    "virtio_pci_modern_dev",
    "virtio_pci",
    "9pnet",
    "9pnet_virtio",
    "netfs",
    "fscache",
    "9p",
    "can",
    "can-raw",
    "can-isotp",
    "can-dev",
    "vcan",
]

# Environment passed to the command (besides the prefixes below).
PASS_ENV = [
    "PATH",
    "PYTHONPATH",
    "PYTHONHASHSEED",
    "PYTHONDONTWRITEBYTECODE",
    "PYTHONUNBUFFERED",
    "PYTHONWARNINGS",
    "PYTHONFAULTHANDLER",
    "PYTHONDEVMODE",
    "VIRTUAL_ENV",
    "HOME",
    "USER",
    "LOGNAME",
    "LANG",
    "LANGUAGE",
    "LC_ALL",
    "LC_CTYPE",
    "TZ",
    "CI",
    "NO_COLOR",
    "FORCE_COLOR",
    "PY_COLORS",
    "COLUMNS",
    "TMPDIR",
    "MAKEFLAGS",
]
PASS_ENV_PREFIXES = ("AACMM_", "PYTEST_", "HYPOTHESIS_", "CAN_")

PROTO = re.compile(r"AACMM_VCAN_(STAGE|ERROR|EXIT|DMESG)=(.*)")
KERNEL_TROUBLE = re.compile(
    r"Kernel panic|BUG:|Oops|general protection|sysrq: |"
    r"Out of memory|Killed process|Unable to mount|not syncing"
)


class InfraError(Exception):
    """The runner itself cannot do its job (exit 125)."""


def log(msg: str) -> None:
    sys.stderr.write(f"run-in-vcan: {msg}\n")
    sys.stderr.flush()


def env_flag(name: str) -> bool:
    return os.environ.get(name, "").strip().lower() not in ("", "0", "no", "false", "off")


def env_flag_default(name: str, default: bool) -> bool:
    raw = os.environ.get(name, "").strip().lower()
    if not raw:
        return default
    return raw not in ("0", "no", "false", "off")


def env_num(name: str, default: float) -> float:
    raw = os.environ.get(name, "").strip()
    if not raw:
        return default
    try:
        val = float(raw)
    except ValueError:
        raise InfraError(f"{name}={raw!r} is not a number") from None
    if val <= 0:
        raise InfraError(f"{name} must be positive, got {raw!r}")
    return val


def ifaces() -> list[str]:
    names = os.environ.get("AACMM_VCAN_IFACES", "vcan0").split()
    for n in names:
        if not re.fullmatch(r"[A-Za-z0-9_.-]{1,15}", n):
            raise InfraError(f"bad interface name in AACMM_VCAN_IFACES: {n!r}")
    return names or ["vcan0"]


# --------------------------------------------------------------------------
# command lookup and environment


def resolve_command(argv0: str, path: str) -> str | None:
    if "/" in argv0:
        p = Path(argv0)
        return str(p) if p.is_file() and os.access(p, os.X_OK) else None
    return shutil.which(argv0, path=path)


def child_env(mode: str) -> dict[str, str]:
    extra = os.environ.get("AACMM_VCAN_ENV", "").split()
    env: dict[str, str] = {}
    for k, v in os.environ.items():
        if k.startswith("AACMM_VCAN"):
            continue  # runner settings stay outside (no nested VMs)
        if k in PASS_ENV or k in extra or k.startswith(PASS_ENV_PREFIXES):
            env[k] = v
    env.setdefault("PATH", "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin")
    env["AACMM_VCAN"] = mode
    env["AACMM_VCAN_IFACES"] = " ".join(ifaces())
    if mode == "vm":
        # The command's stdout is a serial port in the VM: only claim a real
        # terminal if ours is one.
        if sys.stdout.isatty():
            env["TERM"] = os.environ.get("TERM", "xterm")
            env.setdefault("COLUMNS", str(shutil.get_terminal_size().columns))
        else:
            env["TERM"] = "dumb"
            env.setdefault("COLUMNS", "100")
    elif "TERM" in os.environ:
        env["TERM"] = os.environ["TERM"]
    return env


# --------------------------------------------------------------------------
# native mode


def _can_socket_ok(kind: int, proto: int) -> bool:
    try:
        s = socket.socket(socket.AF_CAN, kind, proto)
    except (OSError, AttributeError):
        return False
    s.close()
    return True


def _modprobe(*mods: str) -> None:
    exe = shutil.which("modprobe", path="/usr/sbin:/sbin:/usr/bin:/bin")
    if exe:
        for m in mods:
            subprocess.run(
                [exe, "-q", m], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False
            )


def _ip() -> str | None:
    return shutil.which("ip", path="/usr/sbin:/sbin:/usr/bin:/bin")


def native_check() -> str | None:
    """None if the host can run the command natively, else the reason."""
    if os.geteuid() != 0:
        return "not root"
    isotp = getattr(socket, "CAN_ISOTP", 6)
    if not _can_socket_ok(socket.SOCK_RAW, socket.CAN_RAW if hasattr(socket, "CAN_RAW") else 1):
        _modprobe("can", "can-raw")
        if not _can_socket_ok(socket.SOCK_RAW, getattr(socket, "CAN_RAW", 1)):
            return "host kernel has no AF_CAN raw sockets"
    if not _can_socket_ok(socket.SOCK_DGRAM, isotp):
        _modprobe("can-isotp")
        if not _can_socket_ok(socket.SOCK_DGRAM, isotp):
            return "host kernel has no CAN ISO-TP sockets"
    ip = _ip()
    if not ip:
        return "no ip(8) (iproute2) on the host"
    for name in ifaces():
        if not Path(f"/sys/class/net/{name}").exists():
            _modprobe("vcan")
            r = subprocess.run(
                [ip, "link", "add", "dev", name, "type", "vcan"],
                capture_output=True,
                text=True,
                check=False,
            )
            if r.returncode != 0:
                return f"cannot create {name}: {r.stderr.strip()}"
            subprocess.run([ip, "link", "delete", name], capture_output=True, check=False)
    return None


def run_native(cmd: list[str], timeout: float) -> int:
    ip = _ip()
    assert ip
    created = []
    for name in ifaces():
        if not Path(f"/sys/class/net/{name}").exists():
            r = subprocess.run(
                [ip, "link", "add", "dev", name, "type", "vcan"],
                capture_output=True,
                text=True,
                check=False,
            )
            if r.returncode != 0:
                raise InfraError(f"cannot create {name}: {r.stderr.strip()}")
            created.append(name)
        r = subprocess.run(
            [ip, "link", "set", "up", name], capture_output=True, text=True, check=False
        )
        if r.returncode != 0:
            raise InfraError(f"cannot bring {name} up: {r.stderr.strip()}")
    log(f"host kernel has vcan: running natively on {' '.join(ifaces())}")
    env = child_env("native")
    t0 = time.monotonic()
    try:
        proc = subprocess.Popen(cmd, env=env, start_new_session=True)
    except OSError as e:
        raise InfraError(f"cannot start {cmd[0]}: {e}") from None

    def killgroup(sig: int) -> None:
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            pass

    try:
        try:
            rc = proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            log(
                f"TIMEOUT: command still running after {timeout:.0f} s "
                "(AACMM_VCAN_TIMEOUT); killing it"
            )
            killgroup(signal.SIGTERM)
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                killgroup(signal.SIGKILL)
                proc.wait()
            return EXIT_TIMEOUT
    except BaseException:
        killgroup(signal.SIGTERM)
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            killgroup(signal.SIGKILL)
            proc.wait()
        raise
    finally:
        killgroup(signal.SIGKILL)  # leftovers of the command's process group
        for name in created:
            subprocess.run([ip, "link", "delete", name], capture_output=True, check=False)
    if rc < 0:
        rc = 128 - rc
    log(f"exit {rc} (native, {time.monotonic() - t0:.1f} s)")
    return rc


# --------------------------------------------------------------------------
# VM: kernel, modules, initramfs


def _version_key(v: str) -> list[tuple[int, object]]:
    return [(0, int(p)) if p.isdigit() else (1, p) for p in re.split(r"[.\-+~]", v)]


def find_kernel() -> tuple[str, Path, Path]:
    boot = Path(os.environ.get("AACMM_VCAN_BOOT_DIR", "/boot"))
    mods = Path(os.environ.get("AACMM_VCAN_MODULES_DIR", "/lib/modules"))
    want = os.environ.get("AACMM_VCAN_KERNEL", "").strip()
    found = []
    for k in boot.glob("vmlinuz-*"):
        ver = k.name[len("vmlinuz-") :]
        if (mods / ver / "modules.dep").is_file():
            found.append(ver)
    hint = "install Debian's kernel: apt-get install linux-image-amd64 (or make setup)"
    if want:
        if want not in found:
            raise InfraError(
                f"AACMM_VCAN_KERNEL={want}: no {boot}/vmlinuz-{want} with {mods}/{want}/modules.dep"
            )
        ver = want
    elif not found:
        raise InfraError(
            f"no kernel for the VM: no {boot}/vmlinuz-* with a matching "
            f"{mods}/<version>/modules.dep; {hint}"
        )
    else:
        ver = max(found, key=_version_key)
    kernel = boot / f"vmlinuz-{ver}"
    if not os.access(kernel, os.R_OK):
        raise InfraError(f"{kernel} is not readable (run as root?)")
    return ver, kernel, mods / ver


def _kernel_config(moddir: Path, ver: str) -> str:
    for p in (
        Path(os.environ.get("AACMM_VCAN_BOOT_DIR", "/boot")) / f"config-{ver}",
        moddir / "build" / ".config",
    ):
        try:
            return p.read_text(errors="replace")
        except OSError:
            continue
    return ""


def boot_image(build: Path, ver: str, kernel: Path, moddir: Path) -> Path:
    """The kernel image to give QEMU.

    Debian's bzImage is xz-compressed, and decompressing it under TCG costs
    ~3.5 s of every boot. Kernels built with CONFIG_PVH can instead be booted
    as the plain ELF vmlinux, so that is extracted once (cached in the build
    directory) and used. Falls back to the bzImage when anything is off.
    """
    if not env_flag_default("AACMM_VCAN_PVH", True):
        return kernel
    if "CONFIG_PVH=y" not in _kernel_config(moddir, ver).splitlines():
        return kernel
    st = kernel.stat()
    out = build / f"vmlinux-{ver}-{st.st_size}-{st.st_mtime_ns}"
    if out.is_file():
        os.utime(out)
        return out
    data = kernel.read_bytes()
    elf = None
    for magic, make in (
        (b"\xfd7zXZ\x00", lambda: lzma.LZMADecompressor(format=lzma.FORMAT_XZ)),
        (b"\x1f\x8b\x08", lambda: zlib.decompressobj(31)),
    ):
        pos = data.find(magic)
        while pos >= 0 and elf is None:
            try:
                cand = make().decompress(data[pos:])
            except (lzma.LZMAError, zlib.error, EOFError, ValueError):
                cand = b""
            if cand[:4] == b"\x7fELF":
                elf = cand
            pos = data.find(magic, pos + 1)
        if elf is not None:
            break
    if elf is None:
        return kernel
    tmp = out.with_name(out.name + f".tmp{os.getpid()}")
    tmp.write_bytes(elf)
    os.replace(tmp, out)
    for old in build.glob(f"vmlinux-{ver}-*"):
        if old != out and ".tmp" not in old.name:
            old.unlink(missing_ok=True)
    return out


def _modname(path: str) -> str:
    base = path.rsplit("/", 1)[-1]
    base = re.sub(r"\.ko(\.(xz|zst|gz))?$", "", base)
    return base.replace("-", "_")


def resolve_modules(moddir: Path) -> list[Path]:
    """Module files to insert, dependencies first."""
    dep: dict[str, tuple[str, list[str]]] = {}
    for line in (moddir / "modules.dep").read_text().splitlines():
        if ":" not in line:
            continue
        path, deps = line.split(":", 1)
        dep[_modname(path)] = (path, deps.split())
    builtin = set()
    bfile = moddir / "modules.builtin"
    if bfile.is_file():
        builtin = {_modname(x) for x in bfile.read_text().split()}

    order: list[Path] = []
    seen: set[str] = set()

    def add(name: str, why: str) -> None:
        key = _modname(name)
        if key in seen:
            return
        seen.add(key)
        if key in dep:
            path, deps = dep[key]
            for d in reversed(deps):  # modules.dep lists the deepest last
                add(d, name)
            order.append(moddir / path)
        elif key not in builtin:
            raise InfraError(
                f"kernel {moddir.name} has no module {name!r} "
                f"(needed for {why}); is linux-image-amd64 complete?"
            )

    wanted = VM_MODULES + os.environ.get("AACMM_VCAN_EXTRA_MODULES", "").split()
    for m in wanted:
        if "/" in m:  # an explicit .ko file (tests use this)
            if not Path(m).is_file():
                raise InfraError(f"AACMM_VCAN_EXTRA_MODULES: no such file {m}")
            if m not in seen:
                seen.add(m)
                order.append(Path(m))
        else:
            add(m, "the vcan VM")
    return order


def _read_module(path: Path) -> bytes:
    data = path.read_bytes()
    name = path.name
    if name.endswith(".xz"):
        return lzma.decompress(data)
    if name.endswith(".gz"):
        return gzip.decompress(data)
    if name.endswith(".zst"):
        zstd = shutil.which("zstd")
        if not zstd:
            raise InfraError(
                f"{path} is zstd-compressed and there is no zstd; apt-get install zstd"
            )
        return subprocess.run([zstd, "-dc", str(path)], capture_output=True, check=True).stdout
    return data


def _is_static_elf(path: Path) -> bool:
    with open(path, "rb") as f:
        hdr = f.read(64)
        if hdr[:4] != b"\x7fELF" or hdr[4] != 2:
            return False
        phoff = int.from_bytes(hdr[32:40], "little")
        phentsize = int.from_bytes(hdr[54:56], "little")
        phnum = int.from_bytes(hdr[56:58], "little")
        f.seek(phoff)
        table = f.read(phentsize * phnum)
    for i in range(phnum):
        if int.from_bytes(table[i * phentsize : i * phentsize + 4], "little") == 3:  # PT_INTERP
            return False
    return True


class Cpio:
    """Minimal writer for the "newc" cpio format the kernel unpacks."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []
        self.ino = 1

    def _entry(
        self, name: str, mode: int, data: bytes = b"", rdev: tuple[int, int] = (0, 0)
    ) -> None:
        nm = name.encode() + b"\0"
        fields = [self.ino, mode, 0, 0, 1, 0, len(data), 0, 0, rdev[0], rdev[1], len(nm), 0]
        self.ino += 1
        hdr = b"070701" + b"".join(b"%08X" % x for x in fields) + nm
        hdr += b"\0" * (-len(hdr) % 4)
        self.parts.append(hdr + data + b"\0" * (-len(data) % 4))

    def dir(self, name: str) -> None:
        self._entry(name, stat.S_IFDIR | 0o755)

    def file(self, name: str, data: bytes, perm: int = 0o644) -> None:
        self._entry(name, stat.S_IFREG | perm, data)

    def chardev(self, name: str, major: int, minor: int) -> None:
        self._entry(name, stat.S_IFCHR | 0o600, rdev=(major, minor))

    def bytes(self) -> bytes:
        self._entry("TRAILER!!!", 0)
        out = b"".join(self.parts)
        return out + b"\0" * (-len(out) % 512)


def build_initramfs(build: Path, ver: str, moddir: Path) -> Path:
    busybox = Path(os.environ.get("AACMM_VCAN_BUSYBOX", "/bin/busybox"))
    if not busybox.is_file():
        raise InfraError(f"no {busybox}; apt-get install busybox-static (or make setup)")
    if not _is_static_elf(busybox):
        raise InfraError(f"{busybox} is not a static binary; apt-get install busybox-static")
    mods = resolve_modules(moddir)
    init = INIT_SCRIPT.read_bytes()

    h = hashlib.sha256()
    h.update(f"{FORMAT_VERSION}\0{ver}\0".encode())
    h.update(init)
    for p in [busybox, *mods]:
        st = p.stat()
        h.update(f"{p}\0{st.st_size}\0{st.st_mtime_ns}\0".encode())
    out = build / f"initramfs-{ver}-{h.hexdigest()[:12]}.cpio"
    if out.is_file():
        os.utime(out)  # mtime = last use, for the clean-up below
        return out

    c = Cpio()
    for d in ("bin", "dev", "proc", "sys", "newroot", "hosttmp", "tmp", "lib", "lib/modules"):
        c.dir(d)
    c.chardev("dev/console", 5, 1)
    c.chardev("dev/null", 1, 3)
    c.file("bin/busybox", busybox.read_bytes(), 0o755)
    c.file("init", init, 0o755)
    for i, m in enumerate(mods):
        c.file(f"lib/modules/{i:03d}-{_modname(m.name)}.ko", _read_module(m))
    tmp = out.with_suffix(f".tmp{os.getpid()}")
    tmp.write_bytes(c.bytes())
    os.replace(tmp, out)
    for old in build.glob("initramfs-*.cpio"):
        if old != out and time.time() - old.stat().st_mtime > 3600:
            old.unlink(missing_ok=True)  # stale ones; recent ones may be in use
    return out


# --------------------------------------------------------------------------
# VM: the run


def _tmp_binds(paths: list[str]) -> list[str]:
    names = set()
    for p in paths:
        if not p:
            continue
        for q in {os.path.abspath(p), os.path.realpath(p)}:
            parts = Path(q).parts
            if len(parts) >= 3 and parts[0] == "/" and parts[1] == "tmp":
                if os.path.lexists(os.path.join("/tmp", parts[2])):
                    names.add(parts[2])
    return sorted(names)


def write_job(jobdir: Path, cmd: list[str], env: dict[str, str], ipexe: str) -> None:
    q = shlex.quote
    cwd = os.getcwd()
    mask = os.umask(0o22)
    os.umask(mask)
    lines = ["# generated by tests/vcan/vcan_runner.py", f"umask {mask:04o}"]
    lines += [f"export {k}={q(v)}" for k, v in sorted(env.items())]
    lines += [
        f"cd {q(cwd)} || {{ echo {q(f'run-in-vcan: cannot cd to {cwd} in the VM')} >&2; "
        f"exit {EXIT_INFRA}; }}",
        "exec " + " ".join(q(a) for a in cmd),
    ]
    (jobdir / "job.sh").write_text("\n".join(lines) + "\n")
    setup = ["set -e", f"{q(ipexe)} link set lo up"]
    for name in ifaces():
        setup += [f"{q(ipexe)} link add dev {name} type vcan", f"{q(ipexe)} link set up {name}"]
    (jobdir / "setup.sh").write_text("\n".join(setup) + "\n")
    binds = _tmp_binds(
        [
            cwd,
            str(REPO),
            str(jobdir),
            resolve_command(cmd[0], env.get("PATH", "")) or "",
            *[a for a in cmd[1:] if a.startswith("/tmp/")],
            env.get("VIRTUAL_ENV", ""),
            *env.get("PYTHONPATH", "").split(":"),
        ]
    )
    (jobdir / "tmpbinds").write_text("".join(b + "\n" for b in binds))


def _set_pdeathsig() -> None:
    # QEMU dies with us even if we are SIGKILLed.
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass  # best effort: the runner also kills QEMU on every exit path


class VmRun:
    def __init__(self, jobdir: Path, verbose: bool) -> None:
        self.jobdir = jobdir
        self.verbose = verbose
        self.console = open(jobdir / "console.log", "w", errors="replace")
        self.stages: dict[str, float] = {}
        self.errors: list[str] = []
        self.dmesg: list[str] = []
        self.exit_line: int | None = None
        self.exit_seen = threading.Event()
        self.exit_seen_at = 0.0
        self.command_started = threading.Event()
        self.lock = threading.Lock()
        self.t0 = time.monotonic()

    def console_reader(self, fd: int) -> None:
        buf = b""
        with os.fdopen(fd, "rb", buffering=0) as f:
            while True:
                chunk = f.read(4096)
                if not chunk:
                    break
                buf += chunk
                while b"\n" in buf:
                    line, buf = buf.split(b"\n", 1)
                    self._console_line(line)
        if buf:
            self._console_line(buf)
        self.console.flush()

    def _console_line(self, raw: bytes) -> None:
        line = raw.decode("utf-8", "replace").replace("\r", "")
        with self.lock:
            self.console.write(line + "\n")
            self.console.flush()
        if self.verbose:
            log(f"console: {line}")
        m = PROTO.search(line)
        if not m:
            return
        kind, val = m.groups()
        if kind == "STAGE":
            name = val.split()[0] if val.split() else "?"
            self.stages[name] = time.monotonic() - self.t0
            if name == "command":
                self.command_started.set()
        elif kind == "ERROR":
            self.errors.append(val)
            log(f"VM: {val}")
        elif kind == "DMESG":
            self.dmesg.append(val)
        elif kind == "EXIT":
            try:
                self.exit_line = int(val.strip().split()[0])
            except (ValueError, IndexError):
                pass
            self.exit_seen_at = time.monotonic()
            self.exit_seen.set()

    @staticmethod
    def copy_reader(fd: int, out) -> None:  # type: ignore[no-untyped-def]
        with os.fdopen(fd, "rb", buffering=0) as f:
            while True:
                chunk = f.read(65536)
                if not chunk:
                    break
                try:
                    out.write(chunk)
                    out.flush()
                except (BrokenPipeError, ValueError):
                    pass

    def console_tail(self, n: int = 12) -> str:
        """The console's telling lines (panics, oopses) and its last n lines."""
        try:
            lines = (self.jobdir / "console.log").read_text(errors="replace").splitlines()
        except OSError:
            return ""
        key = [x for x in lines[:-n] if KERNEL_TROUBLE.search(x)][:8]
        if key:
            key.append("...")
        return "\n".join("  | " + x for x in key + lines[-n:])


def run_vm(cmd: list[str], timeout: float) -> int:
    qemu = os.environ.get("AACMM_VCAN_QEMU", "qemu-system-x86_64")
    qemu_exe = shutil.which(qemu)
    if not qemu_exe:
        raise InfraError(f"{qemu} not found; apt-get install qemu-system-x86 (or make setup)")
    ver, kernel, moddir = find_kernel()
    ipexe = _ip()
    if not ipexe:
        raise InfraError("no ip(8) on the host (the VM uses the host's); apt-get install iproute2")
    default = str(REPO / "build" / "vcan")
    build = Path(os.environ.get("AACMM_VCAN_BUILD", default)).absolute()  # job dirs, logs
    cache = Path(os.environ.get("AACMM_VCAN_CACHE", default)).absolute()  # vmlinux, initramfs
    build.mkdir(parents=True, exist_ok=True)
    cache.mkdir(parents=True, exist_ok=True)
    initrd = build_initramfs(cache, ver, moddir)
    image = boot_image(cache, ver, kernel, moddir)

    jobdir = build / f"run-{os.getpid()}-{int(time.time())}"
    if re.search(r"[\s\"'\\]", str(jobdir)):
        raise InfraError(
            f"the build directory path {build} contains blanks or quotes; "
            "set AACMM_VCAN_BUILD to a plain path"
        )
    jobdir.mkdir()
    try:
        return _run_job(cmd, timeout, jobdir, build, qemu_exe, ver, image, initrd, ipexe)
    finally:
        if not env_flag("AACMM_VCAN_KEEP"):
            shutil.rmtree(jobdir, ignore_errors=True)


def _run_job(
    cmd: list[str],
    timeout: float,
    jobdir: Path,
    build: Path,
    qemu_exe: str,
    ver: str,
    image: Path,
    initrd: Path,
    ipexe: str,
) -> int:
    env = child_env("vm")
    write_job(jobdir, cmd, env, ipexe)
    cache = os.environ.get("AACMM_VCAN_9P_CACHE", "loose")
    if cache not in ("none", "loose", "mmap", "fscache"):
        raise InfraError(f"AACMM_VCAN_9P_CACHE={cache!r}: use none, loose, mmap or fscache")
    mem = int(env_num("AACMM_VCAN_MEM", 1024))
    smp = int(env_num("AACMM_VCAN_SMP", 2))
    boot_timeout = env_num("AACMM_VCAN_BOOT_TIMEOUT", 120)
    verbose = env_flag("AACMM_VCAN_VERBOSE")

    # passthrough keeps the guest's file ownership, which needs root on the
    # host; "none" is the same minus the chown, for unprivileged runs.
    security = "passthrough" if os.geteuid() == 0 else "none"
    con_r, con_w = os.pipe()
    out_r, out_w = os.pipe()
    err_r, err_w = os.pipe()
    append = (
        f"console=ttyS0 quiet loglevel=3 panic=-1 8250.nr_uarts=4 "
        f"aacmm_job={jobdir} aacmm_9p_cache={cache}"
    )
    # fmt: off
    argv = [
        qemu_exe, "-accel", "tcg", "-cpu", "max", "-m", str(mem), "-smp", str(smp),
        "-nodefaults", "-no-user-config", "-display", "none", "-no-reboot",
        "-kernel", str(image), "-initrd", str(initrd), "-append", append,
        # ttyS0: console, ttyS1: the command's stdout, ttyS2: its stderr
        "-chardev", f"file,id=con,path=/dev/fd/{con_w}", "-serial", "chardev:con",
        "-chardev", f"file,id=out,path=/dev/fd/{out_w}", "-serial", "chardev:out",
        "-chardev", f"file,id=err,path=/dev/fd/{err_w}", "-serial", "chardev:err",
        "-fsdev", f"local,id=r,path=/,security_model={security},multidevs=remap",
        "-device", "virtio-9p-pci,fsdev=r,mount_tag=hostroot",
    ]
    # fmt: on
    run = VmRun(jobdir, verbose)
    qemu_log = open(jobdir / "qemu-stderr.log", "w+b")
    log(
        f"no vcan on the host kernel; booting a QEMU/TCG VM (kernel {ver}, "
        f"{smp} CPUs, {mem} MiB, timeout {timeout:.0f} s)"
    )
    try:
        proc = subprocess.Popen(
            argv,
            stdin=subprocess.DEVNULL,
            stdout=qemu_log,
            stderr=qemu_log,
            pass_fds=(con_w, out_w, err_w),
            preexec_fn=_set_pdeathsig,
        )  # no threads yet
    except OSError as e:
        raise InfraError(f"cannot start {qemu_exe}: {e}") from None
    finally:
        for fd in (con_w, out_w, err_w):
            os.close(fd)
    threads = [
        threading.Thread(target=run.console_reader, args=(con_r,), daemon=True),
        threading.Thread(target=VmRun.copy_reader, args=(out_r, sys.stdout.buffer), daemon=True),
        threading.Thread(target=VmRun.copy_reader, args=(err_r, sys.stderr.buffer), daemon=True),
    ]
    for t in threads:
        t.start()

    def stop_qemu() -> None:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=3)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()

    rc: int | None = None
    failure = ""
    try:
        deadline = run.t0 + timeout
        while True:
            try:
                proc.wait(timeout=0.2)
                break
            except subprocess.TimeoutExpired:
                pass
            now = time.monotonic()
            if now > deadline:
                failure = (
                    f"TIMEOUT: no result after {timeout:.0f} s (AACMM_VCAN_TIMEOUT); killed QEMU"
                )
                rc = EXIT_TIMEOUT
                break
            if (
                not run.command_started.is_set()
                and not run.exit_seen.is_set()
                and now - run.t0 > boot_timeout
            ):
                failure = (
                    f"VM did not reach the command within {boot_timeout:.0f} s "
                    "(AACMM_VCAN_BOOT_TIMEOUT); killed QEMU"
                )
                rc = EXIT_INFRA
                break
            if run.exit_seen.is_set() and now - run.exit_seen_at > 10:
                break  # reported but did not power off: stop it ourselves
    finally:
        stop_qemu()
        for t in threads:
            t.join(timeout=5)
        if failure:
            log(failure)
        run.console.close()
        shutil.copyfile(jobdir / "console.log", build / "last-console.log")

    qemu_log.seek(0)
    qemu_err = qemu_log.read().decode("utf-8", "replace").strip()
    qemu_log.close()
    reported: int | None = None
    try:
        reported = int((jobdir / "exit").read_text().strip())
    except (OSError, ValueError):
        reported = run.exit_line
    if rc is None:
        if reported is None:
            log(f"the VM stopped without reporting an exit status (QEMU exit {proc.returncode})")
            if qemu_err:
                log("QEMU said:\n" + "\n".join("  | " + x for x in qemu_err.splitlines()[-15:]))
            tail = run.console_tail()
            if tail:
                log(f"last console lines ({build / 'last-console.log'}):\n{tail}")
            rc = EXIT_INFRA
        else:
            rc = reported
            if rc == EXIT_INFRA and run.errors:
                log(f"VM infrastructure failure; console log: {build / 'last-console.log'}")
                for d in run.dmesg:
                    log(f"  dmesg: {d}")
    elif rc == EXIT_INFRA and not run.command_started.is_set():
        tail = run.console_tail()
        if tail:
            log(f"last console lines:\n{tail}")

    total = time.monotonic() - run.t0
    boot = run.stages.get("command")
    if boot is not None and "done" in run.stages:
        log(
            f"exit {rc} (VM ready in {boot:.1f} s, command {run.stages['done'] - boot:.1f} s, "
            f"total {total:.1f} s)"
        )
    else:
        log(f"exit {rc} (total {total:.1f} s)")
    return rc


# --------------------------------------------------------------------------

USAGE = """\
usage: run-in-vcan.sh [--mode auto|native|vm] [--timeout SECONDS] [--verbose] [--] CMD [ARG...]

Runs CMD with SocketCAN interface(s) vcan0 up: natively when the host kernel
supports vcan and we are root, else in a QEMU VM over the host's root.
Settings (environment): AACMM_VCAN_MODE, AACMM_VCAN_TIMEOUT (900),
AACMM_VCAN_BOOT_TIMEOUT (120), AACMM_VCAN_IFACES ("vcan0"), AACMM_VCAN_MEM,
AACMM_VCAN_SMP, AACMM_VCAN_KERNEL, AACMM_VCAN_ENV (extra variable names to
pass), AACMM_VCAN_9P_CACHE (loose), AACMM_VCAN_VERBOSE, AACMM_VCAN_KEEP.
See docs/testing-vcan.md."""


def main(argv: list[str]) -> int:
    args = list(argv)
    while args and args[0].startswith("-"):
        opt = args.pop(0)
        if opt == "--":
            break
        if opt in ("-h", "--help"):
            print(USAGE)
            return 0
        if opt in ("--mode", "--timeout") and args:
            os.environ["AACMM_VCAN_" + opt[2:].upper()] = args.pop(0)
        elif opt.startswith(("--mode=", "--timeout=")):
            k, v = opt[2:].split("=", 1)
            os.environ["AACMM_VCAN_" + k.upper()] = v
        elif opt in ("-v", "--verbose"):
            os.environ["AACMM_VCAN_VERBOSE"] = "1"
        else:
            log(f"unknown option {opt}\n{USAGE}")
            return 2
    if not args:
        log(f"no command given\n{USAGE}")
        return 2

    got = {"sig": 0}

    def on_signal(signum: int, _frame: object) -> None:
        got["sig"] = signum
        raise KeyboardInterrupt

    for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(s, on_signal)

    try:
        timeout = env_num("AACMM_VCAN_TIMEOUT", 900)
        mode = os.environ.get("AACMM_VCAN_MODE", "auto").strip() or "auto"
        if mode not in ("auto", "native", "vm"):
            raise InfraError(f"AACMM_VCAN_MODE={mode!r}: use auto, native or vm")
        env_path = os.environ.get("PATH", os.defpath)
        if not resolve_command(args[0], env_path):
            log(f"command not found: {args[0]}")
            return EXIT_NOTFOUND
        if mode in ("auto", "native"):
            reason = native_check()
            if reason is None:
                return run_native(args, timeout)
            if mode == "native":
                raise InfraError(f"AACMM_VCAN_MODE=native but {reason}")
        return run_vm(args, timeout)
    except InfraError as e:
        log(f"error: {e}")
        return EXIT_INFRA
    except KeyboardInterrupt:
        sig = got["sig"] or signal.SIGINT
        log(f"interrupted by {signal.Signals(sig).name}; stopped")
        return 128 + sig


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except BrokenPipeError:
        sys.exit(1)
    except OSError as e:
        if e.errno == errno.ENOSPC:
            log("error: no space left on device")
            sys.exit(EXIT_INFRA)
        raise
