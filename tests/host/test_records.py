"""Sessions (aacmm.records): writer, reader, undo, repair after a kill, per-row parameter sets."""

from __future__ import annotations

import csv
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from aacmm.core import EncoderConfig, Model, Params, counts_to_angles
from aacmm.plans import load_plan
from aacmm.protocol import Sample
from aacmm.records import (
    POINT_COLUMNS,
    ParamSetRecord,
    RecordError,
    SessionWriter,
    read_session,
)
from hypothesis import given, settings
from hypothesis import strategies as st

pytestmark = pytest.mark.timeout(60)

PAPER = ParamSetRecord.from_device(ParamSetRecord(0, Params(), EncoderConfig()).to_device())


def other_set() -> ParamSetRecord:
    """A set with another arm geometry and another encoder configuration."""
    p = Params(d_mm=(301.0, 65.5, 790.0, 65.5, 880.0, 0.0), l_mm=150.0)
    e = EncoderConfig(counts_per_rev=(1 << 20,) * 6, zero_offset_counts=(5, 0, 0, 0, 0, 7))
    return ParamSetRecord.from_device(ParamSetRecord(0, p, e).to_device())


def sample_for(ps: ParamSetRecord, counts: tuple[int, ...], seq: int) -> Sample:
    """The sample a device with ``ps`` would send (point rounded to 0.1 um)."""
    th = counts_to_angles(np.array([counts], dtype=np.uint64), ps.encoders)
    p = Model(ps.params).points(th)[0]
    return Sample(seq, 1000 * seq, counts, tuple(round(float(v) * 1e4) for v in p), 1)


def fill(w: SessionWriter, ps: ParamSetRecord, n: int, rng: np.random.Generator) -> None:
    w.set_param_set(ps)
    cpr = ps.encoders.counts_per_rev[0]
    for _ in range(n):
        counts = tuple(int(c) for c in rng.integers(0, cpr, 6))
        w.record(sample_for(ps, counts, w.accepted), time.time())


def test_round_trip_labels_and_recompute(tmp_path: Path) -> None:
    plan = load_plan("iso10360-12")
    w = SessionWriter.create(tmp_path / "s", plan, device={"serial_number": 7}, port="x")
    w.begin_run("capture")
    fill(w, PAPER, 30, np.random.default_rng(1))
    w.close("interrupted", "test")
    s = read_session(tmp_path / "s")
    assert s.status == "interrupted" and not s.complete and len(s) == 30
    assert s.device == {"serial_number": 7}
    assert s.plan.sha256 == plan.sha256
    for p, slot in zip(s.points, plan.slots, strict=False):
        assert (p.slot, p.step_id, p.point_index, p.articulation_index) == (
            slot.index,
            slot.step_id,
            slot.point_index,
            slot.articulation_index,
        )
        assert p.param_set == PAPER
    assert [p.articulation_index for p in s.points_of("location")] == [0] * 5
    # recomputed from counts in double precision = the device points within their 0.05 um rounding
    assert np.abs(s.points_mm() - s.device_points_mm).max() <= 0.5e-4 + 1e-9
    # the CSV is plain: header, one row per point, same columns as documented
    with open(tmp_path / "s" / "points.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == POINT_COLUMNS and len(rows) == 30
    assert rows[0]["param_crc32"] == PAPER.crc_hex and rows[0]["end"] == ""


def test_session_csv_loads_with_pandas(tmp_path: Path) -> None:
    """The session's points.csv is what pandas reads as it is: labels, integer counts, mm."""
    import pandas as pd

    plan = load_plan("iso10360-12")
    w = SessionWriter.create(tmp_path / "s", plan)
    fill(w, PAPER, 54, np.random.default_rng(4))
    w.close("interrupted")
    s = read_session(tmp_path / "s")
    df = pd.read_csv(tmp_path / "s" / "points.csv")
    assert tuple(df.columns) == POINT_COLUMNS and len(df) == 54
    counts = df[[f"count{i}" for i in range(1, 7)]].to_numpy()
    assert counts.dtype.kind in "iu" and (counts == s.counts).all()
    xyz = df[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=float)
    assert np.abs(xyz - s.device_points_mm).max() <= 1e-9
    assert list(df["step_id"]) == [p.step_id for p in s.points]
    ends = df.loc[df["step_id"] == "length500", "end"].tolist()
    assert ends == ["A", "B", "A", "B"]


def test_length_labels(tmp_path: Path) -> None:
    plan = load_plan("iso10360-12")
    w = SessionWriter.create(tmp_path / "s", plan)
    fill(w, PAPER, 54, np.random.default_rng(2))
    w.close("interrupted")
    s = read_session(tmp_path / "s")
    bar = s.points_of("length500")
    assert [(p.position_index, p.end) for p in bar] == [(0, "A"), (0, "B"), (1, "A"), (1, "B")]


def test_parameter_set_per_row(tmp_path: Path) -> None:
    """15.5: each row is converted with the set in force when it was taken."""
    plan = load_plan("kinematic-calibration")
    other = other_set()
    w = SessionWriter.create(tmp_path / "s", plan)
    rng = np.random.default_rng(3)
    fill(w, PAPER, 5, rng)
    fill(w, other, 5, rng)  # e.g. a reconnect to a device with another set
    w.close("interrupted")
    s = read_session(tmp_path / "s")
    assert [p.param_set.crc32 for p in s.points] == [PAPER.crc32] * 5 + [other.crc32] * 5
    assert s.set_changes() == [(0, PAPER.crc32), (5, other.crc32)]
    # an independent reference: each half with its own model and encoders
    ref = np.vstack(
        [
            Model(ps.params).points(counts_to_angles(s.counts[rows], ps.encoders))
            for ps, rows in ((PAPER, slice(0, 5)), (other, slice(5, 10)))
        ]
    )
    got = s.points_mm()
    assert np.allclose(got, ref, atol=1e-9)
    assert np.abs(got - s.device_points_mm).max() <= 0.5e-4 + 1e-9
    # converting everything with the first set would be wrong by millimetres
    wrong = Model(PAPER.params).points(counts_to_angles(s.counts, PAPER.encoders))
    assert np.abs(wrong[5:] - ref[5:]).max() > 1.0
    with pytest.raises(RecordError, match="parameter set changes at row 6"):
        s.single_params("this analysis")
    meta = json.loads((tmp_path / "s" / "session.json").read_text())
    assert [d["first_slot"] for d in meta["param_sets"]] == [0, 5]


def test_undo_and_resume_after_a_cut_row(tmp_path: Path) -> None:
    plan = load_plan("probe-calibration")
    folder = tmp_path / "s"
    w = SessionWriter.create(folder, plan)
    fill(w, PAPER, 4, np.random.default_rng(4))
    assert w.undo() == plan.slots[3]
    assert w.accepted == 3 and w.next_slot == plan.slots[3]
    # a kill -9 in the middle of the next append leaves half a row
    with open(folder / "points.csv", "a") as f:
        f.write("3,0,pivot,cone,seat,,,3,3,99,1")
    s = read_session(folder)
    assert len(s) == 3 and s.warnings
    w2 = SessionWriter.resume(folder, plan)
    assert w2.accepted == 3 and w2.next_slot == plan.slots[3]
    fill(w2, PAPER, 2, np.random.default_rng(5))
    w2.close("interrupted")
    s = read_session(folder)
    assert len(s) == 5 and not s.warnings
    events = list(csv.DictReader(open(folder / "events.csv", newline="")))
    assert [e["event"] for e in events].count("undo") == 1
    assert [e["event"] for e in events].count("point") == 6


def test_resume_refuses_another_plan(tmp_path: Path) -> None:
    w = SessionWriter.create(tmp_path / "s", load_plan("probe-calibration"))
    w.close("interrupted")
    with pytest.raises(RecordError, match="another plan"):
        SessionWriter.resume(tmp_path / "s", load_plan("iso10360-12"))
    with pytest.raises(FileExistsError):
        SessionWriter.create(tmp_path / "s", load_plan("probe-calibration"))


def test_damaged_sessions_are_refused(tmp_path: Path) -> None:
    plan = load_plan("probe-calibration")
    folder = tmp_path / "s"
    w = SessionWriter.create(folder, plan)
    fill(w, PAPER, 3, np.random.default_rng(6))
    w.close("interrupted")
    side = folder / "session.json"
    good = side.read_text()
    # a parameter set edited by hand no longer matches its CRC
    meta = json.loads(good)
    meta["param_sets"][0]["params"]["l_mm"] = 180.0
    side.write_text(json.dumps(meta))
    with pytest.raises(RecordError, match="does not match its CRC"):
        read_session(folder)
    side.write_text("[" * 100000)
    with pytest.raises(RecordError, match=r"nested too deeply|not valid JSON"):
        read_session(folder)
    side.write_text(good)
    pts = folder / "points.csv"
    text = pts.read_text()
    pts.write_text(text.replace(",pivot,cone,seat,,,1,1,", ",pivot,cone,seat,,,2,1,"))
    with pytest.raises(RecordError, match=r"points.csv:3: labels do not match point 2"):
        read_session(folder)
    pts.write_text(text.replace(PAPER.crc_hex, "0x12345678", 1))
    with pytest.raises(RecordError, match=r"points.csv:2: parameter set '0x12345678'"):
        read_session(folder)
    with pytest.raises(RecordError, match="not a session folder"):
        read_session(tmp_path)


def test_record_refuses_without_set_and_past_the_end(tmp_path: Path) -> None:
    plan = load_plan("probe-calibration")
    w = SessionWriter.create(tmp_path / "s", plan)
    with pytest.raises(RecordError, match="no parameter set"):
        w.record(sample_for(PAPER, (0,) * 6, 0), 0.0)
    fill(w, PAPER, 30, np.random.default_rng(7))
    assert w.next_slot is None
    with pytest.raises(RecordError, match="complete"):
        w.record(sample_for(PAPER, (0,) * 6, 0), 0.0)
    w.close("complete")
    assert read_session(tmp_path / "s").complete


def test_param_set_record_json_round_trip() -> None:
    other = other_set()
    back = ParamSetRecord.from_json(json.loads(json.dumps(other.to_json())), "x")
    assert back == other
    assert math.isclose(back.params.l_mm, 150.0)


_mutation = st.tuples(
    st.integers(0, 10**6),
    st.sampled_from(["del", "ins", "flip"]),
    st.binary(min_size=1, max_size=8),
)


_GOLDEN: Path | None = None


@settings(max_examples=120, deadline=None)
@given(st.lists(_mutation, min_size=1, max_size=4))
def test_damaged_files_are_refused_cleanly(tmp_path_factory: Any, muts: list[Any]) -> None:
    """Every file is hostile: a session or log damaged at random is read or refused with
    RecordError (one line), never another exception."""
    import shutil

    from aacmm.records.logs import read_log

    global _GOLDEN
    if _GOLDEN is None:
        _GOLDEN = tmp_path_factory.mktemp("golden")
        w = SessionWriter.create(_GOLDEN / "s", load_plan("probe-calibration"))
        fill(w, PAPER, 4, np.random.default_rng(8))
        w.close("interrupted")
        (_GOLDEN / "run.csv").write_text((_GOLDEN / "s" / "points.csv").read_text())
    base = tmp_path_factory.mktemp("d")
    shutil.copytree(_GOLDEN, base, dirs_exist_ok=True)
    log = base / "run.csv"
    for target in (base / "s" / "points.csv", base / "s" / "session.json", log):
        data = bytearray(target.read_bytes())
        for pos, op, blob in muts:
            i = pos % (len(data) + 1)
            if op == "del":
                del data[i : i + len(blob)]
            elif op == "ins":
                data[i:i] = blob
            elif data:
                data[i % len(data)] ^= blob[0] or 1
        target.write_bytes(bytes(data))
    for read in (lambda: read_session(base / "s"), lambda: read_log(log)):
        try:
            read()
        except RecordError as exc:
            assert "\n" not in str(exc)
