"""Window-sweep plots of the toy view: held-out coverage and RMSE against the calibration window.

Plain bokeh updated in place, like :mod:`dashboard.plots.timeseries` (a few tens of
milliseconds to build, about a millisecond to update; ``docs/decisions.md`` has the HoloViews
measurements behind the choice).

Data sources are named ``sweep-coverage`` and ``sweep-rmse`` (columns ``window_s``, ``value``).
"""

from __future__ import annotations

from bokeh.models import ColumnDataSource, Range1d, Span
from bokeh.plotting import figure

from dashboard.plots.timeseries import COLORS

__all__ = ["QUANTITIES", "SweepPlot"]

#: quantity -> (row key, axis label with unit, title, scale to the plotted unit)
QUANTITIES = {
    "coverage": ("coverage95_prediction", "Held-out coverage (%)", "Coverage of the 95 % prediction band (%) vs window",
                 100.0),
    "rmse": ("rmse_prediction", "Held-out RMSE (du)", "Held-out RMSE (du) vs window", 1.0),
}


class SweepPlot:
    """Coverage (%) or RMSE (du) of the Laplace preview against the calibration window.

    Parameters
    ----------
    quantity : {"coverage", "rmse"}
        What to plot.
    height : int
        Figure height in pixels (the width follows the container).
    """

    def __init__(self, quantity: str, height: int = 280) -> None:
        if quantity not in QUANTITIES:
            raise ValueError(f"unknown sweep quantity {quantity!r}; expected one of {', '.join(QUANTITIES)}")
        self.quantity = quantity
        self._key, label, title, self._scale = QUANTITIES[quantity]
        # explicit ranges (set by update): a DataRange1d over empty sources (the sweep of a new
        # scenario is cleared while it is computed) logs "could not set initial ranges" in the browser
        fig = figure(height=height, sizing_mode="stretch_width", title=title, toolbar_location=None, tools="",
                     x_range=Range1d(0.0, 16.0), y_range=Range1d(0.0, 100.0 if quantity == "coverage" else 1.0))
        fig.xaxis.axis_label = "Calibration window (s)"
        fig.yaxis.axis_label = label
        self.source = ColumnDataSource({"window_s": [], "value": []}, name=f"sweep-{quantity}")
        fig.line("window_s", "value", source=self.source, color=COLORS["mean"], line_width=2)
        fig.scatter("window_s", "value", source=self.source, color=COLORS["mean"], size=6)
        #: The window of the latest final result (dashed).
        self.marker = Span(dimension="height", location=0.0, line_color=COLORS["calibration"], line_dash="dashed",
                           visible=False)
        fig.add_layout(self.marker)
        if quantity == "coverage":  # the nominal level
            fig.add_layout(Span(dimension="width", location=95.0, line_color=COLORS["truth"], line_dash="dotted"))
        self.figure = fig

    def update(self, rows=None, window_s: float | None = None) -> None:
        """Show sweep ``rows`` (:func:`beam.toy.sweep_windows`; None: empty) and mark ``window_s``."""
        rows = rows or []
        self.source.data = {"window_s": [r["window_s"] for r in rows],
                            "value": [self._scale * r[self._key] for r in rows]}
        values = self.source.data["value"]
        windows = [r["window_s"] for r in rows] + ([window_s] if window_s is not None else [])
        if windows:
            self.figure.x_range.update(start=min(0.0, min(windows)), end=max(windows) + 1.0)
        if self.quantity == "coverage":
            self.figure.y_range.update(start=min([0.0] + values), end=102.0)
        elif values:
            self.figure.y_range.update(start=0.0, end=1.1 * max(values) or 1.0)
        self.marker.visible = window_s is not None
        if window_s is not None:
            self.marker.location = float(window_s)
