"""Device commands: ``aacmm info``, ``aacmm params``, ``aacmm measure``, ``aacmm compute``.

Each opens the device named by ``--port`` (or ``$AACMM_PORT``), checks the
protocol version, does its work and prints the result (``--json`` for
machine-readable output). Errors end the command through
:func:`aacmm.cli.main`: one line on stderr and the status of
:mod:`aacmm.commands.exitcodes`.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aacmm.commands.common import (
    add_connection_options,
    add_force_option,
    device_from_args,
    flag_names,
    link_temperatures,
    print_err,
)
from aacmm.commands.exitcodes import OK, UsageError
from aacmm.errors import DeviceError
from aacmm.fileio import check_outputs
from aacmm.records.files import fmt_point
from aacmm.records.schema import temps_c

if TYPE_CHECKING:
    from aacmm.client import Client
    from aacmm.protocol import ComputeResult, Jacobian, ParamSet, Sample

JAC_ROWS = 3
JAC_COLS = 25
PARAM_COLUMN_NAMES = (
    [f"theta{i}" for i in range(1, 7)]
    + [f"alpha{i}" for i in range(1, 7)]
    + [f"d{i}" for i in range(1, 7)]
    + [f"a{i}" for i in range(1, 7)]
    + ["l"]
)


class ReadBackError(DeviceError):
    """The device's parameters differ from what was sent (exit status 1)."""

    def __init__(self, message: str) -> None:
        super().__init__(message, status=-2)


def register(sub: Any) -> None:
    info = sub.add_parser(
        "info",
        help="device identity, firmware, protocol version and parameter state",
        description="Connect, check the protocol version and print the device info.",
    )
    add_connection_options(info)
    info.add_argument("--json", action="store_true", help="print JSON")
    info.set_defaults(func=cmd_info)

    params = sub.add_parser(
        "params",
        help="read, write, store or reset the device's parameter set",
        description="Parameter sets as TOML or JSON files (see docs/cli.md).",
    )
    psub = params.add_subparsers(dest="params_command", metavar="ACTION", required=True)
    get = psub.add_parser("get", help="print the active set or write it to a file")
    add_connection_options(get)
    get.add_argument(
        "-o", "--output", metavar="FILE", help="write to FILE (.toml or .json) instead of stdout"
    )
    get.add_argument(
        "--format", choices=("toml", "json"), default=None, help="stdout format (default toml)"
    )
    add_force_option(get)
    get.set_defaults(func=cmd_params_get)
    pset = psub.add_parser(
        "set",
        help="validate a file, send it, read the set back and compare",
        description="Validate FILE (nothing is sent if it is bad), activate it on the device, "
        "then read the active set back and compare it and its CRC with the file.",
    )
    add_connection_options(pset)
    pset.add_argument("file", metavar="FILE", help="parameter file (.toml or .json)")
    pset.add_argument("--save", action="store_true", help="also store it on the device")
    pset.add_argument("--check", action="store_true", help="only validate FILE; do not connect")
    pset.add_argument(
        "--override",
        action="store_true",
        help="send FILE even if its [arm] table names another device serial number",
    )
    pset.set_defaults(func=cmd_params_set)
    save = psub.add_parser("save", help="store the active set in the device's storage")
    add_connection_options(save)
    save.set_defaults(func=cmd_params_save)
    dflt = psub.add_parser("defaults", help="activate the device's built-in default set")
    add_connection_options(dflt)
    dflt.add_argument("--save", action="store_true", help="also store the defaults")
    dflt.set_defaults(func=cmd_params_defaults)

    meas = sub.add_parser(
        "measure",
        help="one sample: encoder counts, point, status (optionally the Jacobian)",
        description="Ask the device for one sample now.",
    )
    add_connection_options(meas)
    meas.add_argument(
        "-j",
        "--jacobian",
        action="store_true",
        help="include the 3 x P Jacobian (P = 25: the paper's arm)",
    )
    meas.add_argument("--json", action="store_true", help="print JSON")
    meas.set_defaults(func=cmd_measure)  # with the link temperatures when the device reads them

    comp = sub.add_parser(
        "compute",
        help="have the device compute the point (and Jacobian) for its N encoder counts",
        description="Send six encoder readings; print the device's point and optional Jacobian.",
    )
    add_connection_options(comp)
    comp.add_argument(
        "counts",
        nargs="+",
        type=_count,
        metavar="COUNT",
        help="the arm model's N (4..7; the paper's arm: 6) encoder counts 0..2^32-1",
    )
    comp.add_argument(
        "-j",
        "--jacobian",
        action="store_true",
        help="include the 3 x P Jacobian (P = 25: the paper's arm)",
    )
    comp.add_argument(
        "--temperature",
        metavar="C[,C...]",
        help="compute at these link temperatures, degC (-40 .. 85): one for every link or one "
        "per link (default: the parameters' reference temperatures)",
    )
    comp.add_argument("--json", action="store_true", help="print JSON")
    comp.set_defaults(func=cmd_compute)


def _count(text: str) -> int:
    try:
        v = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 0 <= v <= 0xFFFFFFFF:
        raise argparse.ArgumentTypeError(f"{v} outside 0..4294967295")
    return v


def _print_json(data: Any) -> None:
    print(json.dumps(data, indent=2))


def _jacobian_text(jac: Jacobian, names: Sequence[str] = PARAM_COLUMN_NAMES) -> str:
    """The 3 x P Jacobian, one line per column named by the device's arm model."""
    lines = ["jacobian (mm per parameter unit; rows x, y, z):"]
    for c, name in enumerate(names):
        vals = "  ".join(f"{jac[r][c]:+.6e}" for r in range(JAC_ROWS))
        lines.append(f"  {name:<7} {vals}")
    return "\n".join(lines)


def _column_names(dev: Any) -> tuple[str, ...]:
    """The Jacobian's column names of the device's arm model (the paper's 25 for it)."""
    arm, _ = dev.client.get_params().to_arm()
    return tuple(arm.param_names)


def _jacobian_rows(jac: Jacobian) -> list[list[float]]:
    return [list(row) for row in jac]


# ---------------------------------------------------------------- info


def cmd_info(args: argparse.Namespace) -> int:
    from aacmm.client import devstate

    with device_from_args(args) as dev:
        d = devstate.info_dict(dev.info)
        d["url"] = dev.url
        d["transport"] = dev.client.transport.description
        diag = dev.client.diagnostics()
        ps = dev.client.get_params()
        rtt = dev.client.ping()
        d["ping_ms"] = round(rtt * 1e3, 3)
    d["error_model"] = {
        "harmonics": list(ps.harmonics),
        "thermal": bool(ps.cte),
        "text": errmodel_text(ps),
    }
    d["param_source_text"] = devstate.param_source_text(dev.info, diag)
    d["diagnostics"] = devstate.diag_dict(diag) if diag is not None else None
    if args.json:
        _print_json(d)
        return OK
    print(f"device      {d['url']} ({d['transport']})")
    print(f"serial no.  {d['serial_number']}")
    print(f"firmware    {d['firmware']}, protocol {d['protocol_version']}")
    print(f"build       {' '.join(d['build_flags_names']) or '-'}")
    print(f"parameters  crc {d['param_crc32_hex']}, {d['param_source_text']}")
    print(f"arm model   {dev.info.joints} joints, {dev.info.params} parameters")
    print(f"error model {d['error_model']['text']}")
    if diag is None:
        print(f"storage     {d['storage_state_name']}")
    else:
        print(f"storage     {devstate.storage_text(diag)}")
        warning = devstate.storage_warning(diag)
        if warning:
            print(f"            warning: {warning}")
        print(f"reset       {devstate.reset_text(diag)}")
        lines = devstate.encoder_lines(diag)
        print(f"encoders    {lines[0]}")
        for line in lines[1:]:
            print(f"            {line}")
        print(
            f"link        {diag.serial_frames_bad} bad frames, {diag.samples_dropped} samples "
            f"dropped, {diag.samples_late} late, {diag.encoder_faults} without a point"
        )
    print(f"temperature {devstate.temperature_text(dev.info, diag)}")
    print(f"max body    {d['max_body_bytes']} bytes, CAN node {d['can_node_id']}")
    print(f"ping        {d['ping_ms']:.3f} ms")
    return OK


# ---------------------------------------------------------------- params


def _local_crc(ps: ParamSet) -> int:
    from aacmm.protocol import param_set_crc32

    return param_set_crc32(ps)  # thread-safe (a CRC calculator per thread)


def cmd_params_get(args: argparse.Namespace) -> int:
    from aacmm.records.paramfile import dump_param_set, file_format, write_param_file

    if args.output:  # refused before the device is touched
        file_format(Path(args.output))
        check_outputs([args.output], args.force)
    from aacmm.protocol.errwire import error_model

    with device_from_args(args) as dev:
        ps = dev.client.get_params()
    crc = _local_crc(ps)
    em = error_model(ps) if ps.harm_cos or ps.cte else None  # the [errmodel] table
    if args.output:
        write_param_file(ps, args.output, crc, force=args.force, errmodel=em)
        extra = f"; error model: {errmodel_text(ps)}" if em is not None else ""
        print(f"wrote {args.output} (crc 0x{crc:08x}{extra})", file=sys.stderr)
    else:
        sys.stdout.write(dump_param_set(ps, args.format or "toml", crc, errmodel=em))
    return OK


def _verify(dev_params: ParamSet, sent: ParamSet, what: str) -> None:
    if dev_params != sent:
        from aacmm.records.paramfile import param_set_dict

        a, b = param_set_dict(sent), param_set_dict(dev_params)
        diff = [k for k in {**a, **b} if a.get(k) != b.get(k)] or ["the error model"]
        raise ReadBackError(f"{what}: the device reads back other values for {', '.join(diff)}")


def _check_arm(file: str, arm: Any, serial: int, override: bool) -> str:
    """'' or a note; refuses (WrongArmError) a file of another device serial number."""
    from aacmm.commands.exitcodes import WrongArmError

    if arm is None or arm.serial_number is None or arm.serial_number == serial:
        return ""
    what = f"{file}: a parameter set of the arm with serial number {arm.serial_number}"
    if not override:
        raise WrongArmError(
            f"{what}; this device is serial {serial}: not sent (--override sends it anyway)"
        )
    return f"; sent with --override to serial {serial} although it is {what[len(file) + 2 :]}"


def errmodel_text(ps: ParamSet) -> str:
    """The error model a parameter set carries, in words: ``encoder harmonics K per
    joint 2,2,2,2,2,2`` (and ``, thermal expansion``), or ``none (DH only)``."""
    from aacmm.records.paramsets import errmodel_text as text

    return text(ps.harmonics, bool(ps.cte))


def _with_file_errmodel(file: str, ps: ParamSet, em: Any) -> ParamSet:
    """``ps`` with the file's error model in its wire fields (its thermal expansion as
    the thermal block); UsageError (exit 2, nothing sent) for a value the wire cannot
    carry."""
    from aacmm.protocol.errwire import with_error_model

    if em is None:
        return ps
    try:
        return with_error_model(ps, em)
    except ValueError as exc:
        raise UsageError(f"{file}: [errmodel]: {exc}; nothing sent") from None


def cmd_params_set(args: argparse.Namespace) -> int:
    from aacmm.client.devstate import has_temperatures
    from aacmm.protocol import ParamSource
    from aacmm.records.paramfile import describe_errmodel, has_thermal, load_param_file_errmodel

    ps, arm, em = load_param_file_errmodel(args.file)  # validated before anything is sent
    if args.check:
        whose = (
            f", for the arm with serial number {arm.serial_number}"
            if arm is not None and arm.serial_number is not None
            else ""
        )
        shape = "" if ps.is_paper_shape else f", {ps.joints} joints, {ps.n_params} parameters"
        ps = _with_file_errmodel(args.file, ps, em)
        harm = f"; error model: {describe_errmodel(em)}" if em is not None else ""
        if em is not None and has_thermal(em):
            harm += " (only a device that reads its link temperatures takes it)"
        print(f"{args.file}: valid parameter set{shape}, crc 0x{_local_crc(ps):08x}{whose}{harm}")
        return OK
    ps = _with_file_errmodel(args.file, ps, em)
    want = _local_crc(ps)
    harm = f"; error model: {errmodel_text(ps)}" if em is not None else ""
    with device_from_args(args) as dev:
        c = dev.client
        if em is not None and has_thermal(em) and not has_temperatures(dev.info):
            raise UsageError(
                f"{args.file}: its [errmodel] table has thermal expansion (cte_per_k, tref_c): "
                "the device reads no link temperatures (no TEMPERATURES build flag) and cannot "
                "compensate it, nothing sent"
            )
        note = _check_arm(args.file, arm, dev.info.serial_number, args.override)
        before = c.get_params()
        change = _model_change(before, ps)
        got = _set_params(c, ps, before)
        if got != want:
            raise ReadBackError(
                f"device reports crc 0x{got:08x} for the set, expected 0x{want:08x}"
            )
        _verify(c.get_params(), ps, args.file)
        info = c.info()
        if info.param_crc32 != want:
            raise ReadBackError(f"device info names crc 0x{info.param_crc32:08x} after set")
        msg = f"active: {args.file} (crc 0x{want:08x}{harm}), read back and identical"
        if args.save:
            saved = c.save_params()
            if saved != want:
                raise ReadBackError(f"device stored crc 0x{saved:08x}, expected 0x{want:08x}")
            msg += "; saved"
            _warn_if_volatile(c, "params set")
        elif info.param_source == ParamSource.STORAGE:  # exactly the stored set
            msg += "; identical to the stored set"
        else:
            msg += (
                "; NOT saved: lost at restart (add --save, or run `aacmm params save` to keep it)"
            )
    print(msg + note)
    if change:
        print_err("params set", change)
    return OK


def _set_params(c: Client, ps: ParamSet, before: ParamSet) -> int:
    """SET_PARAMS; a set the device cannot serve (ERR_UNSUPPORTED: a joint count its
    encoders, or the simulator's replay, do not have) says so in its one line."""
    from aacmm.protocol import Status

    try:
        return c.set_params(ps)
    except DeviceError as exc:
        if exc.status != int(Status.ERR_UNSUPPORTED) or ps.joints == before.joints:
            raise
        raise DeviceError(
            f"{exc}: the device cannot serve an arm of {ps.joints} joints (its encoders, or "
            f"a simulator's replay file, give another joint count); the set in force, "
            f"{before.joints} joints, is unchanged",
            exc.status,
            exc.request_type,
        ) from None


def _shape(ps: ParamSet) -> str:
    conv = ps.convention or (0,) * ps.joints
    kinds = {0: "standard", 1: "modified"}
    conventions = "/".join(sorted({kinds[c] for c in conv}))
    betas = [i + 1 for i, b in enumerate(ps.beta_rad) if b is not None]
    tip = "tip l" if ps.tip_xy_mm is None else "tip vector"
    beta = ""
    if betas:
        beta = f", {'betas on joints' if len(betas) > 1 else 'a beta on joint'} "
        beta += ", ".join(map(str, betas))
    return f"{ps.joints} joints, {ps.n_params} parameters ({conventions} DH{beta}, {tip})"


def _model_change(before: ParamSet, after: ParamSet) -> str:
    """'' or a note that the set changes the device's arm model (its shape: N,
    conventions, betas, tip kind), not only its values (docs/cli.md)."""

    def key(ps: ParamSet) -> tuple[object, ...]:
        n = ps.joints
        conv = ps.convention or (0,) * n
        betas = tuple(b is not None for b in (ps.beta_rad or (None,) * n))
        return (n, conv, betas, ps.tip_xy_mm is None)

    if key(before) == key(after):
        return ""
    return f"note: the device's arm model changes from {_shape(before)} to {_shape(after)}"


def _warn_if_volatile(client: Client, cmd: str) -> None:
    """Warn on stderr when the device's store does not survive power-off."""
    from aacmm.client import devstate
    from aacmm.protocol import StorageKind

    diag = client.diagnostics()
    if diag is not None and not devstate.persistent(diag):
        kind = devstate.STORAGE_KIND_TEXT.get(StorageKind(diag.storage_kind), "unknown")
        print_err(
            cmd,
            f"warning: the device stores parameters in {kind}: "
            "the saved set will not survive a power cycle",
        )


def cmd_params_save(args: argparse.Namespace) -> int:
    with device_from_args(args) as dev:
        active = dev.info.param_crc32
        saved = dev.client.save_params()
        if saved != active:
            raise ReadBackError(f"device stored crc 0x{saved:08x}, active set is 0x{active:08x}")
        _warn_if_volatile(dev.client, "params save")
    print(f"saved the active set (crc 0x{saved:08x})")
    return OK


def cmd_params_defaults(args: argparse.Namespace) -> int:
    with device_from_args(args) as dev:
        c = dev.client
        crc = c.restore_defaults()
        ps = c.get_params()
        if _local_crc(ps) != crc:
            raise ReadBackError(
                f"device reports crc 0x{crc:08x} for its defaults but reads back another set"
            )
        msg = f"defaults active (crc 0x{crc:08x})"
        if args.save:
            saved = c.save_params()
            if saved != crc:
                raise ReadBackError(f"device stored crc 0x{saved:08x}, expected 0x{crc:08x}")
            msg += "; saved"
            _warn_if_volatile(c, "params defaults")
        else:
            from aacmm.client.devstate import has_saved_set

            if has_saved_set(c.diagnostics()):
                msg += "; not saved: a restart loads the stored set (add --save to replace it)"
    print(msg)
    return OK


# ---------------------------------------------------------------- measure / compute


def sample_dict(s: Sample) -> dict[str, Any]:
    d: dict[str, Any] = {
        "seq": s.seq,
        "device_time_us": s.timestamp_us,
        "counts": list(s.counts),
        "point_mm": [float(fmt_point(v)) for v in s.point_100nm],
        "flags": s.status,
        "flag_names": flag_names(s.status).split("|"),
    }
    t = temps_c(s.temp)
    if t is not None:
        d["temperatures_c"] = list(t)
    if s.jacobian is not None:
        d["jacobian"] = _jacobian_rows(s.jacobian)
    return d


def temps_text(temps: Sequence[float | None]) -> str:
    """``20.00 20.10 - ... C``: link temperatures (``-``: no reading)."""
    return " ".join("-" if t is None else f"{t:.2f}" for t in temps) + " C"


def cmd_measure(args: argparse.Namespace) -> int:
    from aacmm.client.devstate import has_temperatures

    with device_from_args(args) as dev:
        s = dev.client.measure(jacobian=args.jacobian, temperatures=has_temperatures(dev.info))
        names = _column_names(dev) if s.jacobian is not None else ()
    if args.json:
        _print_json(sample_dict(s))
        return OK
    x, y, z = (fmt_point(v) for v in s.point_100nm)
    print(f"seq         {s.seq}")
    print(f"time        {s.timestamp_us} us (device)")
    print(f"counts      {' '.join(str(c) for c in s.counts)}")
    print(f"point       x {x}  y {y}  z {z} mm")
    print(f"flags       0x{s.status:04x} {flag_names(s.status)}")
    t = temps_c(s.temp)
    if t is not None:
        print(f"temps       {temps_text(t)} (links 1-{len(t)})")
    if s.jacobian is not None:
        print(_jacobian_text(s.jacobian, names))
    return OK


def compute_dict(
    counts: list[int], r: ComputeResult, temps: list[float] | None = None
) -> dict[str, Any]:
    d: dict[str, Any] = {
        "counts": counts,
        "temperatures_c": temps if r.temperatures else None,
        "point_mm": list(r.point_mm),
        "flags": r.status,
        "flag_names": flag_names(r.status).split("|"),
    }
    if r.jacobian is not None:
        d["jacobian"] = _jacobian_rows(r.jacobian)
    return d


def cmd_compute(args: argparse.Namespace) -> int:
    if not 4 <= len(args.counts) <= 7:
        raise UsageError(
            f"compute needs the arm model's 4 to 7 encoder counts (its joints: `aacmm info`), "
            f"got {len(args.counts)}"
        )
    temps = link_temperatures(args.temperature, len(args.counts))
    with device_from_args(args) as dev:
        r = dev.client.compute(args.counts, jacobian=args.jacobian, temperatures_c=temps)
        names = _column_names(dev) if r.jacobian is not None else ()
    if temps is not None and not r.temperatures:
        print_err("compute", "warning: the device computed at its reference temperatures")
    if args.json:
        _print_json(compute_dict(args.counts, r, temps))
        return OK
    x, y, z = r.point_mm
    print(f"counts      {' '.join(str(c) for c in args.counts)}")
    if temps is not None:
        print(f"temps       {temps_text(temps)} (links 1-{len(temps)})")
    print(f"point       x {x:.6f}  y {y:.6f}  z {z:.6f} mm")
    print(f"flags       0x{r.status:04x} {flag_names(r.status)}")
    if r.jacobian is not None:
        print(_jacobian_text(r.jacobian, names))
    return OK
