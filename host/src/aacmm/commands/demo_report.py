"""The demo's before/after table and figure, and its check against the truth.

* :func:`before_after` puts two ``aacmm verify`` JSON reports of the same plan
  and arm side by side (value before, after, MPE, change, verdicts): a figure
  whose magnitude grew says "worse" with its factor;
  :func:`print_before_after` (``aacmm demo --compare DIR``) prints it and
  writes it as text, JSON and a PNG figure; its exit status is 11 (worse)
  when any figure grew, else 7 when the arm still fails, else 0.
* :func:`truth_check` is the only code of the demo that reads the
  simulator's truth (``arm/truth.toml``, written by ``aacmm sim
  --truth-out``): it measures random lengths across the arm's reach with the
  parameter sets the device used before and after calibration, through the
  true encoders, and compares them with the true distances.
  ``aacmm demo --check DIR`` runs it (:func:`print_truth_check`), after
  checking that the truth is the arm's: its serial number must be the one the
  sessions' device reported (exit status 10 otherwise).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aacmm.simulation.truthcheck import CHECK_LENGTHS, CHECK_SEED

#: results whose sign matters (a size or length deviation), printed with it
SIGNED = frozenset({"p_size", "e_uni", "effective_diameter"})
#: the figures the demo's story is told with: length error and single-point articulation
HEADLINE = (("e_uni", "length error E_Uni"), ("spat_range", "SPAT (max - min)/2"))


@dataclass(frozen=True)
class BeforeAfter:
    """Rows (one per verification result), the two verdicts, and the text table."""

    rows: list[dict[str, Any]]
    verdict_before: str
    verdict_after: str
    text: str
    arm: dict[str, Any] | None = None

    @property
    def worse(self) -> list[dict[str, Any]]:
        """The rows whose figure grew from before to after."""
        return [r for r in self.rows if r["worse"]]

    def to_json(self) -> dict[str, Any]:
        return {
            "format": "aacmm-demo-before-after-1",
            "verdict_before": self.verdict_before,
            "verdict_after": self.verdict_after,
            "worse": [r["key"] for r in self.worse],
            "arm": self.arm,
            "rows": self.rows,
        }


def _value(v: float | None, key: str) -> str:
    if v is None:
        return "-"
    return f"{v:+.4f}" if key in SIGNED else f"{v:.4f}"


def _mpe(row: dict[str, Any]) -> str:
    """The MPE; before/after when they differ (E_Uni's depends on the worst length)."""
    b, a = row["mpe_mm"], row["mpe_after_mm"]
    if b is None:
        return "-"
    return f"{b:.4f}" if a in (None, b) else f"{b:.3f}/{a:.3f}"


def _factor(before: float | None, after: float | None) -> float | None:
    if before is None or after is None or after == 0:
        return None
    return abs(before) / abs(after)


def _change(before: float | None, after: float | None) -> str:
    from aacmm.calibration.validation import describe_change

    if before is None or after is None:
        return "-"
    return describe_change(before, after)


def report_arm(rep: dict[str, Any]) -> dict[str, Any]:
    """The arm a verification report names: device (``serial N``), firmware, parameter set."""
    got = rep.get("session")
    meta: dict[str, Any] = got if isinstance(got, dict) else {}
    return {k: meta.get(k) for k in ("device", "firmware", "params_crc32")}


def before_after(before: dict[str, Any], after: dict[str, Any]) -> BeforeAfter:
    """The results of two verification reports (``aacmm verify --json``) side by side.

    Raises:
        ValueError: the reports are of different plans.
        WrongArmError: the reports name different devices (serial numbers).
    """
    from aacmm.commands.exitcodes import WrongArmError

    pb, pa = before.get("plan", {}), after.get("plan", {})
    if pb.get("sha256") != pa.get("sha256"):
        raise ValueError("the two verification reports are of different plans")
    arm_b, arm_a = report_arm(before), report_arm(after)
    if arm_b["device"] and arm_a["device"] and arm_b["device"] != arm_a["device"]:
        raise WrongArmError(
            f"the reports are of two arms (device {arm_b['device']} before, {arm_a['device']} "
            "after): a before/after comparison needs one arm"
        )
    res_a = {r["key"]: r for r in after["results"]}
    rows: list[dict[str, Any]] = []
    for rb in before["results"]:
        ra = res_a.get(rb["key"], {})
        vb, va = rb.get("value_mm"), ra.get("value_mm")
        rows.append(
            {
                "key": rb["key"],
                "name": rb["name"],
                "before_mm": vb,
                "after_mm": va,
                "mpe_mm": rb.get("mpe_mm"),
                "mpe_after_mm": ra.get("mpe_mm"),
                "verdict_before": rb.get("verdict"),
                "verdict_after": ra.get("verdict"),
                "factor": _factor(vb, va),
                "change": _change(vb, va),
                "worse": vb is not None and va is not None and abs(va) > abs(vb),
            }
        )
    width = max(len(r["name"]) for r in rows) if rows else 4
    cw = max([len(r["change"]) for r in rows] + [6])
    lines = []
    if arm_b["device"] or arm_a["device"]:
        lines.append(
            f"arm: device {arm_b['device'] or arm_a['device']}, firmware "
            f"{arm_b['firmware'] or '-'}; parameter set {arm_b['params_crc32'] or '-'} before, "
            f"{arm_a['params_crc32'] or '-'} after"
        )
    lines.append(f"{'test':<{width}}  before mm   after mm       MPE mm  {'change':<{cw}}  verdict")
    for r in rows:
        lines.append(
            f"{r['name']:<{width}}  {_value(r['before_mm'], r['key']):>9}  "
            f"{_value(r['after_mm'], r['key']):>9}  {_mpe(r):>11}  {r['change']:<{cw}}  "
            f"{r['verdict_before']} -> {r['verdict_after']}"
        )
    vb, va = str(before["verdict"]), str(after["verdict"])
    lines.append(f"{'verdict':<{width}}  {vb:>9}  {va:>9}")
    by_key = {r["key"]: r for r in rows}
    headline = []
    for k, label in HEADLINE:
        h = by_key.get(k)
        if h is None or h["before_mm"] is None or h["after_mm"] is None:
            continue
        if h["worse"]:
            headline.append(f"{label} WORSE: grew {h['change'].split()[0]}")
        elif h["factor"] is not None and abs(h["after_mm"]) < abs(h["before_mm"]):
            headline.append(f"{label} fell {h['change'].split()[0]}")
        else:
            headline.append(f"{label} {h['change']}")
    if headline:
        lines.append("calibration: " + ", ".join(headline))
    worse = [r for r in rows if r["worse"]]
    if worse:
        lines.append(
            f"WORSE after than before: {len(worse)} of {len(rows)} figures grew ("
            + ", ".join(f"{r['name']} {r['change'].split()[0]}" for r in worse)
            + ")"
        )
    arm = {"before": arm_b, "after": arm_a}
    return BeforeAfter(rows, vb, va, "\n".join(lines) + "\n", arm)


def figure(table: BeforeAfter) -> Any:
    """Each result as a fraction of its MPE, before and after (log scale)."""
    from matplotlib.figure import Figure

    rows = [r for r in table.rows if r["mpe_mm"] and r["before_mm"] is not None]
    fig = Figure(figsize=(8.0, 0.55 * len(rows) + 1.6))
    ax = fig.add_subplot()
    y = np.arange(len(rows))[::-1]
    for k, (field, mpe, label, colour) in enumerate(
        (
            ("before_mm", "mpe_mm", f"before calibration ({table.verdict_before})", "tab:red"),
            ("after_mm", "mpe_after_mm", f"after calibration ({table.verdict_after})", "tab:green"),
        )
    ):
        ratio = [abs(r[field] or 0.0) / (r[mpe] or r["mpe_mm"]) for r in rows]
        ax.barh(y + (0.2 - 0.4 * k), ratio, height=0.38, color=colour, label=label)
    ax.axvline(1.0, color="black", lw=1.2, ls="--", label="MPE")
    ax.set_xscale("log")
    ax.set_yticks(y, [r["name"] for r in rows], fontsize=8)
    ax.set_xlabel("|value| / MPE (log scale; passes left of the dashed line)")
    ax.set_title("Verification of the simulated arm, before and after calibration", fontsize=10)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3)
    fig.tight_layout()
    return fig


def print_before_after(folder: Path, force: bool = False) -> int:
    """``aacmm demo --compare DIR``: read ``DIR/before-report/report.json`` and
    ``DIR/after-report/report.json``, print the table, write ``before-after.txt``,
    ``.json`` and ``.png`` into ``DIR``."""
    from aacmm.fileio import check_outputs, load_json, save_figure, write_output

    targets = [folder / f"before-after.{x}" for x in ("txt", "json", "png")]
    check_outputs(targets, force)
    table = before_after(
        load_json(folder / "before-report" / "report.json"),
        load_json(folder / "after-report" / "report.json"),
    )
    write_output(targets[0], table.text, force=force)
    write_output(targets[1], json.dumps(table.to_json(), indent=2) + "\n", force=force)
    save_figure(figure(table), targets[2], force=force, dpi=120)
    print(table.text, end="")
    print("(wrote before-after.txt, before-after.json, before-after.png)")
    return compare_status(table)


def compare_status(table: BeforeAfter) -> int:
    """The exit status of a comparison: WORSE (11) when a figure grew, NOT_MET (7)
    when the arm still fails after, else OK."""
    from aacmm.commands.exitcodes import NOT_MET, OK, WORSE

    if table.worse:
        return WORSE
    return NOT_MET if table.verdict_after == "FAIL" else OK


# ------------------------------------------------------------ the truth


def truth_check(
    folder: Path, lengths: int = CHECK_LENGTHS, seed: int = CHECK_SEED
) -> dict[str, Any]:
    """Lengths across the reach as the arm measures them, before and after, against the truth.

    ``lengths`` pairs of random postures within the simulated arm's joint
    limits; each end's true point from the truth's geometry, its measured
    point from the true encoders' noise-free readings (with their
    eccentricity) converted by the parameter set the device used for the
    ``before`` and ``after`` sessions of ``folder``
    (:mod:`aacmm.simulation.truthcheck`).

    Raises:
        aacmm.errors.AacmmError / ValueError: a missing or damaged file.
    """
    from aacmm.core import counts_to_angles
    from aacmm.records import read_session
    from aacmm.simulation.truth import load_truth
    from aacmm.simulation.truthcheck import length_errors, reach_lengths

    truth = load_truth(folder / "arm" / "truth.toml")
    check_truth_arm(truth, folder)
    check = reach_lengths(truth, lengths, seed)
    counts = check.counts
    out: dict[str, Any] = {
        "format": "aacmm-demo-truth-check-1",
        "truth": "arm/truth.toml",
        "origin": truth.origin,
        "lengths": lengths,
        "seed": seed,
        "true_length_mm": [float(check.true_mm.min()), float(check.true_mm.max())],
        "serial_number": truth.device_serial,
    }

    def figures(ps: Any) -> dict[str, Any]:
        pts = ps.points(counts_to_angles(counts, ps.encoders))  # with its error model
        return {
            "params_crc32": ps.crc_hex,
            "errmodel": ps.errmodel_text(),
            **length_errors(check, pts).to_json(),
        }

    for name in ("before", "after"):
        ps = read_session(folder / name).param_set_of(0)
        out[name] = {"session": name, **figures(ps)}
    dh = folder / DH_ONLY_FILE
    if dh.is_file():  # the same calibration data, the arm alone (aacmm demo writes it)
        from aacmm.records.paramfile import load_param_file
        from aacmm.records.paramsets import ParamSetRecord

        ps = ParamSetRecord.from_device(load_param_file(dh))
        out["dh_only"] = {"session": None, "file": DH_ONLY_FILE, **figures(ps)}
    # what the true geometry itself measures through these encoders: the part
    # of the error (eccentricity) that no calibration of the DH model removes
    pts = truth.model().points(counts_to_angles(counts, truth.encoders))
    out["floor"] = {
        "session": None,
        "params_crc32": "truth",
        **length_errors(check, pts).to_json(),
    }
    out["factor"] = out["before"]["rms_mm"] / out["after"]["rms_mm"]
    return out


#: ``aacmm demo``'s calibration of the same data without the error model
#: (:data:`aacmm.commands.demo.DH_ONLY`), checked against the truth when present.
DH_ONLY_FILE = "calibrated-dh-only.toml"


def check_truth_arm(truth: Any, folder: Path) -> None:
    """The truth must be the arm the demo's sessions were taken on (its device serial).

    Raises:
        WrongArmError: a session's device reported another serial number.
    """
    from aacmm.commands.exitcodes import WrongArmError
    from aacmm.records import read_session

    for name in ("before", "after"):
        dev = read_session(folder / name).device or {}
        serial = dev.get("serial_number")
        if serial is not None and serial != truth.device_serial:
            raise WrongArmError(
                f"{folder / 'arm' / 'truth.toml'}: the truth of the arm with serial number "
                f"{truth.device_serial}; session {name} was taken on serial {serial}: not this "
                "arm's truth"
            )


def truth_check_text(c: dict[str, Any]) -> str:
    lo, hi = c["true_length_mm"]
    origin = c["origin"]
    what = f"{origin.get('kind')}:{origin.get('seed')}" if origin.get("kind") else "a truth file"
    lines = [
        f"truth: {c['truth']} ({what}, the arm with serial number {c.get('serial_number')}), "
        "written by the simulator, read here for the first time",
        f"{c['lengths']} random lengths across the arm's reach ({lo:.0f}-{hi:.0f} mm), each end "
        "in a random posture:",
        "what the arm measures (its own encoders, eccentric, without noise) - the true distance",
        "           rms mm    95 % mm    max mm  parameters",
    ]
    for name in ("before", "after", "dh_only", "floor"):
        r = c.get(name)
        if r is None:
            continue
        if r["session"]:
            em = r.get("errmodel", "none (DH only)")
            what = f"{r['params_crc32']} (session {r['session']})"
            what += f", error model: {em}" if em != "none (DH only)" else ""
        elif name == "dh_only":
            what = f"{r['file']}: the same data calibrated without the error model (the arm alone)"
        else:
            what = "the true parameters: what the encoders' reading errors alone leave to DH"
        label = "DH only" if name == "dh_only" else name
        lines.append(
            f"{label:<8} {r['rms_mm']:>8.4f}  {r['p95_mm']:>9.4f}  {r['max_mm']:>8.4f}  {what}"
        )
    f = c["factor"]
    if f >= 1:
        lines.append(f"the calibration cut the rms length error {_times(f)} over the whole reach")
    else:
        lines.append(
            f"WORSE: the calibration made the rms length error grow {_times(1 / f)} over the "
            "whole reach"
        )
    return "\n".join(lines) + "\n"


def _times(f: float) -> str:
    from aacmm.calibration.validation import factor_text

    return factor_text(f)


def print_truth_check(folder: Path, force: bool = False) -> int:
    """``aacmm demo --check DIR``: print the check, write ``truth-check.json``/``.txt``."""
    from aacmm.fileio import check_outputs, write_output

    targets = [folder / "truth-check.json", folder / "truth-check.txt"]
    check_outputs(targets, force)
    c = truth_check(folder)
    text = truth_check_text(c)
    write_output(targets[0], json.dumps(c, indent=2) + "\n", force=force)
    write_output(targets[1], text, force=force)
    print(text, end="")
    from aacmm.commands.exitcodes import OK, WORSE

    return WORSE if c["factor"] < 1 else OK
