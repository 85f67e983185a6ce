"""Shared pieces of the commands: the connection options, opening a device
(connect with the port held exclusively, handshake), output files, the live status line and small
helpers.

Output files: every file a command writes goes through :func:`atomic_output`,
:func:`write_output`, :func:`save_figure` or :func:`atomic_path` (from
:mod:`aacmm.fileio`):
refused if it exists unless ``--force`` (:func:`add_force_option`), written
to a temporary file in the same directory, fsynced and renamed. Call
:func:`check_outputs` with all of a command's outputs before its work starts,
so a refusal comes at once, not after a long computation.

Arm models (issue 26): :func:`add_model_option` (``--model NAME|FILE``),
:func:`model_arm` (the model it names, default the paper's ``gao2013``) and
:func:`check_log_arm` (refuse a log or session of another arm shape than the
model's: :class:`WrongArmError`, exit status 10).

Heavy modules (the client, python-can, pyserial) are imported inside the
functions so that ``aacmm --help`` and the analysis commands start fast.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass, field
from typing import IO, TYPE_CHECKING, Any

from aacmm.commands.exitcodes import UsageError

if TYPE_CHECKING:
    from aacmm.arm import Arm
    from aacmm.client import Client
    from aacmm.models import ArmModel
    from aacmm.protocol import DeviceInfo
    from aacmm.records.paramsets import ParamSetRecord

ENV_PORT = "AACMM_PORT"
DEFAULT_TIMEOUT = 1.0
DEFAULT_RETRIES = 2


def add_connection_options(parser: argparse.ArgumentParser) -> None:
    """``--port``, ``--timeout`` and ``--retries``: the same on every device command."""
    g = parser.add_argument_group("connection")
    g.add_argument(
        "-p",
        "--port",
        metavar="URL",
        default=None,
        help="device URL: serial:///dev/ttyUSB0, /dev/pts/3, socketcan://can0?node=1, "
        f"socket://host:port ... (default: ${ENV_PORT})",
    )
    g.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT,
        metavar="S",
        help=f"seconds to wait for each answer, up to 3600 (default {DEFAULT_TIMEOUT})",
    )
    g.add_argument(
        "--retries",
        type=int,
        default=DEFAULT_RETRIES,
        metavar="N",
        help=f"extra attempts for read-only requests after a timeout (default {DEFAULT_RETRIES})",
    )


def add_force_option(parser: argparse.ArgumentParser) -> None:
    """``-f``/``--force``: the one switch that lets a command replace its output files."""
    parser.add_argument(
        "-f", "--force", action="store_true", help="replace output files that already exist"
    )


def port_url(args: argparse.Namespace) -> str:
    """The device URL from ``--port``, the environment, or else the running simulator's.

    Without ``--port`` and ``$AACMM_PORT``, the URL an ``aacmm sim`` of this
    user publishes (:func:`aacmm.simulation.process.published_url`; waited for while
    one is starting) is used, and said on stderr.

    Raises:
        UsageError: none of them, or the URL is malformed.
    """
    url = (args.port or os.environ.get(ENV_PORT, "")).strip()
    if not url:
        # A running (or starting) `aacmm sim` publishes its URL (docs/cli.md, aacmm sim).
        from aacmm.simulation.process import published_sims, published_url

        url = published_url() or ""
        if not url:
            raise UsageError(
                f"no device given: use --port URL, set {ENV_PORT}, or start a simulator "
                "(aacmm sim &)"
            )
        n = len(published_sims())
        more = f" (the newest of {n} running; --port for another)" if n > 1 else ""
        cmd = getattr(args, "command", None) or "aacmm"
        print(f"aacmm {cmd}: using the simulator at {url}{more}", file=sys.stderr, flush=True)
    from aacmm.transport import parse_url

    try:
        parse_url(url)
    except ValueError as exc:
        raise UsageError(f"bad device URL {url!r}: {exc}") from None
    return url


def url_kind(url: str) -> tuple[str, str, int]:
    """``(kind, target, node)`` of a valid device URL (kind: serial, socketcan, virtual)."""
    from aacmm.transport import parse_url

    u = parse_url(url)
    return u.kind, u.target, u.node


@dataclass
class Device:
    """An open, checked connection: the URL, the client and the device info.

    A serial port is held exclusively by the client's transport for as long
    as the connection is open (:class:`aacmm.transport.SerialTransport`).
    """

    url: str
    client: Client
    info: DeviceInfo
    _closed: bool = field(default=False, repr=False)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self.client.close()

    def __enter__(self) -> Device:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_device(url: str, timeout: float, retries: int) -> Device:
    """Connect (a serial port exclusively) and check the protocol version.

    Raises:
        PortBusyError, InitError, VersionMismatchError, DeviceTimeoutError,
        DeviceError, UsageError (bad timeout or retries).
    """
    from aacmm.client import check_timeout, connect

    try:
        timeout = check_timeout(timeout, "--timeout")
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if retries < 0:
        raise UsageError(f"--retries must be >= 0, got {retries}")
    client = connect(url, timeout=timeout, retries=retries)
    try:
        info = client.handshake()
    except BaseException:
        client.close()
        raise
    return Device(url, client, info)


def device_from_args(args: argparse.Namespace) -> Device:
    """:func:`open_device` with the connection options of a command."""
    return open_device(port_url(args), args.timeout, args.retries)


# ---------------------------------------------------------------- output helpers


def flag_names(status: int) -> str:
    """Sample status bits as names (``POINT_VALID|PARAMS_DEFAULT``)."""
    from aacmm.protocol import SampleStatus

    names = [f.name for f in SampleStatus if f.name and status & f.value]
    unknown = status & ~sum(f.value for f in SampleStatus)
    if unknown:
        names.append(f"0x{unknown:x}")
    return "|".join(names) if names else "0"


def is_tty(stream: IO[str]) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


class StatusLine:
    """A live one-line status on stderr (tqdm), only when stderr is a terminal.

    Shows the samples (and the target count), the elapsed time, the current
    rate and the caller's text (lost samples, ...). It is removed when closed
    (``leave=False``), so only the final summary stays on the screen. Off a
    terminal it does nothing.
    """

    def __init__(self, total: int | None = None, enabled: bool = True) -> None:
        self.enabled = enabled and is_tty(sys.stderr)
        self._bar: Any = None
        self._last = time.monotonic()
        self._last_n = 0
        self._n = 0
        if self.enabled:
            from tqdm import tqdm

            try:
                size = os.get_terminal_size(sys.stderr.fileno())
                sized = size.columns > 0 and size.lines > 0
            except (OSError, ValueError):
                sized = False
            fmt = (
                "{n_fmt} samples | {elapsed}{postfix}"
                if total is None
                else "{n_fmt}/{total_fmt} samples {bar:20} {elapsed}<{remaining}{postfix}"
            )
            self._bar = tqdm(
                total=total,
                file=sys.stderr,
                leave=False,
                # a terminal that reports no size (a fresh pty) counts as 80x24;
                # tqdm would print nothing on it
                dynamic_ncols=sized,
                ncols=None if sized else 80,
                nrows=None if sized else 24,
                mininterval=0.25,
                bar_format=fmt,
            )

    def update(self, n: int, text: str = "") -> None:
        """Add ``n`` samples; refresh the rate and text at most 4 times a second."""
        if self._bar is None:
            return
        self._n += n
        now = time.monotonic()
        dt = now - self._last
        if dt >= 0.25:
            rate = (self._n - self._last_n) / dt
            self._last, self._last_n = now, self._n
            self._bar.set_postfix_str(
                f"{rate:.0f} Hz, {text}" if text else f"{rate:.0f} Hz", refresh=False
            )
        self._bar.update(n)

    def note(self, text: str) -> None:
        """Show ``text`` now (e.g. "reconnecting")."""
        if self._bar is not None:
            self._bar.set_postfix_str(text, refresh=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def link_temperature(text: str | None, option: str = "--temperature") -> float | None:
    """The links' temperature an operator states (degC), or None when not given.

    Raises:
        UsageError: not a number, NaN, or outside the core's -40 .. 85 degC.
    """
    from aacmm.commands.exitcodes import UsageError
    from aacmm.errmodel import TEMP_MAX_C, TEMP_MIN_C

    if text is None:
        return None
    try:
        temp = float(text)
    except ValueError:
        temp = math.nan
    if not (math.isfinite(temp) and TEMP_MIN_C <= temp <= TEMP_MAX_C):
        raise UsageError(
            f"{option} {text}: the links' temperature must be a number within "
            f"{TEMP_MIN_C:g} .. {TEMP_MAX_C:g} degC"
        )
    return temp


def link_temperatures(
    text: str | None, joints: int, option: str = "--temperature"
) -> list[float] | None:
    """``C[,C...]``: one link temperature (degC) for every link or one per link of
    ``joints``; None when not given.

    Raises:
        UsageError: not numbers within -40 .. 85 degC, or neither 1 nor ``joints`` values.
    """
    from aacmm.commands.exitcodes import UsageError

    if text is None:
        return None
    parts = [p.strip() for p in text.split(",")]
    values = [link_temperature(p, option) for p in parts]
    if len(values) == 1:
        values = values * joints
    if len(values) != joints:
        raise UsageError(
            f"{option} {text}: give one temperature for every link or {joints} (one per "
            f"link), got {len(parts)}"
        )
    return [float(v) for v in values if v is not None]


def print_err(cmd: str, text: str) -> None:
    print(f"aacmm {cmd}: {text}", file=sys.stderr, flush=True)


def device_param_set(cmd: str, dev: Device) -> ParamSetRecord:
    """The device's parameter set in force, with a warning on stderr when the CRC
    the device reports (its info) is not the CRC of the set it sends."""
    from aacmm.records.paramsets import ParamSetRecord

    ps = ParamSetRecord.from_device(dev.client.get_params())
    if ps.crc32 != dev.info.param_crc32:
        print_err(
            cmd,
            f"warning: the device reports parameter CRC 0x{dev.info.param_crc32:08x}, "
            f"its parameter set hashes to {ps.crc_hex}",
        )
    return ps


def add_run_limit_options(parser: argparse.ArgumentParser, bar: str) -> None:
    """``--max-hours`` and ``--progress``/``--no-progress`` of a long analysis run.

    ``bar``: what the progress bar counts, for the help text.
    """
    from aacmm.uncertainty.runlimits import MAX_RUN_S

    parser.add_argument(
        "--max-hours",
        type=float,
        default=MAX_RUN_S / 3600,
        metavar="H",
        help=f"refuse a run estimated longer than H hours (default {MAX_RUN_S / 3600:g})",
    )
    parser.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help=f"progress of {bar} on stderr (default: for long runs; a bar at a terminal)",
    )


def max_run_seconds(args: argparse.Namespace) -> float:
    """``--max-hours`` in seconds.

    Raises:
        UsageError: not a positive number.
    """
    h = float(args.max_hours)
    if not (h > 0 and h < 1e6):
        raise UsageError(f"--max-hours must be a positive number of hours, got {args.max_hours}")
    return h * 3600.0


class RunProgress:
    """A long analysis run seen from stderr: its estimate first, then its progress.

    :meth:`update` goes to the run's progress callback. Once the first half
    second is measured (:class:`aacmm.uncertainty.runlimits.RunClock`), a run
    estimated beyond the limit is refused (:class:`RunLimitError`, exit
    status 2); one estimated at :data:`LONG_RUN_S` or more is announced with
    its estimate (``aacmm mc: estimated time about 3 h 10 min (...); Ctrl-C
    stops it``), then shown as a bar at a terminal, or off a terminal as a
    line every 5 % (at least 10 s apart). ``show``: ``--progress`` (True: a
    bar from the start, False: no progress, only the estimate).
    """

    def __init__(
        self,
        cmd: str,
        total: float,
        unit: str,
        *,
        show: bool | None,
        limit_s: float,
        what: str,
        hint: str,
    ) -> None:
        from aacmm.uncertainty.runlimits import RunClock

        self.cmd = cmd
        self.show = show
        self.clock = RunClock(total, unit, limit_s, what, hint)
        self._bar: Any = None
        self._lines = False
        self._last_line = 0.0
        self._last_pct = 0
        if show:
            self._open_bar()

    def _open_bar(self) -> None:
        from tqdm import tqdm

        c = self.clock
        self._bar = tqdm(
            total=c.total, desc=self.cmd, unit=c.unit.rstrip("s") or c.unit, unit_scale=True,
            file=sys.stderr, leave=False, initial=c.done,
        )  # fmt: skip

    def preset(self, seconds: float) -> None:
        """The whole run's time, estimated another way (a pilot run): refused
        beyond the limit, announced when long.

        Raises:
            RunLimitError: beyond the limit.
        """
        self._announce(self.clock.preset(seconds))

    def _announce(self, est: Any) -> None:
        from aacmm.uncertainty.runlimits import LONG_RUN_S

        if est is None or est.seconds < LONG_RUN_S:
            return
        print_err(self.cmd, f"estimated time {est.describe()}; Ctrl-C stops it")
        if self.show is None:
            if is_tty(sys.stderr):
                self._open_bar()
            else:
                self._lines = True
                self._last_line = time.monotonic()

    def update(self, n: float) -> None:
        """``n`` more units done.

        Raises:
            RunLimitError: the run, as measured so far, would exceed the limit.
        """
        self._announce(self.clock.update(n))
        if self._bar is not None:
            self._bar.update(n)
        elif self._lines:
            self._line()

    def _line(self) -> None:
        from aacmm.uncertainty.runlimits import format_count, format_duration

        c = self.clock
        pct = int(100 * c.done / c.total)
        now = time.monotonic()
        if pct < self._last_pct + 5 or now - self._last_line < 10.0 or c.done >= c.total:
            return
        est = c.current()
        left = f", {format_duration(est.remaining_s)} left" if est is not None else ""
        print_err(
            self.cmd, f"{pct}% ({format_count(c.done)} of {format_count(c.total)} {c.unit}){left}"
        )
        self._last_pct, self._last_line = pct, now

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


# ---------------------------------------------------------------- arm models (issue 26)


def add_model_option(parser: argparse.ArgumentParser, what: str = "the arm analysed") -> None:
    """``--model NAME|FILE``: the arm model of an analysis command (default: the paper's).

    ``what`` says in the help what the model is (the default: the arm analysed).
    """
    parser.add_argument(
        "--model",
        metavar="NAME|FILE",
        default=None,
        help=f"{what}: a shipped arm model (aacmm model list) or a model file "
        "(default gao2013, the paper's arm)",
    )


def model_arm(args: argparse.Namespace) -> ArmModel:
    """The arm model ``--model`` names (:func:`add_model_option`), or the default one.

    Raises:
        ModelError: no such shipped model or file, or an invalid model (exit status 2).
    """
    from aacmm.models import DEFAULT_MODEL, load_model

    return load_model(args.model if args.model is not None else DEFAULT_MODEL)


def model_given(args: argparse.Namespace) -> bool:
    """True if the user gave ``--model`` (not the default)."""
    return getattr(args, "model", None) is not None


def arm_shape(arm: Arm) -> tuple[int, str, tuple[int, ...], tuple[str, ...]]:
    """What makes two arms the same model up to their values: joints, tip kind,
    declared betas, conventions."""
    return (arm.n_joints, arm.tip, arm.beta_joints, tuple(j.convention for j in arm.joints))


def check_log_arm(what: str, log_arm: Arm, model: ArmModel) -> None:
    """Refuse data (a log, a session) taken with an arm of another shape than ``model``.

    ``what`` names the data for the message (its path); ``log_arm`` is the arm
    its sidecar gives (values may differ from the model's: a calibrated arm).

    Raises:
        WrongArmError: another joint count, tip kind, betas or conventions
            (exit status 10).
    """
    from aacmm.commands.exitcodes import WrongArmError

    if arm_shape(log_arm) == arm_shape(model.arm):
        return
    raise WrongArmError(
        f"{what} was taken with an arm of {log_arm.n_joints} joints and {log_arm.n_params} "
        f"parameters, not of model {model.name} ({model.n_joints} joints, {model.n_params} "
        "parameters): give the log's model with --model"
    )
