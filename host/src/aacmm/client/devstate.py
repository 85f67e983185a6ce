"""Device state in words: where the parameters came from, where they are stored
and whether that survives power-off, why the device last started, and the
encoder inputs and the link temperature sensors (device info + diagnostics,
docs/protocol.md 2.2 and 2.6).

Used by ``aacmm info`` (text and ``--json``), the ``params`` commands and the
log's sidecar (:func:`info_dict`).
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

from aacmm.protocol import (
    BuildFlags,
    DeviceInfo,
    Diagnostics,
    EncoderFault,
    EncoderInterface,
    ParamSource,
    ResetCause,
    Sample,
    SampleStatus,
    SlotState,
    StorageFlags,
    StorageKind,
    StorageState,
)
from aacmm.protocol.constants import TEMP_NONE

PARAM_SOURCE_TEXT = {
    ParamSource.DEFAULTS: "built-in defaults",
    ParamSource.STORAGE: "the stored set (a restart loads it)",
    ParamSource.HOST: "set by the host, not saved: lost at restart",
}

STORAGE_KIND_TEXT = {
    StorageKind.NONE: "none (parameters cannot be saved)",
    StorageKind.RAM: "RAM (lost at every restart)",
    StorageKind.RAM_RETAINED: "RAM kept across resets (lost at power-off)",
    StorageKind.FILE: "file",
    StorageKind.FLASH: "flash",
    StorageKind.EEPROM: "EEPROM",
}

SLOT_TEXT = {
    SlotState.ERASED: "erased",
    SlotState.NEWEST: "newest record",
    SlotState.OLDER: "older record, the fallback",
    SlotState.BAD_CRC: "rejected: CRC mismatch (a cut save or damage)",
    SlotState.BAD_CONTENTS: "rejected: parameters out of range",
    SlotState.VERSION: "rejected: record of another format version",
    SlotState.BAD_LENGTH: "rejected: wrong payload length",
    SlotState.INCOMPLETE: "rejected: incomplete record (a save cut after it began)",
    SlotState.UNRECOGNISED: "rejected: not a record (unrecognised data)",
    SlotState.READ_ERROR: "unreadable (storage read failed)",
}

RESET_TEXT = {
    ResetCause.UNKNOWN: "cause not recorded",
    ResetCause.POWER_ON: "power-on",
    ResetCause.PIN: "reset pin or debugger",
    ResetCause.WATCHDOG: "WATCHDOG (the main loop stalled)",
    ResetCause.SOFTWARE: "software reset request",
    ResetCause.FAULT: "CPU FAULT",
}

INTERFACE_TEXT = {
    EncoderInterface.COUNTS: "counts from the port",
    EncoderInterface.BISS_C: "BiSS-C",
    EncoderInterface.SSI_BINARY: "SSI binary",
    EncoderInterface.SSI_GRAY: "SSI Gray",
}

FAULT_TEXT = {
    EncoderFault.NONE: "none",
    EncoderFault.CRC: "CRC mismatch",
    EncoderFault.ERROR_BIT: "encoder error bit",
    EncoderFault.STUCK_LOW: "data line stuck low",
    EncoderFault.STUCK_HIGH: "data line stuck high (no answer)",
    EncoderFault.TIMEOUT: "timeout (no start bit or short frame)",
    EncoderFault.FRAMING: "framing",
    EncoderFault.RANGE: "count beyond counts per revolution",
    EncoderFault.READ: "read failed",
}


def _name(enum: Any, value: int) -> str:
    try:
        return str(enum(value).name.lower())
    except ValueError:
        return f"unknown ({value})"


def _text(table: dict[Any, str], enum: Any, value: int) -> str:
    try:
        return table[enum(value)]
    except ValueError:
        return f"unknown ({value})"


def persistent(d: Diagnostics) -> bool:
    """The parameter store survives power-off."""
    return bool(d.storage_flags & StorageFlags.PERSISTENT)


def has_saved_set(d: Diagnostics | None) -> bool:
    """Storage holds a valid record (what a restart loads)."""
    return d is not None and SlotState.NEWEST in d.slot_state


def param_source_text(info: DeviceInfo, d: Diagnostics | None) -> str:
    """Where the active set came from, and what a restart does."""
    text = _text(PARAM_SOURCE_TEXT, ParamSource, info.param_source)
    if info.param_source == ParamSource.DEFAULTS and has_saved_set(d):
        text += " (not saved: a restart loads the stored set)"
    if info.param_source == ParamSource.STORAGE and d is not None and not persistent(d):
        text += ", but the store is lost at power-off"
    return text


def storage_text(d: Diagnostics) -> str:
    """One line: the store and what each slot holds."""
    kind = _text(STORAGE_KIND_TEXT, StorageKind, d.storage_kind)
    if d.storage_kind == StorageKind.NONE:
        return kind
    if d.storage_kind in (StorageKind.FILE, StorageKind.FLASH, StorageKind.EEPROM):
        kind += ", persistent" if persistent(d) else ", NOT persistent"
    slots = []
    for k in range(2):
        st, gen = d.slot_state[k], d.slot_generation[k]
        s = f"slot {k}: {_text(SLOT_TEXT, SlotState, st)}"
        if st in (SlotState.NEWEST, SlotState.OLDER):
            s += f" (generation {gen})"
        elif st in (SlotState.BAD_CRC, SlotState.BAD_CONTENTS, SlotState.BAD_LENGTH):
            s += f" (generation field {gen})"
        slots.append(s)
    return f"{kind}; " + "; ".join(slots)


def storage_warning(d: Diagnostics) -> str | None:
    """A warning when a rejected slot may have held a newer set than the one in use."""
    states = d.slot_state
    if SlotState.NEWEST not in states:
        return None
    good = states.index(SlotState.NEWEST)
    other = 1 - good
    if states[other] in (SlotState.BAD_CRC, SlotState.BAD_CONTENTS, SlotState.BAD_LENGTH):
        diff = (d.slot_generation[other] - d.slot_generation[good]) & 0xFFFFFFFF
        if 0 < diff < 0x80000000:
            return (
                f"slot {other} was rejected and names a newer generation: the set in use "
                f"(slot {good}) may be older than the last save"
            )
    return None


def reset_text(d: Diagnostics) -> str:
    text = _text(RESET_TEXT, ResetCause, d.reset_cause)
    if d.reset_cause == ResetCause.FAULT:
        text += f" at pc 0x{d.fault_pc:08x}"
    if d.reset_raw:
        text += f" (reset register 0x{d.reset_raw:08x})"
    parts = [text]
    if d.boot_count:
        parts.append(f"start {d.boot_count} since power-up")
    parts.append(f"watchdog {d.watchdog_ms} ms" if d.watchdog_ms else "no watchdog")
    parts.append(f"up {d.uptime_us / 1e6:.1f} s")
    return ", ".join(parts)


def joint_text(j: Any) -> str:
    iface = _text(INTERFACE_TEXT, EncoderInterface, j.interface)
    if j.interface != EncoderInterface.COUNTS:
        iface += f" {j.bits} bit"
    if not j.faults and not j.warnings:
        return f"{iface}, no faults"
    text = f"{iface}, {j.faults} faults"
    if j.faults:
        text += f" (last: {_text(FAULT_TEXT, EncoderFault, j.last_fault)})"
    if j.warnings:
        text += f", {j.warnings} warnings"
    return text


def encoder_lines(d: Diagnostics) -> list[str]:
    """One line for identical healthy joints (all N of the arm model), else one per joint."""
    texts = [joint_text(j) for j in d.joints]
    if len(set(texts)) == 1:
        return [f"joints 1-{len(texts)}: {texts[0]}"]
    return [f"joint {i + 1}: {t}" for i, t in enumerate(texts)]


def has_temperatures(info: DeviceInfo) -> bool:
    """The device reads its link temperatures (build flag TEMPERATURES, set at run time)."""
    return bool(info.build_flags & BuildFlags.TEMPERATURES)


def stream_temperatures(transport: object, info: DeviceInfo, thermal: bool) -> bool:
    """Whether a stream on ``transport`` asks the device for its link temperatures.

    Yes when the device reads them, with one exception: on a CAN link with a set
    in force without the thermal block (``thermal`` False). A sample with
    temperatures does not fit the CAN sample frames and goes as SAMPLE_EVT over
    ISO-TP, as one with the Jacobian does (docs/protocol.md 4.1): about twice the
    bus frames, beyond a 1 Mbit/s bus at 1 kHz, for readings the points do not
    depend on. With the thermal block the points depend on them, so they are
    asked for (and records recompute each row at its readings); the device still
    flags a sample with a temperature fault either way (TEMP_FAULT is in the
    PointZ frame)."""
    from aacmm.transport import CanTransport

    if not has_temperatures(info):
        return False
    return thermal or not isinstance(transport, CanTransport)


def temperature_text(info: DeviceInfo, d: Diagnostics | None) -> str:
    """One line: whether the device reads link temperatures, and its samples with a
    temperature fault (a counter never cleared)."""
    if not has_temperatures(info):
        return "no sensors (the device reads no link temperature)"
    text = "a sensor per link"
    if d is not None:
        text += (
            f", {d.temp_faults} samples with a temperature fault"
            if d.temp_faults
            else ", no temperature faults"
        )
    return text


def no_point_reason(sample: Sample) -> str:
    """Why a sample without a point gives none, in words (a ``TEMP_FAULT`` with the
    thermal model in force: the links whose temperature was not read)."""
    if not sample.status & SampleStatus.TEMP_FAULT:
        return "point not valid"
    links = [
        str(i + 1)
        for i, v in enumerate(sample.temp or ())
        if v == TEMP_NONE or not -4000 <= v <= 8500
    ]
    which = f"link {', '.join(links)}" if links else "a link"
    return (
        f"no point: the temperature of {which} was not read (TEMP_FAULT; the device "
        "compensates thermal expansion and needs every link's)"
    )


def diag_dict(d: Diagnostics) -> dict[str, Any]:
    """Diagnostics as JSON-ready data, with names beside the codes."""
    out: dict[str, Any] = asdict(d)
    out["storage_kind_name"] = _name(StorageKind, d.storage_kind)
    out["storage_persistent"] = persistent(d)
    out["storage_text"] = storage_text(d)
    out["slot_state_names"] = [_name(SlotState, s) for s in d.slot_state]
    out["reset_cause_name"] = _name(ResetCause, d.reset_cause)
    out["reset_text"] = reset_text(d)
    for jd, j in zip(out["joints"], d.joints, strict=True):
        jd["interface_name"] = _name(EncoderInterface, j.interface)
        jd["last_fault_name"] = _name(EncoderFault, j.last_fault)
    warning = storage_warning(d)
    if warning:
        out["storage_warning"] = warning
    return out


def info_dict(info: DeviceInfo) -> dict[str, Any]:
    """Device info as JSON-ready data (with readable names beside the codes)."""
    d: dict[str, Any] = asdict(info)
    d["firmware"] = f"{info.fw_major}.{info.fw_minor}.{info.fw_patch}"
    d["build_flags_names"] = [f.name for f in BuildFlags if f.name and info.build_flags & f.value]
    d["param_crc32_hex"] = f"0x{info.param_crc32:08x}"
    d["temperature_sensors"] = has_temperatures(info)
    try:
        d["param_source_name"] = ParamSource(info.param_source).name.lower()
    except ValueError:
        d["param_source_name"] = f"unknown ({info.param_source})"
    try:
        d["storage_state_name"] = StorageState(info.storage_state).name.lower()
    except ValueError:
        d["storage_state_name"] = f"unknown ({info.storage_state})"
    return d
