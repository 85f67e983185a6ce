"""A real headless browser for the view's tests: Debian's Chromium driven by Playwright.

Playwright's Python package drives the system browser (``/usr/bin/chromium``,
``executable_path``); no browser is downloaded. Chromium runs headless with the
flags that work on this machine (no sandbox as root, no GPU: WebGL runs on
SwiftShader; no background networking, component updates or sync, so the
browser itself makes no request) and a fresh profile (Playwright gives every
launch a new temporary ``--user-data-dir``).

:class:`Watched` records what a page did that a test must check: console
errors, uncaught exceptions, and every request outside the allowed origin.
"""

from __future__ import annotations

import io
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

CHROMIUM = Path(os.environ.get("AACMM_CHROMIUM", "/usr/bin/chromium"))
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
VIEWPORT = {"width": 1280, "height": 760}
REPO = Path(__file__).resolve().parents[2]


def figures_dir(tmp: Path) -> Path:
    """Where screenshots go: ``$AACMM_VIEW_FIGURES`` (``make view-figures``: docs/figures)
    or the test's temporary folder."""
    d = os.environ.get("AACMM_VIEW_FIGURES")
    out = Path(d) if d else tmp
    out.mkdir(parents=True, exist_ok=True)
    return out


@contextmanager
def playwright() -> Iterator[Any]:
    from playwright.sync_api import sync_playwright

    if not CHROMIUM.is_file():
        raise AssertionError(f"{CHROMIUM} missing: scripts/setup.sh installs Debian's chromium")
    with sync_playwright() as p:
        yield p


def launch(p: Any) -> Any:
    return p.chromium.launch(executable_path=str(CHROMIUM), args=FLAGS)


class Watched:
    """A page with its console errors, page errors and outside requests recorded."""

    def __init__(self, browser: Any, allowed: str, offline: bool = False) -> None:
        self.context = browser.new_context(viewport=VIEWPORT, offline=offline)
        self.page = self.context.new_page()
        self.allowed = allowed
        self.console_errors: list[str] = []
        self.outside: list[str] = []
        self.requests: list[str] = []
        self.page.on("console", self._console)
        self.page.on("pageerror", lambda e: self.console_errors.append(f"page error: {e}"))
        self.page.on("request", self._request)

    def _console(self, msg: Any) -> None:
        if msg.type == "error":
            self.console_errors.append(msg.text)

    def _request(self, req: Any) -> None:
        self.requests.append(req.url)
        if not (req.url.startswith(self.allowed) or req.url.startswith(("data:", "blob:"))):
            self.outside.append(req.url)

    def open(self, url: str, timeout_s: float = 90.0) -> Watched:
        self.page.goto(url, timeout=timeout_s * 1000)
        self.page.wait_for_function(
            "window.aacmmView && window.aacmmView.state.ready", timeout=timeout_s * 1000
        )
        return self

    def state(self, expr: str = "s") -> Any:
        """Evaluate ``expr`` with ``s`` the page's state (window.aacmmView.state)."""
        return self.page.evaluate(
            f"(() => {{ const s = window.aacmmView.state; return {expr}; }})()"
        )

    def clean(self) -> None:
        """No console error, no uncaught exception, no request outside the allowed origin."""
        assert self.console_errors == [], self.console_errors
        assert self.outside == [], self.outside
        assert self.state("s.errors") == []

    def screenshot(self, path: Path) -> np.ndarray:
        """Save a PNG of the page and return it as an array; fails if it is blank."""
        png = self.page.screenshot(path=str(path))
        return not_blank(png)


def not_blank(png: bytes) -> np.ndarray:
    """The image (h, w, channels) of a PNG, asserting it shows something: the grey
    levels vary (pixel variance) and more than 2 % of the pixels are not background."""
    import matplotlib.image as mpimg

    img = mpimg.imread(io.BytesIO(png), format="png")
    grey = img[..., :3].mean(axis=2)
    assert float(grey.var()) > 1e-3, f"blank screenshot (grey variance {grey.var():.2e})"
    background = np.median(grey)
    assert float(np.mean(np.abs(grey - background) > 0.05)) > 0.02, "almost nothing drawn"
    return img
