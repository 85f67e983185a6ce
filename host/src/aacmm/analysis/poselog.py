"""Poses from a measurement log (the CSV written by ``aacmm log``).

Contract (what this reader accepts; the logger writes the first form):

* A UTF-8 CSV file. Lines starting with ``#`` are comments. The first other
  line is a header row naming the columns; other columns (time, point,
  button, ...) are ignored, and their order does not matter.
* Joint columns, one of:

  - ``count1`` .. ``count6``: raw encoder readings, unsigned integers
    0 .. 2^32-1 (``c1`` .. ``c6`` are accepted as aliases), converted to
    angles by the firmware's own converter (``aacmm_encoder_to_angles_f64``)
    with the encoder configuration from the sidecar;
  - ``theta1`` .. ``theta6``: joint angles in rad (the model's readings, its
    theta offsets are added by the model).

* An optional JSON sidecar ``<file>.json`` (e.g. ``run1.csv.json``; also
  ``run1.json`` next to ``run1.csv``) with the key ``"encoders"``::

      {"encoders": {"counts_per_rev": [6 ints], "zero_offset_counts": [6 ints],
                    "direction": [6 of +1/-1]}}

  Without a sidecar (or without the key): 2^32 counts per revolution, zero
  offset 0, direction +1 on every joint. The sidecar may also hold
  ``"params"`` (the arm's structural parameters, keys as
  :class:`aacmm.core.Params`), used by ``aacmm mc --log`` unless overridden.

Errors: :class:`PoseLogError` (an ``AacmmError`` and a ``ValueError``) for a
file that cannot be read or does not follow the contract, with the file
name and line in the message.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aacmm.core import JOINTS, EncoderConfig, FloatArray, KinematicsError, Params, counts_to_angles
from aacmm.errors import AacmmError
from aacmm.fileio import InputFileError, load_json

COUNT_COLUMNS: tuple[str, ...] = tuple(f"count{i}" for i in range(1, JOINTS + 1))
COUNT_ALIASES: tuple[str, ...] = tuple(f"c{i}" for i in range(1, JOINTS + 1))
THETA_COLUMNS: tuple[str, ...] = tuple(f"theta{i}" for i in range(1, JOINTS + 1))


class PoseLogError(AacmmError, ValueError):
    """A pose log cannot be read or does not follow the contract."""


@dataclass(frozen=True)
class PoseLog:
    """Poses read from a log: ``theta_rad`` (n, 6), the columns used, the sidecar."""

    path: Path
    theta_rad: FloatArray
    columns: tuple[str, ...]
    encoders: EncoderConfig
    params: Params | None
    sidecar: Path | None


def _sidecar(path: Path) -> Path | None:
    for cand in (path.with_name(path.name + ".json"), path.with_suffix(".json")):
        if cand != path and cand.is_file():
            return cand
    return None


def _read_sidecar(path: Path) -> tuple[EncoderConfig, Params | None]:
    try:  # bounded nesting: a hostile sidecar is one clear error
        meta: Any = load_json(path)
    except InputFileError as e:
        raise PoseLogError(f"sidecar {e}") from None
    if not isinstance(meta, dict):
        raise PoseLogError(f"{path}: sidecar must be a JSON object")
    enc = EncoderConfig()
    if "encoders" in meta:
        e_meta = meta["encoders"]
        try:
            enc = EncoderConfig(
                counts_per_rev=e_meta.get("counts_per_rev", enc.counts_per_rev),
                zero_offset_counts=e_meta.get("zero_offset_counts", enc.zero_offset_counts),
                direction=e_meta.get("direction", enc.direction),
            )
            enc.to_c()
        except (AttributeError, TypeError, ValueError) as e:
            raise PoseLogError(f'{path}: bad "encoders": {e}') from e
    params = None
    if "params" in meta:
        try:
            params = Params(**meta["params"])
            params.validate()
        except (TypeError, ValueError) as e:
            raise PoseLogError(f'{path}: bad "params": {e}') from e
    return enc, params


def read_pose_log(path: str | Path, encoders: EncoderConfig | None = None) -> PoseLog:
    """Read the poses of a log CSV (see the module docstring for the format).

    ``encoders`` overrides the sidecar's encoder configuration.
    Raises PoseLogError for a missing/unreadable file, a missing header, no
    joint columns, a bad value (with its line number), an empty log, or a
    bad sidecar.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise PoseLogError(f"{p}: cannot read log: {e}") from e
    numbered = [
        (i + 1, line)
        for i, line in enumerate(text.splitlines())
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not numbered:
        raise PoseLogError(f"{p}: empty log (no header row)")
    rows = list(csv.reader(line for _, line in numbered))
    header = [h.strip().lower() for h in rows[0]]
    for cols in (COUNT_COLUMNS, COUNT_ALIASES, THETA_COLUMNS):
        if all(c in header for c in cols):
            break
    else:
        raise PoseLogError(
            f"{p}: header has no joint columns (need {','.join(COUNT_COLUMNS)} "
            f"or {','.join(THETA_COLUMNS)}); got {','.join(header)}"
        )
    idx = [header.index(c) for c in cols]
    counts = cols is not THETA_COLUMNS
    values = np.empty((len(rows) - 1, JOINTS), dtype=np.uint64 if counts else np.float64)
    for r, (row, (lineno, _)) in enumerate(zip(rows[1:], numbered[1:], strict=True)):
        try:
            if counts:
                v = [int(row[i]) for i in idx]
                if any(x < 0 or x > 0xFFFFFFFF for x in v):
                    raise ValueError("encoder reading outside 0 .. 2^32-1")
                values[r] = v
            else:
                values[r] = [float(row[i]) for i in idx]
        except (ValueError, IndexError) as e:
            raise PoseLogError(f"{p}:{lineno}: bad joint value: {e}") from e
    if values.shape[0] == 0:
        raise PoseLogError(f"{p}: log has a header but no poses")
    side = _sidecar(p)
    enc, params = _read_sidecar(side) if side is not None else (EncoderConfig(), None)
    if encoders is not None:
        enc = encoders
    if counts:
        try:
            theta = counts_to_angles(values, enc)
        except KinematicsError as e:
            line = numbered[1 + (e.index or 0)][0]
            raise PoseLogError(f"{p}:{line}: {e} (reading beyond counts_per_rev?)") from e
    else:
        theta = np.asarray(values, dtype=np.float64)
        if not np.all(np.isfinite(theta)):
            raise PoseLogError(f"{p}: joint angles must be finite")
    return PoseLog(p, theta, cols, enc, params, side)
