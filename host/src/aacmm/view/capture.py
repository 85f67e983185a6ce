"""The live view beside a capture (``aacmm capture --view``): the server and the feed.

:func:`follow_capture` points a running :class:`~aacmm.view.server.ViewServer`
at a :class:`~aacmm.view.live.LiveFeed` that follows a capture session, and
returns the :class:`CaptureView` capture drives: every sample it reads
(:meth:`CaptureView.on_sample`) and every change of the session
(:meth:`CaptureView.changed`). The page reads the session folder, never the
device, so a browser that closes (or several that open) changes nothing for
the capture.

Errors: none of its own; the feed's and the server's (:mod:`aacmm.view.live`,
:mod:`aacmm.view.server`).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from aacmm.view.live import LiveFeed
from aacmm.view.server import ViewServer

__all__ = ["CaptureView", "follow_capture"]


class CaptureView:
    """What ``aacmm capture --view`` adds to a capture: the server and the feed.

    Capture calls :meth:`on_sample` for every sample it reads and
    :meth:`changed` after every point, undo or confirmation; the page reads
    the session folder, never the device, so a browser that closes (or
    several that open) changes nothing for the capture.
    """

    def __init__(self, srv: ViewServer, feed: LiveFeed) -> None:
        self.srv = srv
        self.feed = feed

    def on_sample(self, sample: Any) -> None:
        self.feed.on_sample(sample)

    def changed(self, accepted: int | None = None) -> None:
        """After a point, an undo or a confirmation; ``accepted``: points now held."""
        self.feed.session_changed(accepted)

    def close(self) -> None:
        self.feed.close()
        if self.srv.pages_open:
            time.sleep(0.3)  # let the pages get the session's end before the server goes
        self.srv.close()


def follow_capture(srv: ViewServer, feed: LiveFeed, folder: Path, plan: Any) -> CaptureView:
    """Serve ``feed`` on ``srv``, following the capture of ``plan`` into ``folder``,
    and start the feed."""
    srv.set_scene(feed.state)
    feed.follow_session(folder, plan)
    feed.start()
    return CaptureView(srv, feed)
