"""A DBC per CAN node (issue 14 item 4).

Before: the packaged DBC described node 0 while every default (simulator,
``socketcan://`` URLs) uses node 1, so ``cantools decode`` printed "Unknown
frame id" for every frame of a default session. Now the DBC of any node is
generated from the one source (``aacmm.dbc``, node 0), shipped per node, and
written by ``aacmm dbc``. The decoding of a real capture from the simulator
over vcan is tests/host/vcan_dbc (make test-vcan).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import cantools
import pytest
from aacmm.commands import exitcodes
from aacmm.protocol import Sample
from aacmm.protocol import can as pcan
from aacmm.transport import DEFAULT_CAN_NODE
from clihelp import one_error_line, run

pytestmark = pytest.mark.timeout(120)

BASE_IDS = {
    "AACMM_SampleHeader": 0x100,
    "AACMM_Counts12": 0x110,
    "AACMM_Counts34": 0x120,
    "AACMM_Counts56": 0x130,
    "AACMM_PointXY": 0x140,
    "AACMM_PointZ": 0x150,
    "AACMM_Trigger": 0x160,
    "AACMM_Counts7": 0x170,
    "AACMM_IsoTpRequest": 0x600,
    "AACMM_IsoTpResponse": 0x680,
}
"""docs/protocol.md section 4, typed in here as the independent reference."""

SAMPLE = Sample(
    seq=0x01020304,
    timestamp_us=(7 << 32) | 123456,
    counts=(1, 2**31, 2**32 - 1, 12345, 0, 999),
    point_100nm=(5_300_295, -5_806_323, -8_508_455),
    status=0x0009,
)


def candump_lines(node: int) -> str:
    """The sample's frames as `candump -l` lines (what `aacmm log --raw x.log` writes)."""
    return "".join(
        f"(1700000000.{i:06d}) vcan0 {f.arbitration_id:03X}#{f.data.hex().upper()}\n"
        for i, f in enumerate(pcan.encode_sample_frames(SAMPLE, node_id=node))
    )


@pytest.mark.parametrize("node", range(16))
def test_dbc_of_each_node(node: int) -> None:
    db = pcan.load_dbc(node)
    assert {m.name: m.frame_id for m in db.messages} == {
        name: base + node for name, base in BASE_IDS.items()
    }
    # the shipped file is the generated one (regenerate:
    # aacmm dbc --all -o host/src/aacmm/data/dbc --force)
    shipped = Path(pcan.node_dbc_path(node)).read_text(encoding="utf-8")
    assert shipped == pcan.dbc_text(node)
    assert f"CAN node {node} " in shipped
    # the node's frames decode with its file, loaded as any tool would
    file_db = cantools.database.load_file(pcan.node_dbc_path(node))
    assert isinstance(file_db, cantools.database.can.Database)
    got: dict[str, Any] = {}
    for f in pcan.encode_sample_frames(SAMPLE, node_id=node):
        decoded = file_db.decode_message(f.arbitration_id, f.data)
        assert isinstance(decoded, dict)
        got.update(decoded)
    assert got["Seq"] == SAMPLE.seq and got["TimestampUs"] == 123456
    assert [got[f"Count{i}"] for i in range(1, 7)] == list(SAMPLE.counts)
    assert [got[a] for a in "XYZ"] == pytest.approx([530.0295, -580.6323, -850.8455], abs=1e-9)
    assert got["Status"] == 9 and got["SeqTag"] == 4 and got["Joints"] == 6


def test_seven_axis_sample_frames_decode_with_cantools() -> None:
    """Issue 26: the frames of a 7-axis arm's sample (the C encoder's, from the
    shared vectors, checked against C in tests/protocol) decode with cantools from
    the shipped DBC of their node: seven frames, Count1..Count7, Joints 7; and a
    4-axis sample is five frames."""
    vectors = Path(__file__).resolve().parents[1] / "vectors" / "protocol_vectors.txt"
    rows = [
        line.split()[2:]
        for line in vectors.read_text().splitlines()
        if line.startswith("can sample_7_n2_")
    ]
    assert len(rows) == 7
    db = cantools.database.load_file(pcan.node_dbc_path(2))
    assert isinstance(db, cantools.database.can.Database)
    got: dict[str, Any] = {}
    names = []
    for frame_id, data in rows:
        msg = db.get_message_by_frame_id(int(frame_id, 16))
        names.append(msg.name)
        decoded = db.decode_message(int(frame_id, 16), bytes.fromhex(data))
        assert isinstance(decoded, dict)
        got.update(decoded)
    assert names == [
        "AACMM_SampleHeader",
        "AACMM_Counts12",
        "AACMM_Counts34",
        "AACMM_Counts56",
        "AACMM_Counts7",
        "AACMM_PointXY",
        "AACMM_PointZ",
    ]
    # the values of SAMPLE_7 in tests/vectors/gen_protocol_vectors.py, typed in here
    assert [got[f"Count{i}"] for i in range(1, 8)] == [7, 6, 5, 4, 3, 2, 0xFFFFFFFF]
    assert got["Joints"] == 7 and got["Seq"] == 7 and got["SeqTag"] == 7
    assert got["Status"] == 0x4001
    assert [got[a] for a in "XYZ"] == pytest.approx([-0.0005, 214748.3647, 0.0], abs=1e-9)
    four = Sample(9, 0, (1, 2, 3, 4), (0, 0, 0), 0, params=17)
    frames = pcan.encode_sample_frames(four, node_id=2)
    assert [db.get_message_by_frame_id(f.arbitration_id).name for f in frames] == [
        "AACMM_SampleHeader",
        "AACMM_Counts12",
        "AACMM_Counts34",
        "AACMM_PointXY",
        "AACMM_PointZ",
    ]


def test_cantools_decode_of_a_default_session() -> None:
    """The issue's symptom: `cantools decode` on the default node's frames."""
    dbc = pcan.node_dbc_path(DEFAULT_CAN_NODE)
    p = subprocess.run(
        [sys.executable, "-m", "cantools", "decode", dbc],
        input=candump_lines(DEFAULT_CAN_NODE),
        capture_output=True,
        text=True,
    )
    assert p.returncode == 0, p.stderr
    assert "Unknown frame id" not in p.stdout
    assert p.stdout.count("::") == 6 and "AACMM_PointZ(" in p.stdout
    # the node-0 source alone is what failed before
    p0 = subprocess.run(
        [sys.executable, "-m", "cantools", "decode", pcan.dbc_path()],
        input=candump_lines(DEFAULT_CAN_NODE),
        capture_output=True,
        text=True,
    )
    assert p0.stdout.count("Unknown frame id") == 6


def test_dbc_command(tmp_path: Path) -> None:
    p = run("dbc")
    assert p.returncode == 0 and p.stdout == pcan.dbc_text(DEFAULT_CAN_NODE)
    assert DEFAULT_CAN_NODE == 1  # as the --help text and docs/cli.md say
    out = tmp_path / "arm.dbc"
    p = run("dbc", "--node", "5", "-o", str(out))
    assert p.returncode == 0, p.stderr
    assert out.read_text() == pcan.dbc_text(5)
    p = run("dbc", "--node", "6", "-o", str(out))
    one_error_line(p, exitcodes.USAGE, "exists", "--force")
    assert out.read_text() == pcan.dbc_text(5)
    assert run("dbc", "--node", "6", "-o", str(out), "--force").returncode == 0
    assert out.read_text() == pcan.dbc_text(6)
    p = run("dbc", "--all", "-o", str(tmp_path))
    assert p.returncode == 0, p.stderr
    assert sorted(f.name for f in tmp_path.glob("aacmm-node*.dbc")) == sorted(
        f"aacmm-node{n}.dbc" for n in range(16)
    )
    p = run("dbc", "--all", "-o", str(tmp_path))
    one_error_line(p, exitcodes.USAGE, "aacmm-node0.dbc exists")
    p = run("dbc", "--all")
    one_error_line(p, exitcodes.USAGE, "-o DIR")
    p = run("dbc", "--node", "16")
    assert p.returncode == exitcodes.USAGE and "outside 0..15" in p.stderr


def test_status_comment_names_every_status_bit() -> None:
    """Issue 29.7: the DBC's Status comment listed bits 0-5 only; a CAN tool user
    reads there what each bit means, so it names every bit of SampleStatus (the one
    definition, aacmm.protocol.constants) by its value, in every node's file."""
    import re

    from aacmm.protocol import SampleStatus

    for node in (0, 1, 15):
        db = cantools.database.load_file(pcan.node_dbc_path(node))
        assert isinstance(db, cantools.database.can.Database)
        sig = next(s for m in db.messages for s in m.signals if s.name == "Status")
        text = sig.comment or ""
        named = {int(v): w for v, w in re.findall(r"(\d+) ([a-z0-9 ]+?)(?=[,;(.]|$)", text)}
        for flag in SampleStatus:
            assert flag.value in named, (flag, text)
            words = str(flag.name).lower().replace("_", " ").replace("joint", "joint ")
            key = {"params default": "default parameters"}.get(words, words)
            assert named[flag.value].startswith(key), (flag, named[flag.value])
