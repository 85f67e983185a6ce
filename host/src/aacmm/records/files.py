"""File mechanics shared by logs and sessions: row writers with a flush
policy, durable appends, atomic JSON replacement, and bounded, hostile-input-safe
readers of CSV and JSON.

Durability vocabulary used in the docs:

* *flushed*: handed to the operating system in one ``write`` of whole rows; a
  process killed with SIGKILL loses nothing flushed, a power cut may.
* *durable*: flushed and ``fsync``-ed (for a rename: the directory too); a
  power cut loses nothing durable.
"""

from __future__ import annotations

import contextlib
import csv
import datetime as dt
import json
import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from aacmm.errors import AacmmError
from aacmm.fileio import InputFileError, load_json, write_output


class RecordError(AacmmError, ValueError):
    """A recorded file (log, session) that cannot be read or breaks its format.

    The message is one line naming the file (and the line where it applies).
    """


def utc_iso(t: float) -> str:
    """Unix time as ISO 8601 UTC with microseconds."""
    return dt.datetime.fromtimestamp(t, dt.UTC).isoformat(timespec="microseconds")


def fmt_point(v: int) -> str:
    """A coordinate in 1e-4 mm as an exact decimal string in mm (``-12.3456``)."""
    sign = "-" if v < 0 else ""
    q, r = divmod(abs(v), 10000)
    return f"{sign}{q}.{r:04d}"


def crc_hex(crc: int) -> str:
    """A parameter-set CRC as written in the files: ``0x`` and 8 hex digits."""
    return f"0x{crc:08x}"


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        n = os.write(fd, view)
        view = view[n:]


def fsync_dir(path: Path) -> None:
    """fsync a directory (so a rename or a new file in it is durable); best effort."""
    with contextlib.suppress(OSError):
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def write_atomic(path: Path, data: bytes) -> None:
    """Replace ``path`` with ``data`` atomically and durably (:func:`aacmm.fileio.write_output`:
    a temporary file in the same directory, fsync, rename, fsync of the directory)."""
    write_output(path, data, force=True)


def write_json_atomic(path: Path, data: dict[str, Any]) -> None:
    """:func:`write_atomic` of ``data`` as indented JSON."""
    write_atomic(path, (json.dumps(data, indent=2) + "\n").encode("utf-8"))


def read_json(path: Path, what: str = "sidecar") -> dict[str, Any]:
    """A JSON object from a file, refusing huge, deeply nested or non-object content
    (:func:`aacmm.fileio.load_json`).

    Raises:
        RecordError: unreadable, too large, bad JSON, nested too deeply, not an object.
    """
    try:
        obj = load_json(path)
    except InputFileError as exc:
        raise RecordError(f"{what} {exc}") from None
    if not isinstance(obj, dict):
        raise RecordError(f"{path}: {what} must be a JSON object")
    return obj


class RowFile:
    """A CSV file written in whole rows: rows are buffered and handed to the OS
    every ``interval`` seconds or ``rows`` rows, whichever comes first, each time
    in one ``write``; ``fsync`` at :meth:`close`.

    Raises (constructor):
        FileExistsError: ``path`` exists and ``overwrite`` is false.
        OSError: it cannot be created.
    """

    def __init__(
        self,
        path: Path,
        columns: tuple[str, ...],
        overwrite: bool,
        interval: float = 0.25,
        rows: int = 256,
    ) -> None:
        self.path = path
        self.interval = interval
        self.max_rows = rows
        self.rows = 0
        self._buf: list[str] = []
        self._last_flush = time.monotonic()
        flags = os.O_WRONLY | os.O_CREAT | (os.O_TRUNC if overwrite else os.O_EXCL)
        self._fd: int | None = os.open(path, flags, 0o644)
        _write_all(self._fd, (",".join(columns) + "\n").encode())

    def add(self, line: str) -> None:
        """Queue one row (with its ``\\n``)."""
        self._buf.append(line)
        self.rows += 1
        if len(self._buf) >= self.max_rows:
            self.flush()

    def maybe_flush(self, now: float) -> None:
        if self._buf and now - self._last_flush >= self.interval:
            self.flush()

    def flush(self) -> None:
        self._last_flush = time.monotonic()
        if self._buf and self._fd is not None:
            data = "".join(self._buf).encode()
            self._buf.clear()
            _write_all(self._fd, data)

    def close(self) -> None:
        if self._fd is None:
            return
        try:
            self.flush()
            with contextlib.suppress(OSError):
                os.fsync(self._fd)
        finally:
            os.close(self._fd)
            self._fd = None


class DurableAppender:
    """A CSV file whose every row is durable when :meth:`append` returns
    (one ``write`` of the whole row, then ``fsync``): what a program acknowledged
    survives a kill -9 or a power cut. Rows can be rewritten atomically
    (:meth:`rewrite`), e.g. after an undo."""

    def __init__(self, path: Path, columns: tuple[str, ...], create: bool) -> None:
        self.path = path
        self.columns = columns
        if create:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            _write_all(fd, (",".join(columns) + "\n").encode())
            os.fsync(fd)
            os.close(fd)
            fsync_dir(path.parent)
        self._fd: int | None = os.open(path, os.O_WRONLY | os.O_APPEND)

    def append(self, line: str) -> None:
        assert self._fd is not None
        _write_all(self._fd, line.encode())
        os.fsync(self._fd)

    def rewrite(self, lines: list[str]) -> None:
        """Replace the whole file (header + ``lines``) atomically and durably."""
        self.close()
        header = ",".join(self.columns) + "\n"
        write_atomic(self.path, (header + "".join(lines)).encode())
        self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND)

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


def truncate_partial_line(path: Path) -> bool:
    """Cut a last line that has no ``\\n`` (a write cut by a kill); True if cut."""
    with open(path, "rb+") as f:
        f.seek(0, os.SEEK_END)
        size = f.tell()
        if size == 0:
            return False
        f.seek(size - 1)
        if f.read(1) == b"\n":
            return False
        f.seek(0)
        data = f.read()
        keep = data.rfind(b"\n") + 1
        f.truncate(keep)
        f.flush()
        os.fsync(f.fileno())
        return True


class CsvTable:
    """A CSV file read whole: the header (lower-cased, stripped), the data rows with
    their line numbers, and whether the last line was cut short (no ``\\n``, as a
    writer killed mid-row leaves it: that row is dropped).

    Lines starting with ``#`` and blank lines are skipped.

    Raises (constructor):
        RecordError: unreadable, not UTF-8, or no header row.
    """

    def __init__(self, path: Path, what: str = "file") -> None:
        self.path = path
        try:
            raw = path.read_bytes()
        except OSError as exc:
            raise RecordError(f"{path}: cannot read {what}: {exc.strerror or exc}") from None
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise RecordError(
                f"{path}: cannot read {what}: not UTF-8 text ({exc.reason})"
            ) from None
        self.cut_short = bool(text) and not text.endswith("\n")
        lines = text.split("\n")
        if self.cut_short:
            lines = lines[:-1]
        numbered = [
            (i + 1, line.rstrip("\r"))
            for i, line in enumerate(lines)
            if line.strip() and not line.lstrip().startswith("#")
        ]
        if not numbered:
            raise RecordError(f"{path}: empty {what} (no header row)")
        try:
            parsed = list(csv.reader(line for _, line in numbered))
        except csv.Error as exc:
            raise RecordError(f"{path}: {what} is not CSV: {exc}") from None
        self.header = [h.strip().lower() for h in parsed[0]]
        self.header_line = numbered[0][0]
        self.rows: list[tuple[int, list[str]]] = [
            (numbered[i][0], row) for i, row in enumerate(parsed) if i > 0
        ]

    def has(self, *columns: str) -> bool:
        return all(c in self.header for c in columns)

    def index(self, column: str) -> int:
        return self.header.index(column)

    def __iter__(self) -> Iterator[tuple[int, list[str]]]:
        return iter(self.rows)

    def __len__(self) -> int:
        return len(self.rows)

    def fail(self, line: int, problem: str) -> RecordError:
        return RecordError(f"{self.path}:{line}: {problem}")
