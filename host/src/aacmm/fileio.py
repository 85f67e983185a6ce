"""Safe file handling for everything aacmm reads or writes.

**Output: one rule for every file.** A file aacmm writes never silently
replaces an existing one: it is refused (:class:`OutputExistsError`, one
line, exit status 2 in the CLI) unless the caller says ``force``. The data go
to a temporary file in the same directory (created exclusively, so a planted
file or symlink is never followed), which is flushed, fsynced and then
renamed over the target; the directory is fsynced after the rename. A reader
therefore sees the old file or the complete new one, never a torn one, and a
writer that fails half-way leaves the target as it was. Without ``force``
the final step is ``link()``, which fails if the name appeared meanwhile, so
even a file created during the write is not replaced.

- :func:`check_outputs`: refuse early, before a long computation or a device
  session (existing file, the same file twice, missing directory, a directory
  that takes no new file: read-only file system, no permission);
- :func:`check_output_dir`: the same for an output *folder* (a report folder,
  a session, the demo's folder) that is created only when it is written;
- :func:`atomic_output`: a context manager yielding the temporary file
  (text or binary), for ``csv.writer``, ``json.dump``, ``f.write``;
- :func:`write_output`: one call for a ``str`` or ``bytes``;
- :func:`save_figure`: a matplotlib figure, format by the suffix;
- :func:`atomic_path`: a temporary *path* (same suffix) for writers that
  insist on a file name (``Figure.savefig(path)``, python-can's ``Logger``,
  a library's ``write_csv(result, path)``).

**Input: bounded nesting.** :func:`load_toml`, :func:`load_json` and
:func:`load_structured` (by suffix) read a file and refuse, with one line,
anything that is not valid or is nested deeper than :data:`MAX_NESTING`
levels (arrays and tables), so a hostile file ends in
:class:`InputFileError` (exit status 2), never a ``RecursionError``.
:func:`loads_toml` and :func:`loads_json` do the same for text in hand.

Both error classes are :class:`~aacmm.errors.AacmmError` and
:class:`ValueError`.
"""

from __future__ import annotations

import contextlib
import json
import os
import stat
import tempfile
import tomllib
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO, Any, Final, Literal, overload

from aacmm.errors import AacmmError

__all__ = [
    "MAX_INPUT_BYTES",
    "MAX_NESTING",
    "InputFileError",
    "OutputExistsError",
    "OutputFileError",
    "atomic_output",
    "atomic_path",
    "check_output_dir",
    "check_outputs",
    "check_writable_dir",
    "load_json",
    "load_structured",
    "load_toml",
    "loads_json",
    "loads_toml",
    "nesting_depth",
    "read_text",
    "save_figure",
    "write_output",
]

MAX_NESTING: Final = 64
"""Deepest nesting of arrays and tables accepted in an input file."""
MAX_INPUT_BYTES: Final = 64 * 1024 * 1024
"""Largest TOML/JSON input file read (64 MiB): every aacmm input is far smaller."""

PathLike = str | os.PathLike[str]


class OutputFileError(AacmmError, ValueError):
    """An output file cannot be written (bad directory, a directory as target, ...)."""


class OutputExistsError(OutputFileError):
    """The output file exists and ``force`` was not given."""


class InputFileError(AacmmError, ValueError):
    """An input file cannot be read, is not valid TOML/JSON, or is nested too deeply."""


# ------------------------------------------------------------------ output


def _exists_message(path: Path) -> str:
    return f"{path} exists (use --force to overwrite)"


def _check_target(p: Path, force: bool) -> None:
    """Refuse an existing target unless ``force``; never replace anything but a
    regular file (a device, a FIFO, a directory, a link to one of them)."""
    if p.is_dir():
        raise OutputFileError(f"{p} is a directory")
    if not os.path.lexists(p):
        return
    if not force:
        raise OutputExistsError(_exists_message(p))
    try:
        regular = stat.S_ISREG(os.stat(p).st_mode)
    except OSError:
        regular = True  # a dangling link: replacing the link itself is harmless
    if not regular:
        raise OutputFileError(f"{p} is not a regular file (not replaced, even with --force)")


def check_writable_dir(directory: PathLike, what: str | None = None) -> None:
    """Refuse a directory in which this process cannot create a file.

    The test is the real thing: a temporary file is created exclusively in
    ``directory`` and removed at once (``access()`` would pass a read-only
    directory for root, and a read-only file system only at the write).
    ``what`` names the output in the message (default: the directory).

    Raises:
        OutputFileError: the directory does not exist, is not a directory, or
            takes no new file (read-only file system, no permission, full).
    """
    d = Path(directory)
    name = what or str(d)
    if not d.is_dir():
        gone = "is not a directory" if d.exists() else "does not exist"
        raise OutputFileError(f"{name}: directory {d} {gone}")
    try:
        fd, tmp = tempfile.mkstemp(dir=d, prefix=".aacmm-probe.", suffix=".tmp")
    except OSError as exc:
        raise OutputFileError(
            f"{name}: cannot create a file in {d}: {exc.strerror or exc}"
        ) from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(tmp)


def check_outputs(paths: Iterable[PathLike | None], force: bool = False) -> list[Path]:
    """Check the output files of a command before it starts its work.

    ``None`` entries (outputs not asked for) are skipped. Returns the paths.

    Raises:
        OutputExistsError: a file exists and ``force`` is false.
        OutputFileError: a path is given twice, names a directory or another
            non-regular file (device, FIFO), its directory does not exist, or
            its directory takes no new file (:func:`check_writable_dir`).
    """
    out: list[Path] = []
    seen: dict[Path, Path] = {}
    probed: set[Path] = set()
    for item in paths:
        if item is None:
            continue
        p = Path(item)
        key = p.resolve()
        if key in seen:
            raise OutputFileError(f"{p} is given twice as an output file")
        seen[key] = p
        _check_target(p, force)
        parent = key.parent
        if not parent.is_dir():
            raise OutputFileError(f"{p}: directory {parent} does not exist")
        if parent not in probed:
            check_writable_dir(parent, str(p))
            probed.add(parent)
        out.append(p)
    return out


def check_output_dir(
    directory: PathLike,
    names: Iterable[str] = (),
    force: bool = False,
    *,
    parents: bool = False,
    empty: bool = False,
    what: str | None = None,
) -> Path:
    """Check an output folder before the work starts, without creating it.

    The folder may exist (then it must be a directory that takes new files,
    holding none of ``names`` unless ``force``, and nothing at all with
    ``empty``) or not (then its parent must exist, or with ``parents`` its
    nearest existing ancestor, and take a new folder). Create it only when
    its files are written, so a refusal or a failed computation leaves no
    empty folder behind. ``what`` names it in messages (``--report DIR``).

    Raises:
        OutputExistsError: one of ``names`` exists and ``force`` is false.
        OutputFileError: not a directory, not empty (``empty``), a missing
            parent, or a place that takes no new file (read-only, ...).
    """
    d = Path(directory)
    name = what or str(d)
    if d.exists() or d.is_symlink():
        if not d.is_dir():
            raise OutputFileError(f"{name}: not a directory")
        if empty and any(d.iterdir()):
            raise OutputFileError(f"{name}: the folder is not empty")
        check_writable_dir(d, name)
        check_outputs([d / n for n in names], force)
        return d
    parent = d.resolve().parent
    if not parents and not parent.is_dir():
        gone = "is not a directory" if parent.exists() else "does not exist"
        raise OutputFileError(f"{name}: directory {parent} {gone}")
    base = parent
    while not base.exists():
        base = base.parent
    check_writable_dir(base, name)
    return d


def _umask() -> int:
    try:  # Linux: read it without changing it (no race with other threads)
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _fsync_dir(directory: Path) -> None:
    with contextlib.suppress(OSError):  # not every file system can
        fd = os.open(directory, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _commit(tmp: str, target: Path, force: bool) -> None:
    """Move the finished temporary file to ``target`` (no clobber unless ``force``)."""
    if force:
        os.replace(tmp, target)
        return
    try:
        os.link(tmp, target)  # atomic, and fails if the name exists
    except FileExistsError:
        raise OutputExistsError(_exists_message(target)) from None
    except OSError:
        # no hard links here (some FUSE, vfat): check, then rename
        if os.path.lexists(target):
            raise OutputExistsError(_exists_message(target)) from None
        os.replace(tmp, target)
        return
    os.unlink(tmp)


@overload
def atomic_output(
    path: PathLike,
    *,
    force: bool = ...,
    binary: Literal[False] = ...,
    encoding: str = ...,
    newline: str | None = ...,
) -> contextlib.AbstractContextManager[IO[str]]: ...
@overload
def atomic_output(
    path: PathLike,
    *,
    force: bool = ...,
    binary: Literal[True],
    encoding: str = ...,
    newline: str | None = ...,
) -> contextlib.AbstractContextManager[IO[bytes]]: ...
def atomic_output(
    path: PathLike,
    *,
    force: bool = False,
    binary: bool = False,
    encoding: str = "utf-8",
    newline: str | None = None,
) -> contextlib.AbstractContextManager[IO[Any]]:
    """Write ``path`` through a temporary file (see the module doc).

    Yields the open temporary file (text, or bytes with ``binary=True``;
    ``newline=""`` for ``csv.writer``). When the block ends normally the
    file is fsynced and renamed to ``path``; if it raises, the temporary
    file is removed and ``path`` is untouched. A new file gets the usual
    permissions (0666 less the umask); a replaced one keeps its mode.

    Raises:
        OutputExistsError: ``path`` exists (before or after the write) and
            ``force`` is false.
        OutputFileError: ``path`` is a directory, or its directory does not
            exist or refuses the temporary file.
        OSError: writing failed (disk full, ...); ``path`` is untouched.
    """
    return _atomic_output(Path(path), force, binary, encoding, newline)


def _temp_beside(p: Path, force: bool, suffix: str) -> tuple[int, str]:
    """Check the target and create the temporary file beside it (exclusively,
    with the target's future permissions). Returns the open fd and the path."""
    _check_target(p, force)
    directory = p.parent
    try:
        fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{p.name}.", suffix=suffix)
    except FileNotFoundError:
        raise OutputFileError(f"{p}: directory {directory.resolve()} does not exist") from None
    except OSError as exc:
        raise OutputFileError(f"{p}: cannot create a file in {directory}: {exc.strerror}") from None
    try:
        try:
            mode = os.stat(p).st_mode & 0o7777 if force else None
        except OSError:
            mode = None
        os.fchmod(fd, mode if mode is not None else 0o666 & ~_umask())
    except BaseException:
        os.close(fd)
        os.unlink(tmp)
        raise
    return fd, tmp


@contextlib.contextmanager
def _atomic_output(
    p: Path, force: bool, binary: bool, encoding: str, newline: str | None
) -> Iterator[IO[Any]]:
    fd, tmp = _temp_beside(p, force, ".tmp")
    try:
        if binary:
            f: IO[Any] = os.fdopen(fd, "wb")
        else:
            f = os.fdopen(fd, "w", encoding=encoding, newline=newline)
        with f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        _commit(tmp, p, force)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _fsync_dir(p.parent)


@contextlib.contextmanager
def atomic_path(path: PathLike, *, force: bool = False) -> Iterator[Path]:
    """Like :func:`atomic_output`, but yields the temporary file's *path* for a
    writer that opens the file itself. The temporary name ends in the target's
    suffix (``.mc.png.k2j4x.tmp.png``), so writers that choose a format by the
    suffix choose the same one. When the block ends normally the file is
    fsynced and renamed to ``path``; if it raises, it is removed.

    Raises: as :func:`atomic_output` (also ``OSError`` if the writer removed the file).
    """
    p = Path(path)
    fd, tmp = _temp_beside(p, force, f".tmp{p.suffix}")
    os.close(fd)
    try:
        yield Path(tmp)
        # the writer opened the file by name (perhaps replaced it): fsync by name
        fd = os.open(tmp, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        _commit(tmp, p, force)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _fsync_dir(p.parent)


def write_output(path: PathLike, data: str | bytes, *, force: bool = False) -> None:
    """Write ``data`` (text as UTF-8, or bytes) to ``path`` atomically.

    Raises: as :func:`atomic_output`.
    """
    if isinstance(data, bytes):
        with atomic_output(path, force=force, binary=True) as fb:
            fb.write(data)
    else:
        with atomic_output(path, force=force) as ft:
            ft.write(data)


def save_figure(fig: Any, path: PathLike, *, force: bool = False, **savefig: Any) -> None:
    """Save a matplotlib figure atomically; the format follows the suffix (``.png``, ...).

    ``savefig`` keyword arguments (``dpi``, ...) go to ``Figure.savefig``.

    Raises: as :func:`atomic_output`; ``ValueError`` for a format matplotlib
    does not know.
    """
    suffix = Path(path).suffix.lower().lstrip(".")
    savefig.setdefault("format", suffix or "png")
    with atomic_output(path, force=force, binary=True) as f:
        fig.savefig(f, **savefig)


# ------------------------------------------------------------------ input


def nesting_depth(value: Any) -> int:
    """Depth of nested lists and dicts in ``value`` (a scalar is 0), without recursion."""
    depth = 0
    stack: list[tuple[Any, int]] = [(value, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, dict):
            children: Iterable[Any] = v.values()
        elif isinstance(v, list):
            children = v
        else:
            continue
        depth = max(depth, d)
        stack.extend((c, d + 1) for c in children)
    return depth


def _too_deep(src: str) -> InputFileError:
    return InputFileError(f"{src}: nested too deeply (more than {MAX_NESTING} levels)")


def _checked(data: Any, src: str) -> Any:
    if nesting_depth(data) > MAX_NESTING:
        raise _too_deep(src)
    return data


def loads_toml(text: str, src: str = "input") -> dict[str, Any]:
    """Parse TOML text (``src`` names it in messages).

    Raises:
        InputFileError: not valid TOML, or nested deeper than :data:`MAX_NESTING`.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputFileError(f"{src}: not valid TOML: {exc}") from None
    except RecursionError:
        raise _too_deep(src) from None
    except ValueError as exc:  # e.g. an integer with too many digits
        raise InputFileError(f"{src}: not valid TOML: {exc}") from None
    result: dict[str, Any] = _checked(data, src)
    return result


def loads_json(text: str, src: str = "input") -> Any:
    """Parse JSON text (``src`` names it in messages).

    Raises:
        InputFileError: not valid JSON, or nested deeper than :data:`MAX_NESTING`.
    """
    try:
        data = json.loads(text)
    except RecursionError:
        raise _too_deep(src) from None
    except ValueError as exc:  # JSONDecodeError, too many digits, ...
        raise InputFileError(f"{src}: not valid JSON: {exc}") from None
    return _checked(data, src)


def read_text(path: PathLike) -> str:
    """A text file as hostile input: at most :data:`MAX_INPUT_BYTES`, UTF-8 (a
    leading byte-order mark is dropped).

    Raises:
        InputFileError: unreadable, too large, or not UTF-8.
    """
    path = Path(path)
    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_INPUT_BYTES + 1)
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if len(raw) > MAX_INPUT_BYTES:
        raise InputFileError(f"{path}: larger than {MAX_INPUT_BYTES} bytes")
    try:
        return raw.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as exc:
        raise InputFileError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def load_toml(path: PathLike) -> dict[str, Any]:
    """Read a TOML file (UTF-8, at most :data:`MAX_INPUT_BYTES`).

    Raises:
        InputFileError: unreadable, too large, not UTF-8, not valid TOML, or
            nested deeper than :data:`MAX_NESTING`.
    """
    p = Path(path)
    return loads_toml(read_text(p), str(p))


def load_json(path: PathLike) -> Any:
    """Read a JSON file (UTF-8, at most :data:`MAX_INPUT_BYTES`).

    Raises:
        InputFileError: unreadable, too large, not UTF-8, not valid JSON, or
            nested deeper than :data:`MAX_NESTING`.
    """
    p = Path(path)
    return loads_json(read_text(p), str(p))


def load_structured(path: PathLike) -> Any:
    """Read a ``.toml`` or ``.json`` file, by its suffix.

    Raises:
        InputFileError: another suffix, or as :func:`load_toml` / :func:`load_json`.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix == ".toml":
        return load_toml(p)
    if suffix == ".json":
        return load_json(p)
    raise InputFileError(f"{p}: unknown format (use a .toml or .json file)")
