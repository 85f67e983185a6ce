"""The view's web server: one page, its assets, the scene, a push channel.

An aiohttp application on its own thread and event loop, so the caller
(``aacmm view``, ``aacmm capture --view``) stays synchronous. Routes, all
``GET`` (anything else is 405):

======================  ==========================================================
``/``                   the page (``static/index.html``)
``/assets/plotly.js``   plotly.js as the installed ``plotly`` package ships it
``/assets/view.js``     the page's script; ``/assets/view.css`` its style
``/scene.json``         the scene (:mod:`aacmm.view.scene`), or the live state
``/ws``                 a WebSocket the server pushes batches of messages on (a JSON
                        array); a page answers each with ``ack`` and anything else
                        it sends is ignored (the page is read-only)
======================  ==========================================================

Nothing is fetched from anywhere else; the responses carry a
Content-Security-Policy that lets the page load from this server only.
Requests whose ``Host`` header names another host are refused (421) unless
remote access was allowed, so a web page elsewhere cannot reach the server
by DNS rebinding; a WebSocket opened by a page of another origin is refused
(403).

Each page gets the newest message of each kind (``frame``, ``capture``), one
batch at a time: the next batch leaves when the page has acknowledged the
last, so a page that cannot keep up skips frames instead of queueing them
(in the server or in its own event loop), and one slow or stalled browser
costs no memory and delays nobody else.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import ipaddress
import json
import socket
import threading
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

from aacmm.errors import AacmmError, InitError

#: Kinds of pushed messages, in the order a page receives a burst of them.
KINDS: tuple[str, ...] = ("capture", "frame")


class ViewError(AacmmError):
    """The view cannot show its source (exit status 2 in the CLI)."""


class BindError(InitError):
    """The server cannot listen on the address asked (busy, not ours; exit status 3)."""


def static_path(name: str) -> Path:
    """A file of the page (``index.html``, ``view.js``, ``view.css``)."""
    return Path(str(resources.files("aacmm.view").joinpath("static", name)))


def plotly_js_path() -> Path:
    """plotly.js as the installed ``plotly`` wheel ships it.

    Raises ViewError if the package (or the file in it) is missing.
    """
    try:
        p = Path(str(resources.files("plotly").joinpath("package_data", "plotly.min.js")))
    except ModuleNotFoundError:
        raise ViewError("the plotly package is not installed (pip install plotly)") from None
    if not p.is_file():
        raise ViewError(f"{p}: plotly.js missing from the plotly package")
    return p


def is_loopback(host: str) -> bool:
    """True if ``host`` is ``localhost`` or a loopback address (127.0.0.0/8, ::1)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def parse_bind(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (``[::1]:8010``, ``127.0.0.1:0``) -> (host, port). Raises ValueError."""
    host, sep, port_s = text.rpartition(":")
    if not sep or not host:
        raise ValueError(f"--bind {text!r}: expected HOST:PORT, e.g. 127.0.0.1:8010")
    host = host.strip("[]")
    try:
        port = int(port_s)
    except ValueError:
        raise ValueError(f"--bind {text!r}: the port must be a number") from None
    if not 0 <= port <= 65535:
        raise ValueError(f"--bind {text!r}: the port must be in 0..65535 (0: any free port)")
    if host != "localhost":
        try:
            ipaddress.ip_address(host)
        except ValueError:
            raise ValueError(f"--bind {text!r}: HOST must be an IP address or localhost") from None
    return host, port


def listen_socket(host: str, port: int) -> socket.socket:
    """A listening TCP socket on (host, port). Raises BindError with the reason."""
    addr = "127.0.0.1" if host == "localhost" else host
    fam = socket.AF_INET6 if ":" in addr else socket.AF_INET
    s = socket.socket(fam, socket.SOCK_STREAM)
    try:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind((addr, port))
        s.listen(64)
    except OSError as exc:
        s.close()
        where = f"[{addr}]:{port}" if ":" in addr else f"{addr}:{port}"
        if exc.errno == errno.EADDRINUSE:
            raise BindError(
                f"cannot listen on {where}: the port is in use (another aacmm view?); "
                "choose another with --bind HOST:PORT (port 0: any free one)"
            ) from None
        raise BindError(f"cannot listen on {where}: {exc.strerror or exc}") from None
    s.setblocking(False)
    return s


CSP = (
    "default-src 'self'; script-src 'self' 'unsafe-eval'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data: blob:; connect-src 'self'; worker-src blob:; "
    "frame-ancestors 'none'; base-uri 'none'; form-action 'none'"
)


class _Client:
    """One open page: the newest message of each kind, waiting to be sent."""

    def __init__(self, sock: Any) -> None:
        self.sock = sock
        self.pending: dict[str, str] = {}
        self.wake = asyncio.Event()
        self.acked = asyncio.Event()  # the page has taken the last batch
        self.acked.set()


class ViewServer:
    """Serves the page and pushes messages to every open page.

    ``scene`` returns the document for ``/scene.json`` (called on the server's
    thread for every request). :meth:`start` binds and starts the thread
    (BindError if it cannot listen); :meth:`push` hands a message to every
    page (any thread); :meth:`close` stops. :attr:`url` is the page's address.
    """

    def __init__(
        self,
        host: str,
        port: int,
        scene: Callable[[], dict[str, Any]],
        allow_remote: bool = False,
    ) -> None:
        if not allow_remote and not is_loopback(host):
            raise ValueError(f"{host} is not a loopback address: remote access needs allowing")
        self.host = host
        self.allow_remote = allow_remote
        self._scene = scene
        self._sock = listen_socket(host, port)
        self.port = int(self._sock.getsockname()[1])
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._clients: set[_Client] = set()
        self._last: dict[str, str] = {}  # the newest message of each kind, for pages to come
        self._ready = threading.Event()
        self._stop: asyncio.Event | None = None
        self._error: BaseException | None = None
        self._plotly = plotly_js_path()
        #: Pages connected so far, and open now (for the operator's status line and tests).
        self.pages_total = 0

    @property
    def url(self) -> str:
        h = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{h}:{self.port}/"

    def set_scene(self, scene: Callable[[], dict[str, Any]]) -> None:
        """What ``/scene.json`` serves from now on."""
        self._scene = scene

    @property
    def pages_open(self) -> int:
        return len(self._clients)

    # ------------------------------------------------------------ thread side

    def _allowed_host(self, value: str | None) -> bool:
        if self.allow_remote:
            return True
        if not value:
            return False
        host = value.rsplit(":", 1)[0] if not value.endswith("]") else value
        return is_loopback(host.strip("[]"))

    def _app(self) -> Any:
        from aiohttp import WSMsgType, web

        @web.middleware
        async def guard(request: web.Request, handler: Any) -> web.StreamResponse:
            if not self._allowed_host(request.headers.get("Host")):
                return web.Response(status=421, text="misdirected request\n")
            resp: web.StreamResponse = await handler(request)
            resp.headers["Content-Security-Policy"] = CSP
            resp.headers["X-Content-Type-Options"] = "nosniff"
            resp.headers["Cache-Control"] = "no-store"
            resp.headers["Referrer-Policy"] = "no-referrer"
            return resp

        def file(path: Path, ctype: str) -> Callable[[web.Request], Any]:
            async def handler(request: web.Request) -> web.StreamResponse:
                return web.FileResponse(path, headers={"Content-Type": ctype})

            return handler

        async def scene(request: web.Request) -> web.Response:
            doc = self._scene()
            return web.Response(text=json.dumps(doc), content_type="application/json")

        async def ws(request: web.Request) -> web.StreamResponse:
            origin = request.headers.get("Origin")
            host = request.headers.get("Host", "")
            if origin is not None and origin != f"http://{host}":
                return web.Response(status=403, text="another origin\n")
            sock = web.WebSocketResponse(heartbeat=10.0, max_msg_size=4096)
            await sock.prepare(request)
            client = _Client(sock)
            client.pending = dict(self._last)  # a new page starts from the newest state
            if client.pending:
                client.wake.set()
            self._clients.add(client)
            self.pages_total += 1

            async def sender() -> None:
                # One batch in flight: the next goes when the page has taken this one,
                # so what waits is coalesced here (newest wins) instead of queueing
                # behind a busy page's event loop.
                while not sock.closed:
                    await client.wake.wait()
                    await client.acked.wait()
                    client.wake.clear()
                    client.acked.clear()
                    msgs, client.pending = client.pending, {}
                    batch = [msgs[k] for k in KINDS if k in msgs]
                    await sock.send_str("[" + ",".join(batch) + "]")

            task = asyncio.ensure_future(sender())
            try:
                async for msg in sock:  # a page says only "ack": it took a batch
                    if msg.type in (WSMsgType.ERROR, WSMsgType.CLOSE):
                        break
                    if msg.type == WSMsgType.TEXT and msg.data == "ack":
                        client.acked.set()
            finally:
                self._clients.discard(client)
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await task
            return sock

        app = web.Application(middlewares=[guard])
        app.router.add_get("/", file(static_path("index.html"), "text/html; charset=utf-8"))
        app.router.add_get("/assets/plotly.js", file(self._plotly, "text/javascript"))
        app.router.add_get("/assets/view.js", file(static_path("view.js"), "text/javascript"))
        app.router.add_get("/assets/view.css", file(static_path("view.css"), "text/css"))
        app.router.add_get("/scene.json", scene)
        app.router.add_get("/ws", ws)
        return app

    async def _main(self) -> None:
        from aiohttp import web

        self._stop = asyncio.Event()
        runner = web.AppRunner(self._app(), access_log=None, handle_signals=False)
        await runner.setup()
        site = web.SockSite(runner, self._sock, shutdown_timeout=0.5)
        await site.start()
        self._ready.set()
        try:
            await self._stop.wait()
        finally:
            for c in list(self._clients):  # pages see a clean close (1001: going away)
                with contextlib.suppress(Exception):
                    await asyncio.wait_for(c.sock.close(code=1001), 1.0)
            await runner.cleanup()
            me = asyncio.current_task()
            rest = [t for t in asyncio.all_tasks() if t is not me]
            for t in rest:
                t.cancel()
            await asyncio.gather(*rest, return_exceptions=True)

    def _run(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._main())
        except BaseException as exc:  # reported by start()/close(), never lost
            self._error = exc
        finally:
            self._ready.set()
            with contextlib.suppress(Exception):
                loop.close()

    def _deliver(self, kind: str, text: str) -> None:
        self._last[kind] = text
        for c in self._clients:
            c.pending[kind] = text
            c.wake.set()

    # ------------------------------------------------------------ caller side

    def start(self) -> ViewServer:
        self._thread = threading.Thread(target=self._run, name="aacmm-view", daemon=True)
        self._thread.start()
        self._ready.wait(10.0)
        if self._error is not None:
            raise ViewError(f"the view server did not start: {self._error}")
        return self

    def push(self, kind: str, message: dict[str, Any] | str) -> None:
        """Send ``message`` (JSON text or data) as the newest of its ``kind`` to every page."""
        loop = self._loop
        if loop is None or loop.is_closed():
            return
        text = message if isinstance(message, str) else json.dumps(message)
        with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
            loop.call_soon_threadsafe(self._deliver, kind, text)

    def close(self) -> None:
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(stop.set)
        if self._thread is not None:
            self._thread.join(5.0)
        with contextlib.suppress(OSError):
            self._sock.close()

    def __enter__(self) -> ViewServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()
