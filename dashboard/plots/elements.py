"""HoloViews set-up and the hooks that give the drawn bokeh models stable names.

Importing this module loads HoloViews' bokeh backend once per server process (not per session:
``hv.extension`` costs ~0.2 s of event-loop time, which each session would otherwise pay).
The plots of the dashboard are :class:`holoviews.DynamicMap` objects fed by
:class:`holoviews.streams.Pipe`; their panes (``pn.pane.HoloViews``) update the bokeh models in
place on every ``Pipe.send``.

Browser tests and benchmarks read what is drawn through named data sources
(``Bokeh.documents[0].get_model_by_name('sweep-coverage')``); :func:`name_source` is the hook
that names the source of one element, :func:`css_class` marks a figure for the layout tests.
"""

from __future__ import annotations

import holoviews as hv

__all__ = ["HIDE_ON_CLICK", "css_class", "hv", "name_source"]

if "bokeh" not in hv.Store.renderers:
    hv.extension("bokeh", logo=False)
hv.Store.set_current_backend("bokeh")


def name_source(name: str):
    """A hook naming the element's ``ColumnDataSource`` ``name`` (names must be unique in a document)."""

    def hook(plot, element) -> None:
        source = plot.handles.get("source")
        if source is not None and source.name != name:
            source.name = name

    return hook


def css_class(css: str):
    """A hook adding ``css`` to the figure's CSS classes (found by the layout tests)."""

    def hook(plot, element) -> None:
        fig = plot.state
        if css not in fig.css_classes:
            fig.css_classes = [*fig.css_classes, css]

    return hook


#: HoloViews options of an overlay whose legend entries hide their layer when clicked (the
#: legend's small text is ``fontsize={"legend": ...}``). As the overlay's legend style, which
#: HoloViews applies on every update, rather than a hook run after it: HoloViews reset the legend
#: to its default ``click_policy="mute"`` on every update and the hook set it back, so each
#: update sent the browser four legend changes.
HIDE_ON_CLICK = {"click_policy": "hide"}
