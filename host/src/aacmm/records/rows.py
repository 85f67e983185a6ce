"""Recorded rows of encoder counts, each with the parameter set it was taken with.

:class:`Recorded` is what logs and sessions have in common: the N raw
counts per row (N the joints of the arm, 4 to 7; the paper's six), the CRC
of the parameter set in force per row, and the sets themselves. It turns
counts into joint angles with *each row's own* encoder configuration and
recomputes points with each row's own kinematic
parameters (or with parameters the caller gives, e.g. a calibration's), on
the double-precision C core (:mod:`aacmm.core`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from aacmm.arm import Arm
from aacmm.core import FloatArray, KinematicsError, Model, Params, counts_to_angles
from aacmm.errmodel import ErrorModel
from aacmm.errmodel import points as em_points
from aacmm.records.files import RecordError, crc_hex
from aacmm.records.paramsets import ParamSetRecord

UIntArray = npt.NDArray[np.uint64]
U32Array = npt.NDArray[np.uint32]


@dataclass(frozen=True, eq=False)
class Recorded:
    """Rows of counts with their parameter sets.

    ``counts``: (n, N) raw encoder readings; ``param_crc32``: (n,) the CRC of
    the set in force for each row, a key of ``param_sets`` (each an arm of N
    joints: the readers check it).
    """

    path: Path
    counts: UIntArray
    param_crc32: U32Array
    param_sets: dict[int, ParamSetRecord]

    def __len__(self) -> int:
        return int(self.counts.shape[0])

    @property
    def joints(self) -> int:
        """N, the joints of the arm the rows were taken with (count columns)."""
        return int(self.counts.shape[1])

    def check_model(self, model: Params | Arm, what: str = "the model given") -> None:
        """Refuse a model of another arm than the rows' (before anything is computed).

        Raises:
            RecordError: ``model`` has another joint count, or another shape
                (conventions, betas, tip kind) than the rows' parameter sets.
        """
        arm = model if isinstance(model, Arm) else model.to_arm()
        if arm.n_joints != self.joints:
            raise RecordError(
                f"{self.path}: taken with an arm of {self.joints} joints; {what} is an arm "
                f"of {arm.n_joints} joints: not this arm's model"
            )
        for ps in self.param_sets.values():
            own = ps.arm
            if (own.tip, own.beta_joints, [j.convention for j in own.joints]) != (
                arm.tip,
                arm.beta_joints,
                [j.convention for j in arm.joints],
            ):
                raise RecordError(
                    f"{self.path}: taken with parameter set {ps.crc_hex} ({ps.describe()}); "
                    f"{what} is an arm of another shape ({arm.n_joints} joints, "
                    f"{arm.n_params} parameters): not this arm's model"
                )

    def where(self, row: int) -> str:
        """``FILE: row N`` for messages (files with line numbers say ``FILE:LINE``)."""
        return f"{self.path}: row {row + 1}"

    def param_set_of(self, row: int) -> ParamSetRecord:
        """The parameter set in force for one row."""
        return self.param_sets[int(self.param_crc32[row])]

    def set_changes(self) -> list[tuple[int, int]]:
        """``(row, crc)`` at the first row and wherever the set in force changes."""
        out: list[tuple[int, int]] = []
        last = None
        for i, c in enumerate(self.param_crc32.tolist()):
            if c != last:
                out.append((i, c))
                last = c
        return out

    def _groups(self) -> list[tuple[ParamSetRecord, npt.NDArray[np.intp]]]:
        return [
            (self.param_sets[int(c)], np.flatnonzero(self.param_crc32 == c))
            for c in np.unique(self.param_crc32)
        ]

    def angles_rad(self) -> FloatArray:
        """Joint angles (n, N) from the counts, each row with its own encoder configuration.

        Raises:
            RecordError: a reading the row's encoder configuration rejects
                (at or beyond its counts per revolution).
        """
        out = np.empty((len(self), self.joints), dtype=np.float64)
        for ps, rows in self._groups():
            try:
                out[rows] = counts_to_angles(self.counts[rows], ps.encoders)
            except KinematicsError as exc:
                bad = int(rows[exc.index or 0])
                raise RecordError(
                    f"{self.where(bad)}: {exc} (reading beyond the counts per "
                    f"revolution of parameter set {ps.crc_hex}?)"
                ) from None
        return out

    def row_temperatures(self) -> FloatArray | None:
        """The device's link temperatures (n, N) of the rows, degC (NaN: no reading),
        or None when the rows carry none (sessions and logs override this)."""
        return None

    def _thermal_points(
        self, ps: ParamSetRecord, theta: FloatArray, rows: npt.NDArray[np.intp]
    ) -> FloatArray:
        """Rows taken with a set whose thermal block the device applied: each at its own
        link temperatures (a row without all N readings has no point: NaN, as the
        device gave none)."""
        temps = self.row_temperatures()
        if temps is None:
            raise RecordError(
                f"{self.path}: taken with parameter set {ps.crc_hex}, whose thermal block the "
                "device applied at its link temperatures, but the rows carry none"
            )
        t = temps[rows]
        out = np.full((len(rows), 3), np.nan)
        ok = np.isfinite(t).all(axis=1)
        if ok.any():
            try:
                out[ok] = ps.points(theta[rows][ok], t[ok])
            except KinematicsError as exc:
                raise RecordError(f"{self.path}: {exc}") from None
        return out

    def points_mm(
        self,
        params: Params | Arm | None = None,
        errmodel: ErrorModel | None = None,
        temp_c: FloatArray | None = None,
    ) -> FloatArray:
        """Probe points (n, 3) recomputed from the counts in double precision.

        Each row uses the kinematic parameters (and encoder harmonics; with a thermal
        block, at the row's own link temperatures, :meth:`row_temperatures`) of its own
        set in force, or
        ``params`` for every row if given (e.g. a calibrated set); the encoder
        configuration is always the row's own. ``errmodel``: the readings
        corrected and the lengths scaled by this error model instead of the set's
        (:func:`aacmm.errmodel.points`) at the link temperatures ``temp_c``
        (degC, one per link; None: the reference temperatures).

        Raises:
            RecordError: ``params`` or ``errmodel`` is of another arm
                (:meth:`check_model`), a temperature the core refuses.
        """
        if params is not None:
            self.check_model(params)
        if errmodel is not None and errmodel.joints != self.joints:
            raise RecordError(
                f"{self.path}: taken with an arm of {self.joints} joints; the error model "
                f"is of {errmodel.joints} joints"
            )
        theta = self.angles_rad()
        out = np.empty((len(self), 3), dtype=np.float64)
        for ps, rows in self._groups():
            if errmodel is None:
                if params is None and ps.thermal:
                    out[rows] = self._thermal_points(ps, theta, rows)
                elif params is None:
                    out[rows] = ps.points(theta[rows])  # with the set's error model, if any
                else:
                    out[rows] = Model(params).points(theta[rows])
                continue
            model = Model(params if params is not None else ps.model)
            try:
                out[rows] = em_points(model, errmodel, theta[rows], temp_c)
            except KinematicsError as exc:
                raise RecordError(f"{self.path}: {exc}") from None
        return out

    def single_params(self, what: str) -> Params | Arm:
        """The kinematic parameters, if every row has the same (encoders may differ).

        Raises:
            RecordError: the rows were taken with different kinematic parameters;
                ``what`` names the consumer in the message.
        """
        changes = self.set_changes()
        first: Params | Arm = self.param_sets[changes[0][1]].model if changes else Params()
        for row, crc in changes[1:]:
            if self.param_sets[crc].model != first:
                raise RecordError(
                    f"{self.path}: the parameter set changes at row {row + 1} "
                    f"({crc_hex(changes[0][1])} -> {crc_hex(crc)}) and {what} uses one set: "
                    "analyse the parts separately"
                )
        return first
