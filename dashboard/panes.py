"""Panes shared by the views.

:class:`Markdown`
    Panel's Markdown pane, but each text is converted to HTML once per server process: Panel
    renders the Markdown in Python (markdown-it) every time a pane is made or its text
    changes, ~5–15 ms for the guides of the views, and every session makes the same panes on
    the server's event loop.
"""

from __future__ import annotations

import threading
from collections import OrderedDict

import panel as pn

__all__ = ["Markdown"]

_CACHE_SIZE = 256
_cache: OrderedDict = OrderedDict()
_lock = threading.Lock()


class Markdown(pn.pane.Markdown):
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
