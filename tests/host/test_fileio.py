"""aacmm.fileio: the one output-file rule and the bounded-nesting input readers.

Output: refuse an existing file unless forced, never leave a torn or partial
target, no clobber even of a file that appears during the write, no symlink
followed, usable for text, bytes, CSV, JSON and matplotlib figures.
Input: valid files load; hostile nesting (the issue's 1,200-level TOML and
100,000-bracket JSON) ends in InputFileError, never RecursionError.
"""

from __future__ import annotations

import csv
import json
import os
import stat
import tomllib
from pathlib import Path

import pytest
from aacmm import fileio
from aacmm.errors import AacmmError
from aacmm.fileio import (
    MAX_NESTING,
    InputFileError,
    OutputExistsError,
    OutputFileError,
    atomic_output,
    atomic_path,
    check_outputs,
    load_json,
    load_structured,
    load_toml,
    loads_json,
    loads_toml,
    nesting_depth,
    save_figure,
    write_output,
)

pytestmark = pytest.mark.timeout(60)


def leftovers(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir() if p.name.endswith(".tmp"))


# ------------------------------------------------------------------ output


def test_new_file_text_and_bytes(tmp_path: Path) -> None:
    write_output(tmp_path / "a.txt", "héllo\n")
    write_output(tmp_path / "b.bin", b"\x00\xff")
    assert (tmp_path / "a.txt").read_text(encoding="utf-8") == "héllo\n"
    assert (tmp_path / "b.bin").read_bytes() == b"\x00\xff"
    assert leftovers(tmp_path) == []


def test_existing_file_is_refused_and_kept(tmp_path: Path) -> None:
    target = tmp_path / "out.json"
    target.write_text("old")
    with pytest.raises(OutputExistsError, match=r"out\.json exists \(use --force to overwrite\)"):
        write_output(target, "new")
    assert target.read_text() == "old"
    assert leftovers(tmp_path) == []
    write_output(target, "new", force=True)
    assert target.read_text() == "new"


def test_errors_are_usage_errors() -> None:
    # exit status 2 in the CLI: ValueError and AacmmError
    for cls in (OutputExistsError, OutputFileError, InputFileError):
        assert issubclass(cls, ValueError) and issubclass(cls, AacmmError)


def test_failed_write_leaves_target_untouched(tmp_path: Path) -> None:
    target = tmp_path / "out.csv"
    target.write_text("precious\n")
    with pytest.raises(RuntimeError), atomic_output(target, force=True) as f:
        f.write("half a row")
        raise RuntimeError("writer failed")
    assert target.read_text() == "precious\n"
    assert leftovers(tmp_path) == []


def test_file_appearing_during_write_is_not_clobbered(tmp_path: Path) -> None:
    target = tmp_path / "race.txt"
    with pytest.raises(OutputExistsError), atomic_output(target) as f:
        f.write("mine")
        target.write_text("someone else's")  # created after the first check
    assert target.read_text() == "someone else's"
    assert leftovers(tmp_path) == []


def test_symlink_is_not_followed(tmp_path: Path) -> None:
    victim = tmp_path / "victim"
    victim.write_text("keep")
    link = tmp_path / "out.txt"
    link.symlink_to(victim)
    with pytest.raises(OutputExistsError):
        write_output(link, "x")
    dangling = tmp_path / "dangling.txt"
    dangling.symlink_to(tmp_path / "nowhere")
    with pytest.raises(OutputExistsError):
        write_output(dangling, "x")
    assert not (tmp_path / "nowhere").exists()
    write_output(link, "new", force=True)  # replaces the link itself
    assert victim.read_text() == "keep"
    assert not link.is_symlink() and link.read_text() == "new"


def test_planted_temp_name_is_not_used(tmp_path: Path) -> None:
    # the old scheme wrote FILE.tmp with create+truncate; a symlink planted there
    # redirected the write
    victim = tmp_path / "victim"
    victim.write_text("keep")
    (tmp_path / "out.toml.tmp").symlink_to(victim)
    (tmp_path / ".out.toml.tmp").symlink_to(victim)
    write_output(tmp_path / "out.toml", "a = 1\n")
    assert victim.read_text() == "keep"
    assert (tmp_path / "out.toml").read_text() == "a = 1\n"


def test_permissions(tmp_path: Path) -> None:
    old = os.umask(0o027)
    try:
        write_output(tmp_path / "new", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "new").stat().st_mode) == 0o640
    kept = tmp_path / "kept"
    kept.write_text("x")
    kept.chmod(0o600)
    write_output(kept, "y", force=True)
    assert stat.S_IMODE(kept.stat().st_mode) == 0o600


def test_csv_json_and_figure(tmp_path: Path) -> None:
    with atomic_output(tmp_path / "t.csv", newline="") as f:
        w = csv.writer(f)
        w.writerow(["a", "b"])
        w.writerow([1, "x,y"])
    assert (tmp_path / "t.csv").read_bytes() == b'a,b\r\n1,"x,y"\r\n'
    with atomic_output(tmp_path / "t.json") as f:
        json.dump({"k": [1, 2]}, f)
    assert json.loads((tmp_path / "t.json").read_text()) == {"k": [1, 2]}

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    save_figure(fig, tmp_path / "f.png", dpi=50)
    save_figure(fig, tmp_path / "f.svg")
    with pytest.raises(OutputExistsError):
        save_figure(fig, tmp_path / "f.png")
    plt.close(fig)
    assert (tmp_path / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert b"<svg" in (tmp_path / "f.svg").read_bytes()[:500]
    assert leftovers(tmp_path) == []


def test_atomic_path_for_writers_that_open_by_name(tmp_path: Path) -> None:
    target = tmp_path / "fig.png"
    with atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.name.endswith(".png") and tmp != target
        assert not target.exists()
        tmp.write_bytes(b"\x89PNG")  # e.g. Figure.savefig(tmp), can.Logger(tmp)
    assert target.read_bytes() == b"\x89PNG"
    with pytest.raises(OutputExistsError):  # the same rule
        with atomic_path(target):
            pass
    with pytest.raises(ValueError, match="writer"), atomic_path(target, force=True) as tmp:
        tmp.write_bytes(b"half")
        raise ValueError("writer failed")
    assert target.read_bytes() == b"\x89PNG"
    other = tmp_path / "race.csv"
    with pytest.raises(OutputExistsError), atomic_path(other) as tmp:
        tmp.write_text("mine")
        other.write_text("theirs")
    assert other.read_text() == "theirs"
    assert leftovers(tmp_path) == [] and not list(tmp_path.glob(".*.tmp.*"))


def test_bad_targets(tmp_path: Path) -> None:
    with pytest.raises(OutputFileError, match="is a directory"):
        write_output(tmp_path, "x", force=True)
    with pytest.raises(OutputFileError, match="does not exist"):
        write_output(tmp_path / "no" / "such.txt", "x")


def test_only_regular_files_are_replaced(tmp_path: Path) -> None:
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    link = tmp_path / "stdout"
    link.symlink_to("/dev/null")
    for p in (fifo, link):
        with pytest.raises(OutputFileError, match="not a regular file"):
            write_output(p, "x", force=True)
        with pytest.raises(OutputFileError, match="not a regular file"):
            check_outputs([p], force=True)
    assert stat.S_ISFIFO(fifo.lstat().st_mode) and link.is_symlink()
    assert Path("/dev/null").is_char_device()


def test_check_outputs(tmp_path: Path) -> None:
    a, b = tmp_path / "a.csv", tmp_path / "b.json"
    assert check_outputs([a, None, str(b)]) == [a, b]
    b.write_text("{}")
    with pytest.raises(OutputExistsError, match=r"b\.json exists"):
        check_outputs([a, b])
    assert check_outputs([a, b], force=True) == [a, b]
    with pytest.raises(OutputFileError, match="twice"):
        check_outputs([a, tmp_path / "." / "a.csv"])
    with pytest.raises(OutputFileError, match="does not exist"):
        check_outputs([tmp_path / "missing" / "x.png"])
    with pytest.raises(OutputFileError, match="is a directory"):
        check_outputs([tmp_path], force=True)


# ------------------------------------------------------------------ input


def test_nesting_depth_matches_a_recursive_reference() -> None:
    def ref(v: object) -> int:
        if isinstance(v, dict):
            return 1 + max((ref(c) for c in v.values()), default=0)
        if isinstance(v, list):
            return 1 + max((ref(c) for c in v), default=0)
        return 0

    for v in (1, [], {}, [[1], [[2]]], {"a": {"b": [1, {"c": []}]}}, [[], [[[]]], 3]):
        assert nesting_depth(v) == ref(v), v


def test_valid_files_load(tmp_path: Path) -> None:
    t = tmp_path / "a.toml"
    t.write_text('x = 1\n[tab]\ny = [1, [2, [3]]]\nz = "s"\n')
    j = tmp_path / "a.json"
    j.write_text('{"x": [1, {"y": null}]}')
    assert load_toml(t) == tomllib.loads(t.read_text())
    assert load_json(j) == {"x": [1, {"y": None}]}
    assert load_structured(t)["x"] == 1 and load_structured(j)["x"][0] == 1
    # exactly the limit is fine, one more is not
    ok = "[" * MAX_NESTING + "]" * MAX_NESTING
    assert nesting_depth(loads_json(ok)) == MAX_NESTING
    with pytest.raises(InputFileError, match="nested too deeply"):
        loads_json("[" + ok + "]")
    with pytest.raises(InputFileError, match="nested too deeply"):
        loads_toml("a = " + ok)  # the table itself is one level


HOSTILE = {
    "deep.toml": "x = " + "[" * 1200 + "]" * 1200 + "\n",
    "inline.toml": "x = " + "{a = " * 1200 + "1" + "}" * 1200 + "\n",
    "dotted.toml": "x" + ".y" * 5000 + " = 1\n",
    "open.json": "[" * 100_000,
    "deep.json": "[" * 5000 + "]" * 5000,
    "objects.json": '{"a":' * 5000 + "1" + "}" * 5000,
}


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_hostile_nesting_is_one_clear_error(tmp_path: Path, name: str) -> None:
    p = tmp_path / name
    p.write_text(HOSTILE[name])
    with pytest.raises(InputFileError) as info:
        load_structured(p)
    msg = str(info.value)
    assert msg.startswith(str(p)) and "\n" not in msg
    assert "nested too deeply" in msg or "not valid" in msg


def test_other_bad_inputs(tmp_path: Path) -> None:
    bad = {
        "syntax.toml": (b"x = [", "not valid TOML"),
        "syntax.json": (b"{", "not valid JSON"),
        "latin1.toml": (b'x = "\xe9"', "not UTF-8"),
        "digits.json": (b"1" * 5000, "not valid JSON"),
        "thing.yaml": (b"x: 1", "unknown format"),
    }
    for name, (data, words) in bad.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(InputFileError, match=words):
            load_structured(tmp_path / name)
    with pytest.raises(InputFileError, match="cannot read"):
        load_json(tmp_path / "absent.json")
    with pytest.raises(InputFileError, match="cannot read"):
        load_toml(tmp_path)  # a directory


def test_size_limit(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(fileio, "MAX_INPUT_BYTES", 100)
    p = tmp_path / "big.json"
    p.write_text("[" + "1," * 100 + "1]")
    with pytest.raises(InputFileError, match="larger than"):
        load_json(p)
