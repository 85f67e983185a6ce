"""A self-contained HTML page of a scene: no server, no network.

The page (``static/index.html``) with plotly.js, the page's script and style
inlined and the scene embedded as JSON, in one file: it opens from disk in
any browser, offline, and shows what ``aacmm view`` shows for the same
source. plotly.js is most of its size (about 4.8 MB, as the ``plotly``
wheel ships it).

:func:`write_report` puts ``view.json`` and ``report.html`` beside a report's
other files (``aacmm verify``, ``aacmm calibrate``); :func:`report_names`
names them.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from aacmm.fileio import write_output
from aacmm.view.server import plotly_js_path, static_path

VIEW_JSON = "view.json"
REPORT_HTML = "report.html"


def _script(text: str) -> str:
    # "</script" would end the element early (in JavaScript strings too).
    return "<script>" + text.replace("</script", "<\\/script") + "</script>"


def _json_script(doc: dict[str, Any]) -> str:
    text = json.dumps(doc, separators=(",", ":"), allow_nan=False)
    # In JSON, "<" only occurs inside strings, where \u003c means the same.
    text = text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
    return f'<script type="application/json" id="aacmm-scene">{text}</script>'


def standalone_html(scene: dict[str, Any]) -> str:
    """The page of ``scene`` as one HTML document (str). Raises ValueError for a
    scene with NaN or infinite numbers (JSON has none)."""
    page = static_path("index.html").read_text(encoding="utf-8")
    parts = {
        '<link rel="stylesheet" href="/assets/view.css">': "<style>"
        + static_path("view.css").read_text(encoding="utf-8")
        + "</style>",
        '<script src="/assets/plotly.js"></script>': _script(
            plotly_js_path().read_text(encoding="utf-8")
        ),
        '<script src="/assets/view.js"></script>': _json_script(scene)
        + "\n"
        + _script(static_path("view.js").read_text(encoding="utf-8")),
    }
    for tag, inline in parts.items():
        if tag not in page:
            raise RuntimeError(f"index.html lacks {tag}")
        head, _, tail = page.partition(tag)
        page = head + inline + tail
    return page


def report_names() -> list[str]:
    """The files :func:`write_report` adds to a report folder."""
    return [VIEW_JSON, REPORT_HTML]


def write_report(folder: Path, scene: dict[str, Any], force: bool) -> None:
    """``view.json`` (what ``aacmm view FOLDER`` shows) and the self-contained
    ``report.html`` beside a report's other files."""
    write_output(folder / VIEW_JSON, json.dumps(scene, allow_nan=False) + "\n", force=force)
    write_output(folder / REPORT_HTML, standalone_html(scene), force=force)
