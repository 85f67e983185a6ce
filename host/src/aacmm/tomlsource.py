"""Line numbers of the keys of a TOML document, for error messages that
point at the source (plans, arm models: any ``SourceFileError``).

``tomllib`` reports the position of a *syntax* error only; a file's
semantic errors (unknown artefact, negative length, missing field) need the
line of the key or table they concern. :func:`key_lines` walks a document
that ``tomllib`` has already accepted and returns the line of every key path
it defines: table headers, ``key = value`` pairs (dotted keys too), keys of
inline tables and elements of arrays, with array-of-tables entries numbered
as ``tomllib`` numbers them.

A path is a tuple of keys (``str``) and array indices (``int``), e.g.
``("steps", 2, "positions", 4, "centre_mm")``. :func:`line_of` finds the
line of a path or, failing that, of its nearest ancestor that has one (a
missing field is reported at its table's header).

The scanner only has to be right about structure, never about values: the
document is valid TOML, so scalars are skipped up to the next delimiter and
strings (the four kinds) are skipped whole.
"""

from __future__ import annotations

from typing import Any, ClassVar, NoReturn

from aacmm.errors import SourceFileError

Path = tuple[str | int, ...]

_BARE = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-")
_ESCAPES = {"b": "\b", "t": "\t", "n": "\n", "f": "\f", "r": "\r", '"': '"', "\\": "\\"}


class _Scanner:
    def __init__(self, text: str) -> None:
        self.s = text
        self.i = 0
        self.line = 1
        self.lines: dict[Path, int] = {}
        self.aot_count: dict[Path, int] = {}  # array-of-tables lengths, by parent path

    # ------------------------------------------------------------ characters

    def peek(self, k: int = 0) -> str:
        j = self.i + k
        return self.s[j] if j < len(self.s) else ""

    def advance(self, n: int = 1) -> None:
        for _ in range(n):
            if self.i < len(self.s):
                if self.s[self.i] == "\n":
                    self.line += 1
                self.i += 1

    def skip_ws(self) -> None:
        while self.peek() in (" ", "\t"):
            self.advance()

    def skip_ws_nl_comments(self) -> None:
        while True:
            c = self.peek()
            if c in (" ", "\t", "\r", "\n"):
                self.advance()
            elif c == "#":
                self.skip_comment()
            else:
                return

    def skip_comment(self) -> None:
        while self.peek() not in ("", "\n"):
            self.advance()

    # ------------------------------------------------------------ strings and keys

    def read_string(self) -> str:
        """Read one string of any of the four kinds; return its value (escapes decoded
        for basic strings, enough for keys)."""
        q = self.peek()
        triple = self.s.startswith(q * 3, self.i)
        if triple:
            self.advance(3)
            end = q * 3
            start = self.i
            while not self.s.startswith(end, self.i):
                if q == '"' and self.peek() == "\\":
                    self.advance()
                if self.peek() == "":
                    break
                self.advance()
            # up to two more quotes may belong to the string (""""a""""")
            while self.s.startswith(q * 4, self.i):
                self.advance()
            value = self.s[start : self.i]
            self.advance(3)
            return value
        self.advance()
        out: list[str] = []
        while self.peek() not in (q, ""):
            c = self.peek()
            if q == '"' and c == "\\":
                self.advance()
                e = self.peek()
                if e in _ESCAPES:
                    out.append(_ESCAPES[e])
                    self.advance()
                elif e in ("u", "U"):
                    n = 4 if e == "u" else 8
                    self.advance()
                    out.append(chr(int(self.s[self.i : self.i + n], 16)))
                    self.advance(n)
                continue
            out.append(c)
            self.advance()
        self.advance()
        return "".join(out)

    def read_key(self) -> list[str]:
        """A possibly dotted key."""
        parts: list[str] = []
        while True:
            self.skip_ws()
            if self.peek() in ('"', "'"):
                parts.append(self.read_string())
            else:
                start = self.i
                while self.peek() in _BARE and self.peek() != "":
                    self.advance()
                parts.append(self.s[start : self.i])
            self.skip_ws()
            if self.peek() == ".":
                self.advance()
                continue
            return parts

    # ------------------------------------------------------------ values

    def note(self, path: Path, line: int) -> None:
        self.lines.setdefault(path, line)

    def read_value(self, path: Path) -> None:
        self.skip_ws()
        c = self.peek()
        if c in ('"', "'"):
            self.read_string()
        elif c == "[":
            self.read_array(path)
        elif c == "{":
            self.read_inline_table(path)
        else:  # number, bool, date: up to a delimiter
            while self.peek() not in ("", ",", "]", "}", "\n", "#") and not (
                self.peek() == " " and self.peek(1) in ("", ",", "]", "}", "\n", "#", " ")
            ):
                self.advance()

    def read_array(self, path: Path) -> None:
        self.advance()  # [
        k = 0
        while True:
            self.skip_ws_nl_comments()
            if self.peek() in ("]", ""):
                self.advance()
                return
            self.note((*path, k), self.line)
            self.read_value((*path, k))
            k += 1
            self.skip_ws_nl_comments()
            if self.peek() == ",":
                self.advance()

    def read_inline_table(self, path: Path) -> None:
        self.advance()  # {
        while True:
            self.skip_ws()
            if self.peek() in ("}", ""):
                self.advance()
                return
            line = self.line
            key = self.read_key()
            sub: Path = (*path, *key)
            for j in range(len(key)):
                self.note((*path, *key[: j + 1]), line)
            self.skip_ws()
            self.advance()  # =
            self.read_value(sub)
            self.skip_ws()
            if self.peek() == ",":
                self.advance()

    # ------------------------------------------------------------ document

    def run(self) -> dict[Path, int]:
        table: Path = ()
        while True:
            self.skip_ws_nl_comments()
            c = self.peek()
            if c == "":
                return self.lines
            line = self.line
            if c == "[":
                aot = self.peek(1) == "["
                self.advance(2 if aot else 1)
                key = self.read_key()
                self.advance(2 if aot else 1)
                table = self._resolve(key, aot)
                self.note(table, line)
                if aot:
                    self.note(table[:-1], line)
                continue
            key = self.read_key()
            for j in range(len(key)):
                self.note((*table, *key[: j + 1]), line)
            self.skip_ws()
            self.advance()  # =
            self.read_value((*table, *key))

    def _resolve(self, key: list[str], aot: bool) -> Path:
        """The full path of a table header, with array-of-tables indices filled in."""
        path: list[str | int] = []
        for j, part in enumerate(key):
            path.append(part)
            prefix = tuple(path)
            last = j == len(key) - 1
            if last and aot:
                n = self.aot_count.get(prefix, 0)
                self.aot_count[prefix] = n + 1
                path.append(n)
            elif prefix in self.aot_count:  # inside the latest element of an array of tables
                path.append(self.aot_count[prefix] - 1)
        return tuple(path)


def key_lines(text: str) -> dict[Path, int]:
    """The line (1-based) of every key path of a valid TOML document."""
    return _Scanner(text).run()


def line_of(lines: dict[Path, int], path: Path) -> int | None:
    """The line of ``path`` or of its nearest ancestor that has one (None for the root)."""
    p = tuple(path)
    while p:
        if p in lines:
            return lines[p]
        p = p[:-1]
    return None


def format_path(path: Path) -> str:
    """``steps[2].positions[4].centre_mm``."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            text = part if part and all(c in _BARE for c in part) else f'"{part}"'
            out += f".{text}" if out else text
    return out


def value_kind(v: Any) -> str:
    """What a TOML value is, in a message's words ("an integer", "a table", ...)."""
    return {
        bool: "true/false",
        int: "an integer",
        float: "a number",
        str: "a string",
        list: "a list",
        dict: "a table",
    }.get(type(v), type(v).__name__)


class SourceContext:
    """A TOML document being checked: its name and the line of every key, to
    raise :attr:`error` (a :class:`~aacmm.errors.SourceFileError` subclass)
    at ``FILE:LINE: FIELD``. Subclasses set :attr:`error` and may name fields
    their own way (:meth:`field`)."""

    error: ClassVar[type[SourceFileError]] = SourceFileError

    def __init__(self, name: str, text: str) -> None:
        self.name = name
        self.lines = key_lines(text)

    def field(self, path: Path) -> str:
        """How a path is named in a message (default :func:`format_path`)."""
        return format_path(path)

    def fail(self, path: Path, problem: str) -> NoReturn:
        raise self.error(self.name, line_of(self.lines, path), self.field(path), problem)

    def keys(self, table: dict[str, Any], path: Path, allowed: tuple[str, ...]) -> None:
        """Fail at the first key of ``table`` that is not ``allowed``."""
        for k in table:
            if k not in allowed:
                self.fail((*path, k), f"unknown field (allowed here: {', '.join(allowed)})")
