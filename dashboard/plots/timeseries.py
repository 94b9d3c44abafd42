"""Main plot of the toy view: data, truth, posterior predictive mean and bands over the horizon.

Plain bokeh with in-place ``ColumnDataSource`` updates, because this plot receives every
streamed result (preview, intermediate MCMC results, final): measured in the browser
(``python tests/benchmarks/bench_dashboard.py``), a HoloViews version added 0.1-0.8 s to every
median and missed the 0.5 s preview target (the figures are on the design-decisions page). The
plots that change rarely (window sweep, diagnosis) are HoloViews.

The data source of the prediction band is named ``prediction-band`` (columns ``time_s``,
``lower``, ``upper``) and that of the posterior mean ``posterior-mean``, so that browser tests
and benchmarks can read what is drawn via ``Bokeh.documents[0].get_model_by_name``.
"""

from __future__ import annotations

import numpy as np
from bokeh.models import BoxAnnotation, ColumnDataSource, Legend, LegendItem, Range1d
from bokeh.plotting import figure

from dashboard.plots.fonts import style_figure

__all__ = ["COLORS", "TimeSeriesPlot"]

COLORS = {
    "calibration": "#1f77b4",
    "held_out": "#7f7f7f",
    "truth": "#2ca02c",
    "mean": "#d62728",
    "credible": "#d62728",
    "prediction": "#ff9896",
    "pinned": "#555555",  # grey, as the beam view's: lavender was hard to tell from the pink bands
    "window": "#fdd49e",
}
_EMPTY_BAND = {"time_s": [], "lower": [], "upper": []}
_EMPTY_XY = {"time_s": [], "value": []}


def _band(bands, lower: str, upper: str) -> dict:
    if bands is None:
        return dict(_EMPTY_BAND)
    return {"time_s": bands.time_s, "lower": getattr(bands, lower), "upper": getattr(bands, upper)}


def _xy(x, y) -> dict:
    return {"time_s": np.asarray(x), "value": np.asarray(y)}


class TimeSeriesPlot:
    """A bokeh figure whose :meth:`update` shows a toy result (and a pinned one) in place.

    Parameters
    ----------
    height : int
        Figure height in pixels (the width follows the container).
    """

    def __init__(self, height: int = 410) -> None:
        fig = figure(height=height, sizing_mode="stretch_width", x_range=Range1d(0.0, 20.0), y_range=Range1d(-1.5, 1.5),
                     tools="pan,wheel_zoom,box_zoom,reset,save", toolbar_location="above",
                     title="Data, truth and posterior predictive (calibration window shaded)")
        fig.css_classes = ["toy-plot"]  # found by the layout tests
        fig.xaxis.axis_label = "Time (s)"
        fig.yaxis.axis_label = "Signal (du)"
        self.window = BoxAnnotation(left=0.0, right=0.0, fill_color=COLORS["window"], fill_alpha=0.35, level="underlay")
        fig.add_layout(self.window)
        src = self.sources = {
            "pinned-band": ColumnDataSource(dict(_EMPTY_BAND), name="pinned-band"),
            "prediction-band": ColumnDataSource(dict(_EMPTY_BAND), name="prediction-band"),
            "credible-band": ColumnDataSource(dict(_EMPTY_BAND), name="credible-band"),
            "calibration-data": ColumnDataSource(dict(_EMPTY_XY), name="calibration-data"),
            "held-out-data": ColumnDataSource(dict(_EMPTY_XY), name="held-out-data"),
            "truth": ColumnDataSource(dict(_EMPTY_XY), name="truth"),
            "pinned-mean": ColumnDataSource(dict(_EMPTY_XY), name="pinned-mean"),
            "posterior-mean": ColumnDataSource(dict(_EMPTY_XY), name="posterior-mean"),
        }
        # drawn in this order (the data on top of the model's lines, so neither hides the other);
        # listed in the legend in the order of ``items``
        bands = {
            "pinned": fig.varea("time_s", "lower", "upper", source=src["pinned-band"], color=COLORS["pinned"], alpha=0.18),
            "prediction": fig.varea("time_s", "lower", "upper", source=src["prediction-band"],
                                    color=COLORS["prediction"], alpha=0.45),
            "credible": fig.varea("time_s", "lower", "upper", source=src["credible-band"], color=COLORS["credible"],
                                  alpha=0.35),
        }
        lines = {
            "pinned": fig.line("time_s", "value", source=src["pinned-mean"], color=COLORS["pinned"], line_width=1.5,
                               line_dash="dotdash"),
            "truth": fig.line("time_s", "value", source=src["truth"], color=COLORS["truth"], line_dash="dashed",
                              line_width=1.5),
            "mean": fig.line("time_s", "value", source=src["posterior-mean"], color=COLORS["mean"], line_width=2),
        }
        points = {
            "calibration": fig.scatter("time_s", "value", source=src["calibration-data"], size=3,
                                       color=COLORS["calibration"]),
            "held_out": fig.scatter("time_s", "value", source=src["held-out-data"], size=3, color=COLORS["held_out"],
                                    alpha=0.6),
        }
        items = [
            ("95 % prediction band", bands["prediction"]),
            ("95 % credible band", bands["credible"]),
            ("data (calibration)", points["calibration"]),
            ("data (held out)", points["held_out"]),
            ("truth (noise-free)", lines["truth"]),
            ("posterior predictive mean", lines["mean"]),
        ]
        # the pinned result's entries only while one is pinned (none listed for nothing)
        self._pinned_items = [LegendItem(label="pinned: 95 % prediction band", renderers=[bands["pinned"]], visible=False),
                              LegendItem(label="pinned: mean", renderers=[lines["pinned"]], visible=False)]
        # below the plot, as the beam view's: on the right it took half the plot's width at 1024 px
        legend = Legend(items=[LegendItem(label=label, renderers=[r]) for label, r in items] + self._pinned_items,
                        click_policy="hide", spacing=10, orientation="horizontal",
                        nrows=2, padding=4, margin=4, glyph_width=18)  # two rows: in one it ran past the plot's left edge
        fig.add_layout(legend, "below")
        style_figure(fig)
        self.figure = fig
        self._scenario = None

    def update(self, result=None, pinned=None) -> None:
        """Show ``result`` (data, truth, bands) and ``pinned`` (its band and mean, purple).

        The axis ranges are reset when the scenario changes, not between the stages of one
        run, so a zoom survives the arrival of the MCMC result.
        """
        src = self.sources
        if result is None:
            for name, source in src.items():
                source.data = dict(_EMPTY_BAND if "band" in name else _EMPTY_XY)
        else:
            d, b = result.data, result.bands
            src["prediction-band"].data = _band(b, "prediction_lower", "prediction_upper")
            src["credible-band"].data = _band(b, "credible_lower", "credible_upper")
            src["posterior-mean"].data = _xy(b.time_s, b.mean)
            if result.scenario != self._scenario:
                src["calibration-data"].data = _xy(d.time_s[d.calibration], d.data[d.calibration])
                src["held-out-data"].data = _xy(d.time_s[d.held_out], d.data[d.held_out])
                src["truth"].data = _xy(d.time_s, d.truth)
                self.window.right = float(result.scenario.window_s)
                lo = float(min(d.data.min(), b.prediction_lower.min()))
                hi = float(max(d.data.max(), b.prediction_upper.max()))
                pad = 0.08 * (hi - lo)
                self.figure.x_range.update(start=0.0, end=float(d.time_s[-1]))
                self.figure.y_range.update(start=lo - pad, end=hi + pad)
                self._scenario = result.scenario
        pb = None if pinned is None else pinned.bands
        src["pinned-band"].data = _band(pb, "prediction_lower", "prediction_upper")
        src["pinned-mean"].data = dict(_EMPTY_XY) if pb is None else _xy(pb.time_s, pb.mean)
        for item in self._pinned_items:
            if item.visible != (pb is not None):
                item.visible = pb is not None
