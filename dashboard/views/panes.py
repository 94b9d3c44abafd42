"""Panes shared by the views.

:func:`alert_html`
    The HTML of a coloured notice (Bootstrap's alert colours, inline). For a notice whose
    colour follows the results: in the browser a change of a model's ``css_classes`` (what
    :class:`panel.pane.Alert` changes with ``alert_type``) costs 0.2–0.3 s of re-layout per
    change (measured in chromium on the beam view), a change of an HTML pane's text ~1 ms.
:func:`status_html`
    A run's status line with its state in ``data-*`` attributes (read by the browser tests).
:class:`HTML`, :class:`DataFrame`
    Panel's panes, but their stylesheets stay on this server (:class:`LocalStylesheets`).
:class:`Markdown`
    Panel's Markdown pane (stylesheets on this server too), but each text is converted to HTML once per server process: Panel
    renders the Markdown in Python (markdown-it) every time a pane is made or its text
    changes, ~5–15 ms for the guides of the views, and every session makes the same panes on
    the server's event loop.
"""

from __future__ import annotations

import threading
from collections import OrderedDict

import panel as pn

__all__ = ["ALERT_COLOURS", "BUTTON_WRAP", "FLEX_ITEM_GUIDE", "FLEX_ITEM_INPUTS", "FLEX_ITEM_MAIN", "DataFrame",
           "HTML", "Markdown", "alert_html", "status_html"]

#: Layout of the views (CSS, shared with the diagnosis view): a wrapping flex row of a fixed
#: input column, a main column that takes the rest, and the "For the class" panel, which
#: wraps below when the window is too narrow for three columns.
FLEX_ITEM_INPUTS = {"flex": "0 0 300px", "min-width": "0"}
FLEX_ITEM_MAIN = {"flex": "1 1 560px", "min-width": "0"}
FLEX_ITEM_GUIDE = {"flex": "1 1 300px", "min-width": "0", "max-width": "460px"}
#: Lets a button's label wrap instead of spilling over its edges.
BUTTON_WRAP = [":host .bk-btn { white-space: normal; text-align: center; }"]


#: Background, text and border colours of :func:`alert_html` by kind (Bootstrap 5's alerts).
ALERT_COLOURS = {
    "secondary": ("#e2e3e5", "#41464b", "#d3d6d8"),
    "success": ("#d1e7dd", "#0f5132", "#badbcc"),
    "warning": ("#fff3cd", "#664d03", "#ffecb5"),
    "danger": ("#f8d7da", "#842029", "#f5c2c7"),
}


def alert_html(kind: str, html: str) -> str:
    """``html`` in a box coloured as a Bootstrap alert of ``kind`` (a key of :data:`ALERT_COLOURS`);
    ``data-kind`` carries the kind for tests."""
    background, colour, border = ALERT_COLOURS[kind]
    return (f'<div class="notice" data-kind="{kind}" style="background:{background};color:{colour};'
            f'border:1px solid {border};border-radius:6px;padding:8px 12px;">{html}</div>')


def status_html(css: str, stage: str, status: str, requested: int, shown: int, text: str, **data) -> str:
    """The status line, with the state in ``data-*`` attributes (read by the browser tests)."""
    attrs = " ".join(f'data-{k.replace("_", "-")}="{v}"' for k, v in data.items())
    detail = f" <small>({status})</small>" if status else ""
    return (f'<div class="{css}" data-stage="{stage}" data-requested="{requested}" data-shown="{shown}" {attrs}>'
            f"<b>{text}</b>{detail}</div>")


_CACHE_SIZE = 256
_cache: OrderedDict = OrderedDict()
_lock = threading.Lock()


class LocalStylesheets:
    """Mixin for Panel's HTML-type panes: their stylesheets are never rewritten to the CDN.

    Why: when the text of such a pane changes while its bokeh model is not attached to the
    document (a pane in a tab not shown, ``dynamic=True``), Panel 1.9 recomputes the model's
    properties with ``doc=None`` (``HTMLBasePane._update``: ``model.document``), and without a
    document it resolves the pane's stylesheets (``loading.css``, ``markdown.css``,
    ``dataframe.css``, the theme's) to cdn.holoviz.org; the browser requested them from there
    when the tab was opened. Measured: 30 such updates in one session (load, two tabs opened).
    Falling back to the current document, whose ``dist_url`` is this server's, keeps them local.
    """

    def _get_properties(self, doc):
        return super()._get_properties(doc if doc is not None else pn.state.curdoc)


class HTML(LocalStylesheets, pn.pane.HTML):
    """:class:`panel.pane.HTML` with its stylesheets on this server (:class:`LocalStylesheets`)."""


class DataFrame(LocalStylesheets, pn.pane.DataFrame):
    """:class:`panel.pane.DataFrame` with its stylesheets on this server (:class:`LocalStylesheets`)."""


class Markdown(LocalStylesheets, pn.pane.Markdown):
    """:class:`panel.pane.Markdown` with the HTML of each text cached (LRU, process-wide)."""

    def _transform_object(self, obj) -> dict:
        if not isinstance(obj, str):
            return super()._transform_object(obj)
        key = (obj, self.renderer, tuple(map(repr, self.plugins)), self.hard_line_break, self.disable_anchors,
               self.dedent, tuple(self.extensions), repr(sorted(self.renderer_options.items())))
        with _lock:
            hit = _cache.get(key)
            if hit is not None:
                _cache.move_to_end(key)
                return dict(hit)
        out = super()._transform_object(obj)
        with _lock:
            _cache[key] = dict(out)
            while len(_cache) > _CACHE_SIZE:
                _cache.popitem(last=False)
        return out
