"""Issue 27, item 2 (host side): the device's link temperatures in logs and in capture.

- a log row ends with ``temp1_c .. tempN_c`` (empty for a link without a reading), the
  log reader gives them as an array and its trigger file's samples carry them (so a
  session labelled ``--from-log`` has them);
- capture's words for a sample without a point because of TEMP_FAULT name the links;
  its watch of the live readings warns once when they leave the plan's band.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from aacmm.protocol import Sample, SampleStatus

NONE = -32768


def _sample(seq: int, temp: tuple[int, ...] | None, status: int = 1) -> Sample:
    return Sample(
        seq, 1000 * seq, tuple(1000 * (j + 1) + seq for j in range(6)), (1, 2, 3), status, temp=temp
    )


def test_log_rows_and_reader(tmp_path: Path) -> None:
    from aacmm.records.logs import read_log, read_triggers
    from aacmm.records.schema import log_columns, sample_row, trigger_columns

    cols = log_columns(6)
    assert cols[-6:] == tuple(f"temp{i}_c" for i in range(1, 7)) and cols[-7] == "param_crc32"
    temps = [(2000, 2001, 1999, 2050, -150, 8500), (2000,) * 5 + (NONE,), None]
    path = tmp_path / "run.csv"
    rows = [sample_row(_sample(i, t), 1.7e9 + i, "0x00000000") for i, t in enumerate(temps)]
    assert rows[0].rstrip("\n").endswith(",20.00,20.01,19.99,20.50,-1.50,85.00")
    assert rows[1].rstrip("\n").endswith(",20.00,20.00,20.00,20.00,20.00,")
    path.write_text(",".join(cols) + "\n" + "".join(rows))
    log = read_log(path)
    got = log.temperatures_c()
    assert got is not None and got.shape == (3, 6)
    np.testing.assert_allclose(got[0], [20.0, 20.01, 19.99, 20.5, -1.5, 85.0])
    assert np.isnan(got[1, 5]) and np.isnan(got[2]).all()
    # the trigger file: its samples carry the wire values back
    crc = log.param_sets[int(log.param_crc32[0])].crc_hex
    trig = tmp_path / "run.triggers.csv"
    trows = [sample_row(_sample(i, t), 1.7e9 + i, crc, (0, 1)) for i, t in enumerate(temps)]
    trig.write_text(",".join(trigger_columns(6)) + "\n" + "".join(trows))
    got_t = read_triggers(log, trig)
    assert [t.sample.temp for t in got_t] == [*temps[:2], (NONE,) * 6]  # empty: no reading
    # a log written before device temperatures: no array
    old = tmp_path / "old.csv"
    old.write_text(",".join(log_columns(6, temps=False)) + "\n" + "1,1,1.0,1,2,3,4,5,6,0,0,0,1,\n")
    assert read_log(old).temperatures_c() is None


def test_no_point_reason() -> None:
    from aacmm.client.devstate import no_point_reason

    fault = int(SampleStatus.TEMP_FAULT)
    assert no_point_reason(_sample(1, None, 0)) == "point not valid"
    why = no_point_reason(_sample(1, (2000, 2000, NONE, 2000, 9000, 2000), fault))
    assert why.startswith("no point: the temperature of link 3, 5 was not read (TEMP_FAULT")
    assert "\n" not in why


def test_live_band_warning(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """One warning when this run's readings span more than the band, none within it."""
    import argparse

    from aacmm.commands.capture import Capture
    from aacmm.plans import loads_plan, shipped_plan_path

    text = shipped_plan_path("probe-calibration").read_text(encoding="utf-8")
    text += "\n[verification]\ntemperature_c = 20.0\ntemperature_band_c = 3.0\n"
    plan = loads_plan(text, "banded")
    args = argparse.Namespace(no_keys=True, confirm_end=False, output=str(tmp_path / "s"))
    cap = Capture(args, plan)
    for t in (2100, 2200, 2250):
        cap.watch_band(_sample(1, (t,) * 6))
    assert capsys.readouterr().err == ""
    cap.watch_band(_sample(2, (2100,) * 5 + (NONE,)))  # a link without a reading: not used
    cap.watch_band(_sample(3, (2100,) * 5 + (2340,)))  # 23.4 C: 3.4 C from 20
    cap.watch_band(_sample(4, (2600,) * 6))
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1, err
    assert (
        "warning: the device's link temperatures: the links' temperature 23.4 C is 3.4 C" in err[0]
    )
    assert json.dumps(err)  # one plain line


def test_live_view_frame_carries_the_temperatures() -> None:
    from aacmm.core import EncoderConfig, Params
    from aacmm.view.live import LiveFeed

    feed = LiveFeed(Params(), EncoderConfig(), lambda kind, msg: None)
    frame = feed._frame(_sample(1, (2000, NONE, 2150, 2000, 2000, 2000)), 1.7e9)
    assert frame["temps_c"] == [20.0, None, 21.5, 20.0, 20.0, 20.0]
    assert "temps_c" not in feed._frame(_sample(2, None), 1.7e9)
