"""``aacmm capture PLAN -o SESSION``: guided capture of a measurement plan.

The operator is prompted for every point of the plan in order ("step 3/4,
ball bar bar500, position 4 of 10: probe end A"); each press of the front
button (0) records the latched sample with its labels, the second button (1)
undoes the last point, and on a terminal the key ``u`` does the same (``q``
stops). With the keyboard in use, the end of the plan waits for the operator
to confirm it (button 0 or Enter; button 1 or ``u`` undoes the last point
first); without it the session ends at the last point (``--confirm-end``).
Every point is durable before it is acknowledged (``recorded k/N``), so
Ctrl-C, SIGTERM or kill -9 lose nothing acknowledged; ``--resume`` continues
a session; ``--from-log`` labels the presses recorded in an ``aacmm log``
trigger file in plan order instead of reading a device; ``--view`` serves the
live page of ``aacmm view`` beside the capture (:mod:`aacmm.commands.view`).
Session format: docs/plans.md.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import queue
import select
import signal
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aacmm.commands.common import (
    add_connection_options,
    device_param_set,
    is_tty,
    link_temperature,
    print_err,
)
from aacmm.commands.exitcodes import INTERRUPTED, OK, UsageError
from aacmm.commands.stopflag import StopFlag
from aacmm.commands.view import CAPTURE_VIEW_RATE_HZ, add_bind_options
from aacmm.errors import LinkLostError

if TYPE_CHECKING:
    from aacmm.client import SampleStream
    from aacmm.commands.common import Device
    from aacmm.plans import Plan, Slot
    from aacmm.protocol import Sample, Trigger
    from aacmm.records import ParamSetRecord, SessionWriter
    from aacmm.view.capture import CaptureView

#: Rate of the stream capture keeps open while it listens (a live link, and the
#: simulated operator's sign that capture is ready).
LISTEN_RATE_HZ = 20
POINT_VALID = 0x0001
BUTTON_CAPTURE = 0  # aacmm.protocol.Button.CAPTURE
BUTTON_UNDO = 1  # aacmm.protocol.Button.UNDO


def register(sub: Any) -> None:
    p = sub.add_parser(
        "capture",
        help="guided capture of a measurement plan into a session folder",
        description="Prompt for every point of PLAN (a plan file or a shipped plan's name) "
        "and record each press of the probe button with its labels into the session folder "
        "SESSION. Button 1 (or the key u on a terminal) undoes the last point, the last one "
        "included: on a terminal capture waits at the end of the plan until button 0 or "
        "Enter confirms it (see --confirm-end). Ctrl-C keeps everything; --resume continues; "
        "--from-log labels the presses of an existing log.",
    )
    add_connection_options(p)
    p.add_argument("plan", metavar="PLAN", help="plan file or shipped plan name (docs/plans.md)")
    p.add_argument("-o", "--output", required=True, metavar="SESSION", help="session folder")
    p.add_argument("--resume", action="store_true", help="continue the session in SESSION")
    p.add_argument(
        "--from-log",
        metavar="LOG.csv",
        help="no device: label the button presses of an 'aacmm log' run in plan order",
    )
    p.add_argument(
        "--stall",
        type=float,
        default=3.0,
        metavar="S",
        help="no sample for S seconds means the link is lost (default 3)",
    )
    p.add_argument(
        "--temperature",
        metavar="C",
        help="the links' temperature during this run, degC (-40 .. 85), as a thermometer on "
        "the arm reads it (a device with sensors records its own readings per point, which "
        "win where both are known): recorded in the session's run for "
        "aacmm verify --params",
    )
    p.add_argument("--no-keys", action="store_true", help="do not read keys from the terminal")
    p.add_argument(
        "--confirm-end",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="after the last point wait until button 0 (or Enter) confirms the end; button 1 "
        "(or u) undoes the last point (default: only when keys are read from a terminal; "
        "--no-confirm-end: end at the last point)",
    )
    p.add_argument(
        "-q", "--quiet", action="store_true", help="print only acknowledgements and the end prompt"
    )
    p.add_argument(
        "--view",
        action="store_true",
        help="also serve the live 3-D page (aacmm view) of the arm and the session; see --bind",
    )
    add_bind_options(p)
    p.set_defaults(func=cmd_capture)


def say(text: str) -> None:
    print(text, flush=True)


ARTEFACT_WORDS = {
    "cone": "cone seat",
    "sphere": "sphere",
    "ballbar": "ball bar",
    "gauge": "gauge",
    "plane": "plane",
    "part": "part",
}


def step_announcement(plan: Plan, step_index: int) -> str:
    """The line that opens a step: its number, id, points and artefact, and its note."""
    st = plan.steps[step_index]
    art = plan.artefacts.get(st.artefact or "")
    on = f" on {ARTEFACT_WORDS.get(art.type, art.type)} {art.id}" if art is not None else ""
    text = f"step {st.index + 1}/{len(plan.steps)} {st.id}: {st.points} points{on}"
    return f"{text}. {st.note}" if st.note else text


class Capture:
    """One ``aacmm capture`` run against a device."""

    def __init__(self, args: argparse.Namespace, plan: Plan) -> None:
        self.args = args
        self.plan = plan
        self.folder = Path(args.output)
        self.events: queue.Queue[tuple[float, Trigger]] = queue.Queue()
        self.writer: SessionWriter | None = None
        self.dev: Device | None = None
        self.keys = False
        self._tty_state: Any = None
        self.stop_reason: str | None = None
        self.fence_us: int | None = None
        self.stale = 0
        # The last point can be undone only while capture waits for the end to be
        # confirmed: by default when the operator has a keyboard (Enter confirms).
        wants_keys = not args.no_keys and is_tty(sys.stdin)
        self.confirm: bool = wants_keys if args.confirm_end is None else args.confirm_end
        self.confirmed: str | None = None  # how the end was confirmed
        self.view: CaptureView | None = None  # --view: the page, fed from here
        self.sensors = False  # the stream carries the device's link temperatures
        self.live: tuple[float, float] | None = None  # their range during this run
        self.live_warned = False

    # ---------------------------------------------------------- set-up

    def open_session(self, dev: Device, ps: ParamSetRecord) -> SessionWriter:
        from aacmm.client.devstate import info_dict, stream_temperatures
        from aacmm.records import SessionWriter

        self.sensors = stream_temperatures(dev.client.transport, dev.info, ps.thermal)

        if self.args.resume:
            w = SessionWriter.resume(self.folder, self.plan)
        else:
            w = SessionWriter.create(
                self.folder,
                self.plan,
                device=info_dict(dev.info),
                port=dev.url,
                transport=dev.client.transport.description,
                joints=ps.joints,
            )
        if self.args.resume:
            before = (w.meta.get("device") or {}).get("serial_number")
            if before is not None and before != dev.info.serial_number:
                print_err(
                    "capture",
                    f"warning: the session began on device serial {before}; this is serial "
                    f"{dev.info.serial_number} (recorded in the session's runs)",
                )
        if w.set_param_set(ps) and self.args.resume and len(w.param_sets) > 1:
            print_err("capture", f"note: the device's parameter set is now {ps.crc_hex}")
        stated = link_temperature(self.args.temperature)
        w.begin_run(
            "resume" if self.args.resume else "capture",
            port=dev.url,
            serial_number=dev.info.serial_number,
            param_crc32=ps.crc_hex,
            **({} if stated is None else {"temperature_c": stated}),
        )
        self._check_band(w, stated)
        return w

    def _check_band(self, w: SessionWriter, stated: float | None) -> None:
        """A plan's stability band: a warning when the temperatures stated for the
        session's runs break it, a note when this run states none and the arm reads
        none (a device with sensors: :meth:`watch_band` checks its live readings)."""
        band = self.plan.verification.temperature_band_c
        if band is None:
            return
        if stated is None and self.sensors:
            return
        if stated is None:
            print_err(
                "capture",
                f"note: the plan asks for the links' temperature within a {band:g} C band; the "
                "arm reads none: state it with --temperature C (a thermometer on the arm)",
            )
            return
        temps = [r["temperature_c"] for r in w.meta["runs"] if "temperature_c" in r]
        problem = self.plan.verification.band_problem(temps)
        if problem is not None:
            print_err("capture", f"warning: {problem}: let the arm settle before measuring")

    def watch_band(self, sample: Sample) -> None:
        """The device's live link temperatures: one warning when this run's readings
        leave the plan's stability band (their span, or their distance from the plan's
        temperature)."""
        from aacmm.records.schema import temps_c

        t = temps_c(sample.temp)
        band = self.plan.verification.temperature_band_c
        if t is None or band is None or self.live_warned:
            return
        read = [v for v in t if v is not None]
        if not read:
            return
        lo, hi = min(read), max(read)
        if self.live is not None:
            lo, hi = min(lo, self.live[0]), max(hi, self.live[1])
        self.live = (lo, hi)
        problem = self.plan.verification.band_problem([lo, hi])
        if problem is not None:
            self.live_warned = True
            print_err(
                "capture",
                f"warning: the device's link temperatures: {problem}: let the arm settle "
                "before measuring",
            )

    def _on_trigger(self, trig: Trigger) -> None:  # reader thread
        self.events.put((time.time(), trig))

    def start_keys(self) -> None:
        if self.args.no_keys or not is_tty(sys.stdin):
            return
        import termios
        import tty

        with contextlib.suppress(termios.error, OSError):
            fd = sys.stdin.fileno()
            self._tty_state = termios.tcgetattr(fd)
            tty.setcbreak(fd)
            self.keys = True

    def stop_keys(self) -> None:
        if self._tty_state is not None:
            import termios

            with contextlib.suppress(termios.error, OSError):
                termios.tcsetattr(sys.stdin.fileno(), termios.TCSADRAIN, self._tty_state)
            self._tty_state = None

    def read_key(self) -> str | None:
        if not self.keys:
            return None
        ready, _, _ = select.select([sys.stdin], [], [], 0)
        if not ready:
            return None
        data = os.read(sys.stdin.fileno(), 1)
        return data.decode("ascii", "replace").lower() if data else None

    # ---------------------------------------------------------- the run

    def prompt(self, slot: Slot) -> None:
        if self.args.quiet:
            return
        n = len(self.plan.slots)
        if slot.point_index == 0 and slot.position_index in (None, 0):
            say(step_announcement(self.plan, slot.step_index))
        keys = " (u: undo, q: stop)" if self.keys else ""
        say(f"[{slot.index + 1}/{n}] {slot.text}{keys}")

    def prompt_end(self) -> None:
        """The plan is complete; the operator confirms the end or undoes the last point."""
        if self.keys:
            say(
                "plan complete: press the button or Enter to finish, "
                "button 1 or u to undo the last point (q: stop)"
            )
        else:
            say("plan complete: press the button to finish, button 1 to undo the last point")

    def check_params(self, dev: Device, w: SessionWriter) -> None:
        """Before a point is taken: the set in force must be the one recorded."""
        from aacmm.records import ParamSetRecord

        crc = dev.client.info().param_crc32
        if w.current is not None and crc == w.current.crc32:
            return
        ps = ParamSetRecord.from_device(dev.client.get_params())
        w.set_param_set(ps)
        print_err("capture", f"warning: the device's parameter set changed to {ps.crc_hex}")

    def press(self, dev: Device, w: SessionWriter, host_time: float, trig: Trigger) -> None:
        from aacmm.client import device_time_after

        n = len(self.plan.slots)
        if self.fence_us is not None and not device_time_after(
            trig.sample.timestamp_us, self.fence_us
        ):
            w.ignored(trig.sample, host_time, trig.button, True, "pressed before capture listened")
            self.stale += 1
            return
        if trig.button == BUTTON_UNDO:
            self.undo(w, host_time)
            return
        if trig.button == BUTTON_CAPTURE and w.next_slot is None:
            self.confirmed = "button 0"
            w.confirm(trig.sample, host_time, trig.button, self.confirmed)
            return
        if trig.button != BUTTON_CAPTURE:
            w.ignored(trig.sample, host_time, trig.button, True, f"button {trig.button}")
            return
        if not trig.sample.status & POINT_VALID:
            from aacmm.client.devstate import no_point_reason

            why = no_point_reason(trig.sample)
            w.ignored(trig.sample, host_time, trig.button, True, why)
            say(f"  {why} (flags 0x{trig.sample.status:04x}): press again")
            return
        self.watch_band(trig.sample)
        self.check_params(dev, w)
        slot = w.record(trig.sample, host_time, trig.button)
        x, y, z = trig.sample.point_mm
        say(f"  recorded {slot.index + 1}/{n}: x {x:.4f} y {y:.4f} z {z:.4f} mm")

    def undo(self, w: SessionWriter, host_time: float | None) -> None:
        slot = w.undo(host_time)
        if slot is None:
            say("  nothing to undo")
        else:
            say(f"  undone {slot.index + 1}/{len(self.plan.slots)}: {slot.text}")

    def loop(self, dev: Device, w: SessionWriter, stream: SampleStream, stop: StopFlag) -> str:
        """Take presses until the plan is complete (and, with :attr:`confirm`, its end
        confirmed) or a stop; return the end status."""
        from aacmm.errors import DeviceTimeoutError, OperationError

        last_sample = time.monotonic()
        shown: int | None = None
        while True:
            slot = w.next_slot
            if slot is None and (not self.confirm or self.confirmed is not None):
                return "complete"
            where = len(self.plan.slots) if slot is None else slot.index
            if shown != where:
                if slot is None:
                    self.prompt_end()
                else:
                    self.prompt(slot)
                shown = where
            if stop.set:
                self.stop_reason = "SIGTERM" if stop.signal == signal.SIGTERM else "SIGINT"
                return "interrupted"
            # One event, the keyboard and the stream on every turn: a steady flow of
            # button events (a fast operator, or a backlog while the host is slow)
            # must not keep a key or the stall check waiting.
            try:
                host_time, trig = self.events.get(timeout=0.05 if self.view is None else 0.01)
            except queue.Empty:
                pass
            else:
                if trig.pressed:
                    self.press(dev, w, host_time, trig)
                    if self.view is not None:
                        self.view.changed(w.accepted)
                    if w.next_slot is None and (not self.confirm or self.confirmed):
                        continue  # complete
            key = self.read_key()
            if key == "u":
                self.undo(w, None)
                shown = None  # prompt again, also for the slot shown last
                if self.view is not None:
                    self.view.changed(w.accepted)
            elif key == "q":
                self.stop_reason = "key q"
                return "interrupted"
            elif key in ("\n", "\r") and w.next_slot is None and self.confirm:
                self.confirmed = "key Enter"
                w.confirm(None, time.time(), None, self.confirmed)
                continue
            try:
                while True:
                    sample = stream.get(timeout=0.0)
                    last_sample = time.monotonic()
                    self.watch_band(sample)
                    if self.view is not None:
                        self.view.on_sample(sample)
            except DeviceTimeoutError:
                pass
            except (StopIteration, OperationError) as exc:
                raise LinkLostError(f"link lost: {exc}") from None
            if time.monotonic() - last_sample > self.args.stall:
                raise LinkLostError(f"no sample for {self.args.stall:g} s")

    def run(self) -> int:
        from aacmm.commands.common import device_from_args
        from aacmm.commands.view import open_capture_server, start_capture_view

        stop = StopFlag()
        srv = open_capture_server(self.args) if self.args.view else None  # busy: before the device
        try:
            dev = device_from_args(self.args)
        except BaseException:
            if srv is not None:
                srv.close()
            raise
        status, reason, code = "error", "error", 1
        w: SessionWriter | None = None
        try:
            ps = device_param_set("capture", dev)
            w = self.open_session(dev, ps)
            # A session whose points are all taken but whose end was never confirmed
            # (killed while capture waited) waits for the confirmation again.
            if w.next_slot is None and not (self.confirm and w.opened_status != "complete"):
                say(f"session {self.folder} is complete ({w.accepted} points)")
                status, reason, code = "complete", "already complete", OK
                return OK
            if not self.args.quiet:
                what = "resumed" if self.args.resume else "new session"
                say(
                    f"plan {self.plan.name}: {self.plan.title} ({len(self.plan.slots)} points) "
                    f"-> {self.folder} ({what}, {w.accepted} points so far)"
                )
                say(f"device serial {dev.info.serial_number}, parameters {ps.crc_hex}")
            if srv is not None:
                self.view = start_capture_view(srv, dev, self.folder, self.plan)
            dev.client.add_trigger_callback(self._on_trigger)
            stop.install()
            self.start_keys()
            # The device clock now: a button event whose sample was read before it was
            # pressed before capture listened (for example one a device queued while no
            # host read it; answers do not wait behind queued events, so the order of
            # arrival cannot tell).
            self.fence_us = dev.client.measure().timestamp_us
            rate = LISTEN_RATE_HZ if self.view is None else CAPTURE_VIEW_RATE_HZ
            stream = dev.client.stream(rate, timeout=self.args.stall, temperatures=self.sensors)
            try:
                status = self.loop(dev, w, stream, stop)
            finally:
                with contextlib.suppress(Exception):
                    stream.stop()
            if self.stale:
                print_err("capture", f"ignored {self.stale} presses from before the start")
            if status == "complete":
                reason = f"confirmed by {self.confirmed}" if self.confirmed else "complete"
                code = OK
                say(f"complete: {w.accepted} points in {self.folder}")
            else:
                reason = self.stop_reason or "stopped"
                code = INTERRUPTED
            return code
        except LinkLostError as exc:
            status, reason = "link_lost", str(exc)
            raise
        except KeyboardInterrupt:
            status, reason = "interrupted", "SIGINT"
            raise
        finally:
            self.stop_keys()
            stop.restore()
            dev.close()
            if w is not None:
                w.close(status, reason)
                if status != "complete" and w.next_slot is None:
                    print_err(
                        "capture",
                        f"all {w.accepted} points kept in {self.folder}, the end not confirmed; "
                        "confirm it or undo the last point with --resume",
                    )
                elif status != "complete":
                    print_err(
                        "capture",
                        f"{w.accepted} of {len(self.plan.slots)} points kept in {self.folder}; "
                        "continue with --resume",
                    )
            if self.view is not None:
                self.view.changed()  # the page shows the session's end
                self.view.close()
            elif srv is not None:
                srv.close()


def cmd_capture(args: argparse.Namespace) -> int:
    from aacmm.fileio import check_output_dir, check_writable_dir
    from aacmm.plans import load_plan

    if not (args.stall > 0 and args.stall <= 3600):
        raise UsageError("--stall must be in (0, 3600] seconds")
    link_temperature(args.temperature)  # refused before anything else
    plan = load_plan(args.plan)
    folder = Path(args.output)
    if args.from_log is not None and args.view:
        raise UsageError("--view shows a device: it does not go with --from-log")
    if args.from_log is not None and args.temperature is not None:
        raise UsageError(
            "--temperature is the temperature of a capture run: with --from-log give it to "
            "aacmm verify --temperature"
        )
    if args.from_log is not None and not Path(args.from_log).is_file():
        raise UsageError(f"--from-log {args.from_log}: no such file")
    if args.resume:
        from aacmm.records import read_session, session_exists

        if not session_exists(folder):
            raise UsageError(f"{folder}: no session to resume (no session.json)")
        read_session(folder)  # refuse a damaged session before touching the device
        check_writable_dir(folder, str(folder))
    elif folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise UsageError(f"{folder} exists: use --resume to continue it, or another folder")
    elif not folder.resolve().parent.is_dir():
        raise UsageError(f"directory {folder.resolve().parent} does not exist")
    else:  # the folder must be creatable (or take files) before the device is opened
        check_output_dir(folder, what=str(folder))
    if args.from_log is not None:
        return label_log(args, plan)
    return Capture(args, plan).run()


def label_log(args: argparse.Namespace, plan: Plan) -> int:
    """``--from-log``: the presses of a log's trigger file, in order, as the plan's points
    (button 0 presses record, button 1 presses undo, releases are ignored)."""
    from aacmm.client.devstate import no_point_reason
    from aacmm.records import SessionWriter
    from aacmm.records.logs import read_log, read_triggers

    log = read_log(args.from_log)
    if log.format is None:
        raise UsageError(f"{args.from_log}: not an aacmm log (no aacmm sidecar)")
    triggers = read_triggers(log)
    folder = Path(args.output)
    if args.resume:
        w = SessionWriter.resume(folder, plan)
    else:
        w = SessionWriter.create(
            folder,
            plan,
            source="from-log",
            device=log.meta.get("device"),
            port=log.meta.get("port"),
            transport=log.meta.get("transport"),
            joints=log.joints,
        )
    w.begin_run("from-log", log=str(log.path))
    extra = 0
    for t in triggers:
        if not t.pressed:
            continue
        if t.button == BUTTON_UNDO:
            w.undo(t.host_time)
        elif t.button != BUTTON_CAPTURE:
            w.ignored(t.sample, t.host_time, t.button, True, f"button {t.button}")
        elif w.next_slot is None:
            extra += 1
            w.ignored(t.sample, t.host_time, t.button, True, "plan already complete")
        elif not t.sample.status & POINT_VALID:
            w.ignored(t.sample, t.host_time, t.button, True, no_point_reason(t.sample))
        else:
            w.set_param_set(t.param_set)
            w.record(t.sample, t.host_time, t.button)
    status = "complete" if w.next_slot is None else "interrupted"
    w.close(status, f"from log {log.path.name}")
    n = len(plan.slots)
    say(f"labelled {log.path}: {w.accepted} of {n} points -> {folder} ({status})")
    if extra:
        print_err("capture", f"{extra} presses after the plan was complete were ignored")
    if status != "complete":
        print_err("capture", f"the log ends {n - w.accepted} points short; continue with --resume")
    return OK
