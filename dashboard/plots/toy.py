"""Window-sweep plots of the toy view: held-out coverage and RMSE against the calibration window.

HoloViews: a :class:`holoviews.DynamicMap` per quantity, fed by a :class:`holoviews.streams.Pipe`
(the sweep arrives once per scenario and the marker moves once per final result, so the few
milliseconds of a ``Pipe.send`` do not matter). Shown with ``pn.pane.HoloViews``.

Data sources are named ``sweep-coverage`` and ``sweep-rmse`` (columns ``window_s``, ``value``).
"""

from __future__ import annotations

import math

from dashboard.plots.elements import hv, name_source
from dashboard.plots.fonts import HV_FONTSIZE
from dashboard.plots.timeseries import COLORS

__all__ = ["QUANTITIES", "SweepPlot"]

#: quantity -> (row key, axis label with unit, title, scale to the plotted unit)
#: Titles are short: drawn on the canvas, a long one was cut at 1024 and 1280 px ("Coverage of
#: the 95 % predicti"); the axes say the rest.
QUANTITIES = {
    "coverage": ("coverage95_prediction", "Held-out coverage (%)", "95 % band coverage", 100.0),
    "rmse": ("rmse_prediction", "Held-out RMSE (du)", "Held-out RMSE", 1.0),
}


class SweepPlot:
    """Coverage (%) or RMSE (du) of the Laplace preview against the calibration window.

    Parameters
    ----------
    quantity : {"coverage", "rmse"}
        What to plot.
    height : int
        Figure height in pixels (the width follows the container).

    Attributes
    ----------
    pipe : holoviews.streams.Pipe
        Its data is the dict ``{"window_s": [...], "value": [...], "marker_s": float | None}``.
    figure : holoviews.DynamicMap
        What a ``pn.pane.HoloViews`` shows.
    """

    def __init__(self, quantity: str, height: int = 280) -> None:
        if quantity not in QUANTITIES:
            raise ValueError(f"unknown sweep quantity {quantity!r}; expected one of {', '.join(QUANTITIES)}")
        self.quantity = quantity
        self._key, self._label, self._title, self._scale = QUANTITIES[quantity]
        self._height = height
        self.pipe = hv.streams.Pipe(data={"window_s": [], "value": [], "marker_s": None})
        self.figure = hv.DynamicMap(self._element, streams=[self.pipe])

    @property
    def data(self) -> dict:
        """What is drawn: windows (s), values (% or du) and the marked window (s, or None)."""
        return self.pipe.data

    def _element(self, data: dict):
        windows, values, marker = list(data["window_s"]), list(data["value"]), data["marker_s"]
        everything = windows + ([marker] if marker is not None else [])
        # explicit ranges: over an empty sweep (cleared while a new scenario's is computed) a
        # data range logs "could not set initial ranges" in the browser
        xlim = (min([0.0, *everything]), max(everything) + 1.0) if everything else (0.0, 16.0)
        if self.quantity == "coverage":
            ylim = (min([0.0, *values]), 102.0)
        else:
            ylim = (0.0, (1.1 * max(values) or 1.0) if values else 1.0)
        frame = {"window_s": windows, "value": values}
        kdims, vdims = [hv.Dimension("window_s", label="Calibration window (s)")], [hv.Dimension("value", label=self._label)]
        curve = hv.Curve(frame, kdims, vdims).opts(color=COLORS["mean"], line_width=2,
                                                   hooks=[name_source(f"sweep-{self.quantity}")],
                                                   xlim=xlim, ylim=ylim, framewise=True)
        dots = hv.Scatter(frame, kdims, vdims).opts(color=COLORS["mean"], size=6)
        # the window of the latest final result (dashed; transparent when there is none)
        mark = hv.VLine(marker if marker is not None else math.nan).opts(
            color=COLORS["calibration"], line_dash="dashed", line_alpha=1.0 if marker is not None else 0.0)
        layers = [curve, dots, mark]
        if self.quantity == "coverage":  # the nominal level
            layers.append(hv.HLine(95.0).opts(color=COLORS["truth"], line_dash="dotted"))
        return hv.Overlay(layers).opts(
            title=self._title, height=self._height, responsive=True, toolbar=None, default_tools=[], show_legend=False,
            fontsize=HV_FONTSIZE)

    def update(self, rows=None, window_s: float | None = None) -> None:
        """Show sweep ``rows`` (:func:`beam.toy.sweep_windows`; None: empty) and mark ``window_s``."""
        rows = rows or []
        self.pipe.send({"window_s": [float(r["window_s"]) for r in rows],
                        "value": [self._scale * float(r[self._key]) for r in rows],
                        "marker_s": None if window_s is None else float(window_s)})
