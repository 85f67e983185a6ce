"""``aacmm view [SOURCE]``: the arm in the browser, live or from recorded data.

Without SOURCE: a local web server showing the arm from the device's samples
(links, joints, tip and trail) until Ctrl-C. With SOURCE (a capture session,
an ``aacmm log`` CSV, or a report folder of ``verify --report`` /
``calibrate --report``): the same page for the recorded data; ``--html FILE``
writes it as one self-contained file instead. ``aacmm capture --view`` runs
the live page beside a capture (:func:`start_capture_view`). The library is
:mod:`aacmm.view`; docs/view.md.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aacmm.commands.common import add_connection_options, add_force_option, print_err

if TYPE_CHECKING:
    from aacmm.commands.common import Device
    from aacmm.view.capture import CaptureView
    from aacmm.view.live import LiveFeed
    from aacmm.view.server import ViewServer

CMD = "view"
BIND_DEFAULT = "127.0.0.1:8010"
#: The device stream's rate while a page is fed (the page gets --fps of it).
RATE_DEFAULT = 200
RATE_MAX = 1000
#: The stream ``aacmm capture --view`` listens with (instead of its 20 Hz).
CAPTURE_VIEW_RATE_HZ = 200


def add_bind_options(p: argparse.ArgumentParser) -> None:
    """``--bind`` and ``--allow-remote``: where the page is served (view and capture)."""
    p.add_argument(
        "--bind",
        default=BIND_DEFAULT,
        metavar="HOST:PORT",
        help=f"serve the page on HOST:PORT (default {BIND_DEFAULT}; port 0: any free port)",
    )
    p.add_argument(
        "--allow-remote",
        action="store_true",
        help="allow a HOST other than loopback (anyone who reaches it sees the arm)",
    )


def register(sub: Any) -> None:
    from aacmm.view.options import FPS_DEFAULT, FPS_RANGE, TRAIL_DEFAULT

    p = sub.add_parser(
        "view",
        help="the arm in the browser: live from the device, or a session, log or report",
        description="Serve a page (local, no internet needed) showing the arm live from the "
        "device: links, joints, the probe tip and its trail. With SOURCE, show a capture "
        "session (points, fitted features, verification against the MPEs), an aacmm log "
        "(the tip's path, button presses) or a report folder of 'verify --report' or "
        "'calibrate --report' (with calibration residuals per step). The page is read-only. "
        "Ctrl-C stops.",
    )
    add_connection_options(p)
    p.add_argument(
        "source", nargs="?", metavar="SOURCE", help="session folder, log CSV or report folder"
    )
    add_bind_options(p)
    p.add_argument(
        "--rate",
        type=int,
        default=RATE_DEFAULT,
        metavar="HZ",
        help=f"live: the device's sample rate (default {RATE_DEFAULT}, up to {RATE_MAX})",
    )
    p.add_argument(
        "--fps",
        type=int,
        default=FPS_DEFAULT,
        metavar="N",
        help=f"live: frames a second sent to the page, {FPS_RANGE[0]}-{FPS_RANGE[1]} "
        f"(default {FPS_DEFAULT}; the newest sample each time)",
    )
    p.add_argument(
        "--trail",
        type=int,
        default=TRAIL_DEFAULT,
        metavar="N",
        help=f"live: tip positions in the trail (default {TRAIL_DEFAULT}, 0: none)",
    )
    p.add_argument(
        "--stall",
        type=float,
        default=3.0,
        metavar="S",
        help="live: no sample for S seconds means the link is lost (default 3)",
    )
    p.add_argument(
        "--html",
        metavar="FILE",
        help="with SOURCE: write the page as one self-contained HTML file instead of serving it",
    )
    add_force_option(p)
    p.set_defaults(func=cmd_view)


# ---------------------------------------------------------------- the server


def bind_address(args: argparse.Namespace) -> tuple[str, int]:
    """Check ``--bind``/``--allow-remote`` (UsageError) and warn about a remote bind."""
    from aacmm.commands.exitcodes import UsageError
    from aacmm.view.server import is_loopback, parse_bind

    try:
        host, port = parse_bind(args.bind)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if not is_loopback(host):
        if not args.allow_remote:
            raise UsageError(
                f"--bind {args.bind}: {host} is not a loopback address; add --allow-remote "
                "to serve the page to other machines"
            )
        print_err(
            CMD,
            f"warning: serving on {host}:{port}: anyone who can reach this machine can see "
            "the arm and its data (read-only; no password, no encryption)",
        )
    return host, port


def open_server(args: argparse.Namespace, scene: Any) -> ViewServer:
    """Bind (BindError: busy, exit status 3) and start the server."""
    from aacmm.view.server import ViewServer

    host, port = bind_address(args)
    return ViewServer(host, port, scene, allow_remote=args.allow_remote).start()


def _wait(stop: Any) -> None:
    while not stop.set:
        stop.event.wait(0.5)


# ---------------------------------------------------------------- offline


def load_scene(source: str) -> dict[str, Any]:
    """The scene of a session folder, a log, or a report folder. UsageError if none."""
    from aacmm.commands.exitcodes import UsageError
    from aacmm.fileio import load_json
    from aacmm.records import session_exists
    from aacmm.view import scene as sc
    from aacmm.view.html import VIEW_JSON

    p = Path(source)
    if not p.exists():
        raise UsageError(f"{source}: no such session, log or report folder")
    if p.is_dir():
        if session_exists(p):
            return sc.session_scene(p)
        if (p / VIEW_JSON).is_file():
            doc = load_json(p / VIEW_JSON)
            if not isinstance(doc, dict) or doc.get("format") != sc.FORMAT:
                raise UsageError(f"{p / VIEW_JSON}: not an aacmm view scene ({sc.FORMAT})")
            return doc
        if (p / "report.json").is_file():
            rep = load_json(p / "report.json")
            src = rep.get("source") if isinstance(rep, dict) else None
            if isinstance(src, str) and session_exists(src):
                return sc.session_scene(src)
            raise UsageError(
                f"{source}: a report without {VIEW_JSON}, whose session is not at hand "
                "(made by an older aacmm? run verify/calibrate --report again)"
            )
        raise UsageError(f"{source}: not a session (no session.json) nor a report folder")
    return sc.log_scene(p)


def cmd_view(args: argparse.Namespace) -> int:
    from aacmm.commands.exitcodes import UsageError
    from aacmm.fileio import check_outputs, write_output

    if args.html is not None and args.source is None:
        raise UsageError("--html needs a SOURCE (a session, log or report folder)")
    if args.source is None:
        return live(args)
    if args.html is not None:
        check_outputs([args.html], args.force)
        bind_address(args)
    from aacmm.view.html import standalone_html

    scene = load_scene(args.source)
    if args.html is not None:
        write_output(args.html, standalone_html(scene), force=args.force)
        print(f"wrote {args.html} ({len(scene['points'])} points; opens offline in a browser)")
        return 0
    from aacmm.commands.stopflag import StopFlag

    stop = StopFlag()
    stop.install()
    try:
        srv = open_server(args, lambda: scene)
        try:
            print(srv.url, flush=True)
            print_err(CMD, f"{scene['title']}: {len(scene['points'])} points; Ctrl-C to stop")
            _wait(stop)
        finally:
            srv.close()
    finally:
        stop.restore()
    return 0


# ---------------------------------------------------------------- live


def make_feed(dev: Device, srv: ViewServer, fps: int, trail: int, title: str) -> LiveFeed:
    """A :class:`LiveFeed` for the device's parameter set, pushing to ``srv``."""
    from aacmm.client.devstate import info_dict
    from aacmm.view.live import LiveFeed

    params, encoders = dev.client.get_params().to_core()
    info = {
        "title": title,
        "subtitle": f"{dev.url}, device serial {dev.info.serial_number}",
        "device": info_dict(dev.info),
    }
    return LiveFeed(params, encoders, srv.push, fps=fps, trail=trail, info=info)


def _check_live(args: argparse.Namespace) -> None:
    from aacmm.commands.exitcodes import UsageError
    from aacmm.view.options import FPS_RANGE

    lo, hi = FPS_RANGE
    if not lo <= args.fps <= hi:
        raise UsageError(f"--fps must be in {lo}..{hi}, got {args.fps}")
    if not args.fps <= args.rate <= RATE_MAX:
        raise UsageError(f"--rate must be in --fps ({args.fps})..{RATE_MAX} Hz, got {args.rate}")
    if args.trail < 0 or args.trail > 100000:
        raise UsageError(f"--trail must be in 0..100000, got {args.trail}")
    if not 0 < args.stall <= 3600:
        raise UsageError("--stall must be in (0, 3600] seconds")


#: How often the live loop takes the samples queued since its last turn: waking once
#: per sample at 1 kHz would cost the process more than everything else together.
DRAIN_PERIOD_S = 0.005


def drain(stream: Any, feed: LiveFeed, stop: Any, stall_s: float) -> None:
    """Hand the newest sample of ``stream`` to ``feed`` every :data:`DRAIN_PERIOD_S`
    until ``stop``. Raises LinkLostError when no sample came for ``stall_s`` or the
    link is lost."""
    from aacmm.errors import DeviceTimeoutError, LinkLostError, OperationError

    last = time.monotonic()
    while not stop.set:
        stop.event.wait(DRAIN_PERIOD_S)
        newest = None
        try:
            while True:
                newest = stream.get(timeout=0.0)
        except DeviceTimeoutError:
            pass
        except (StopIteration, OperationError) as exc:
            raise LinkLostError(f"link lost: {exc}") from None
        now = time.monotonic()
        if newest is None:
            if now - last > stall_s:
                raise LinkLostError(f"no sample for {stall_s:g} s")
            continue
        last = now
        feed.on_sample(newest)


def live(args: argparse.Namespace) -> int:
    from aacmm.commands.common import device_from_args
    from aacmm.commands.stopflag import StopFlag

    _check_live(args)
    stop = StopFlag()
    feed: LiveFeed | None = None
    srv = open_server(args, lambda: feed.state() if feed is not None else {"kind": "starting"})
    try:
        dev = device_from_args(args)
        try:
            feed = make_feed(dev, srv, args.fps, args.trail, "live view")
            feed.start()
            stop.install()
            print(srv.url, flush=True)
            print_err(CMD, f"live from {dev.url} at {args.rate} Hz; Ctrl-C to stop")
            from aacmm.client.devstate import stream_temperatures

            # the view draws the device's points: the readings ride along where they
            # cost the link nothing it needs (not over CAN)
            temps = stream_temperatures(dev.client.transport, dev.info, thermal=False)
            stream = dev.client.stream(args.rate, timeout=args.stall, temperatures=temps)
            try:
                drain(stream, feed, stop, args.stall)
            finally:
                try:
                    stream.stop()
                except Exception:  # the link may be gone: nothing left to stop
                    pass
        finally:
            if feed is not None:
                feed.close()
            dev.close()
    finally:
        stop.restore()
        srv.close()
    return 0


def open_capture_server(args: argparse.Namespace) -> ViewServer:
    """Before capture opens the device: bind (a busy port fails here, nothing touched)."""
    return open_server(args, lambda: {"kind": "starting"})


def start_capture_view(srv: ViewServer, dev: Device, folder: Path, plan: Any) -> CaptureView:
    """Feed ``srv`` from the capture of ``plan`` into ``folder`` on ``dev``
    (:func:`aacmm.view.capture.follow_capture`) and print the page's address."""
    from aacmm.view.capture import follow_capture

    view = follow_capture(srv, make_feed(dev, srv, 40, 400, f"capture: {plan.title}"), folder, plan)
    print(f"view: {srv.url}", flush=True)
    return view
