"""Corner (pair) plot of posterior draws: marginals on the diagonal, pairs below, truth marked.

Built directly with bokeh rather than as sixteen HoloViews DynamicMaps: an update is a handful
of ``ColumnDataSource.data`` assignments (about a millisecond) instead of ~0.35 s of element
construction on the server's event loop, which matters because results stream in. Ranges are
explicit ``Range1d`` shared by parameter (set by :meth:`CornerPlot.update` from the draws of both
results and the truth), so a column's marginal and the scatters below it, and the row of the
same parameter, zoom together; an empty plot keeps a valid range.
"""

from __future__ import annotations

import numpy as np
from bokeh.models import ColumnDataSource, NoOverlap, Range1d, Span
from bokeh.plotting import figure

from dashboard.outputs.toy import PAIR_PARAMETERS, PARAMETER_LABELS
from dashboard.plots.fonts import TICKS_PX, style_figure

__all__ = ["CornerPlot"]

CURRENT, PINNED, TRUTH = "#1f77b4", "#9467bd", "#2ca02c"
N_BINS = 30


def _draws(result, name: str) -> np.ndarray:
    if result is None or name not in result.draws:
        return np.array([])
    return np.asarray(result.draws[name], dtype=float)


def _hist(values: np.ndarray) -> dict:
    if values.size == 0:
        return {"left": [], "right": [], "top": []}
    top, edges = np.histogram(values, bins=N_BINS, density=True)
    return {"left": edges[:-1], "right": edges[1:], "top": top}


#: Room of the outer panels' axes (tick labels and axis label), px.
AXIS_PX = 80
#: Width of the panels together (px) by default: the whole pair plot fits the main column at
#: 1280 × 800 beside the class panel (~590 px); its last column (the noise σ) was cut there.
FIT_PX = 510


class CornerPlot:
    """Bokeh figures for ``names`` in a lower-triangular grid; :meth:`update` shows new results.

    Parameters
    ----------
    names : sequence of str
        Parameters (keys of ``ToyResult.draws``), default :data:`PAIR_PARAMETERS`.
    size : int, optional
        Width and height of one panel in pixels (the left column and the bottom row are wider /
        taller by :data:`AXIS_PX` for their axes). Default: the panels share :data:`FIT_PX`,
        90 to 170 px each.
    labels : dict, optional
        Axis label (with unit) of each name, default :data:`PARAMETER_LABELS` (the toy's).

    Notes
    -----
    ``update`` reads ``result.draws`` (a dict of arrays) and ``result.truth`` (a dict, may be
    empty) of its arguments.
    """

    def __init__(self, names=PAIR_PARAMETERS, size: int | None = None, labels: dict | None = None) -> None:
        self.names = tuple(names)
        size = size or max(90, min(170, FIT_PX // max(len(self.names), 1)))
        #: Width and height of one panel (px).
        self.size = size
        labels = PARAMETER_LABELS if labels is None else labels
        n = len(self.names)
        self.ranges = ranges = {name: Range1d(0.0, 1.0) for name in self.names}
        self.hist_ranges: dict[str, Range1d] = {}
        self.sources: dict[tuple, ColumnDataSource] = {}
        self.spans: dict[str, Span] = {}
        rows = []
        for i, yname in enumerate(self.names):
            row = []
            for j, xname in enumerate(self.names):
                if j > i:
                    row.append(None)
                    continue
                # tick labels and axis labels on the outer edges only (left column, bottom row), whose
                # figures are wider / taller by the axis's room: every panel's frame is the same
                # size - 8 px (with 14 px ticks in every panel, the first column's frames were 92 px
                # wide and its marginal's title was cut)
                left, bottom = j == 0, i == n - 1
                fig = figure(width=size + (AXIS_PX if left else 0), height=size + (AXIS_PX if bottom else 0),
                             x_range=ranges[xname], toolbar_location=None, tools="pan,wheel_zoom,reset", min_border=4,
                             min_border_left=AXIS_PX if left else 4, min_border_bottom=AXIS_PX if bottom else 4)
                fig.xaxis.visible = bottom
                fig.xaxis.axis_label = labels[xname] if bottom else None
                fig.xaxis.ticker.desired_num_ticks = 3
                # tilted, so that long tick labels (0.2925, 0.2930, ...) do not run into each other
                fig.xaxis.major_label_orientation = 0.7
                fig.yaxis.ticker.desired_num_ticks = 3
                if i == j:
                    fig.y_range = self.hist_ranges[xname] = Range1d(0.0, 1.0)
                    fig.yaxis.visible = False
                    fig.title.text = labels[xname]
                    for key, color, alpha in (("pinned", PINNED, 0.35), ("current", CURRENT, 0.6)):
                        src = ColumnDataSource(_hist(np.array([])), name=f"corner-{xname}-{key}")
                        fig.quad(left="left", right="right", top="top", bottom=0, source=src, color=color,
                                 alpha=alpha, line_alpha=0)
                        self.sources[(xname, key)] = src
                    span = Span(dimension="height", line_color=TRUTH, line_width=2, location=0.0, visible=False)
                    fig.add_layout(span)
                    self.spans[xname] = span
                else:
                    fig.y_range = ranges[yname]
                    fig.yaxis.visible = left
                    fig.yaxis.axis_label = labels[yname] if left else None
                    for key, color, alpha in (("pinned", PINNED, 0.25), ("current", CURRENT, 0.25)):
                        src = ColumnDataSource({"x": [], "y": []})
                        fig.scatter("x", "y", source=src, color=color, alpha=alpha, size=2)
                        self.sources[(xname, yname, key)] = src
                    src = ColumnDataSource({"x": [], "y": []})
                    fig.scatter("x", "y", source=src, marker="x", color=TRUTH, size=12, line_width=3)
                    self.sources[(xname, yname, "truth")] = src
                style_figure(fig)
                # the names over the marginals and along the axes at 14 px, and tick labels that
                # would run into one another left out (scientific ticks of a 100 px panel did)
                fig.title.text_font_size = f"{TICKS_PX}px"
                for axis in (*fig.xaxis, *fig.yaxis):
                    axis.axis_label_text_font_size = f"{TICKS_PX}px"
                    axis.major_label_policy = NoOverlap(min_distance=4)
                row.append(fig)
            rows.append(row)
        #: Rows of figures (None above the diagonal). Lay them out with separate panes
        #: (:meth:`dashboard.views.toy.ToyView`): a bokeh ``GridPlot`` nested in Panel rows and
        #: columns beside another plot stops the document from ever becoming idle (Panel 1.9 /
        #: Bokeh 3.9), and then ``pn.state.onload`` and HoloViews updates never happen.
        self.grid = rows

    def update(self, result=None, pinned=None) -> None:
        """Show the draws of ``result`` (blue), ``pinned`` (purple) and the truth (green)."""
        truth = {} if result is None else result.truth
        for name in self.names:
            cur, pin = _draws(result, name), _draws(pinned, name)
            hist_cur, hist_pin = _hist(cur), _hist(pin)
            self.sources[(name, "current")].data = hist_cur
            self.sources[(name, "pinned")].data = hist_pin
            values = np.concatenate([cur, pin, [truth[name]] if name in truth else []])
            if values.size:
                lo, hi = float(values.min()), float(values.max())
                pad = 0.05 * (hi - lo) if hi > lo else max(abs(lo) * 0.05, 1e-6)
                self.ranges[name].update(start=lo - pad, end=hi + pad)
                top = max([float(np.max(h["top"])) for h in (hist_cur, hist_pin) if len(h["top"])] or [1.0])
                self.hist_ranges[name].update(start=0.0, end=1.05 * top)
            span = self.spans[name]
            if name in truth:
                span.location, span.visible = float(truth[name]), True
            else:
                span.visible = False
        for (key, src) in self.sources.items():
            if len(key) != 3:
                continue
            x, y, which = key
            if which == "truth":
                src.data = {"x": [truth[x]], "y": [truth[y]]} if x in truth and y in truth else {"x": [], "y": []}
            else:
                res = result if which == "current" else pinned
                src.data = {"x": _draws(res, x), "y": _draws(res, y)}
