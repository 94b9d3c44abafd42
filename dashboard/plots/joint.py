"""Panels of the "Several records" view: one figure per record under the joint calibration.

Plain bokeh updated in place (as :mod:`dashboard.plots.beam`): the record's samples, the joint MAP
model's prediction (the band's mean) and its 95 % prediction band, the calibration window
shaded. Record ``K``'s data sources are named ``joint-data-K``, ``joint-band-K``, ``joint-mean-K``
(unique in the document, read by the browser tests).
"""

from __future__ import annotations

from bokeh.models import BoxAnnotation, ColumnDataSource, Legend, LegendItem, Range1d
from bokeh.plotting import figure

from dashboard.outputs.beam import output_units
from dashboard.plots.beam import MEASUREMENT, MAX_POINTS
from dashboard.plots.fonts import style_figure
from dashboard.plots.timeseries import COLORS

__all__ = ["RecordPanel"]


def thinned(n: int) -> slice:
    """Every k-th sample, so that at most :data:`~dashboard.plots.beam.MAX_POINTS` are drawn."""
    return slice(None, None, max(1, -(-n // MAX_POINTS)))


class RecordPanel:
    """A bokeh figure of record ``index`` under a joint calibration (:meth:`show`).

    Parameters
    ----------
    index : int
        The record's position in the joint calibration (names its data sources).
    height : int
        Figure height (px); the width follows the container.
    """

    def __init__(self, index: int, height: int = 300) -> None:
        self.index = index
        fig = figure(height=height, sizing_mode="stretch_width", x_range=Range1d(0.0, 1.0), y_range=Range1d(-1.0, 1.0),
                     tools="pan,wheel_zoom,box_zoom,reset,save", toolbar_location="right", min_border_left=50,
                     title=f"Record {index + 1}")
        fig.css_classes = ["joint-record-plot"]
        fig.xaxis.axis_label = "Time (s)"
        fig.yaxis.axis_label = output_units(None).axis_label()
        self.window = BoxAnnotation(left=0.0, right=0.0, fill_color=COLORS["window"], fill_alpha=0.35, level="underlay")
        fig.add_layout(self.window)
        self.sources = {
            "band": ColumnDataSource({"time_s": [], "lower": [], "upper": []}, name=f"joint-band-{index}"),
            "data": ColumnDataSource({"time_s": [], "value": []}, name=f"joint-data-{index}"),
            "mean": ColumnDataSource({"time_s": [], "value": []}, name=f"joint-mean-{index}"),
        }
        band = fig.varea("time_s", "lower", "upper", source=self.sources["band"], color=COLORS["prediction"], alpha=0.45)
        data = fig.scatter("time_s", "value", source=self.sources["data"], color=MEASUREMENT, size=2, alpha=0.35,
                           line_alpha=0)
        mean = fig.line("time_s", "value", source=self.sources["mean"], color=COLORS["mean"], line_width=2.5)
        window = fig.varea(x=[0, 0], y1=[0, 0], y2=[0, 0], color=COLORS["window"], alpha=0.35)  # legend swatch only
        legend = Legend(items=[LegendItem(label="measurement", renderers=[data]),
                               LegendItem(label="joint MAP model", renderers=[mean]),
                               LegendItem(label="95 % prediction band", renderers=[band]),
                               LegendItem(label="calibration window", renderers=[window])],
                        orientation="horizontal", click_policy="hide", spacing=14, padding=4, margin=4, glyph_width=18)
        fig.add_layout(legend, "below")
        style_figure(fig)
        self.figure = fig

    def show(self, view, title: str) -> None:
        """Draw a record's :class:`~beam.calibration.CalibrationResult` under the joint posterior
        (its record, bands and window) with ``title``."""
        m = view.setup.measurement
        u = output_units(m)
        scale = u.plot_scale
        self.figure.yaxis.axis_label = u.axis_label()
        self.figure.title.text = title
        t, y = m.time_s, m.output * scale
        k = thinned(t.size)
        self.sources["data"].data = {"time_s": t[k], "value": y[k]}
        b = view.bands
        k = thinned(b.time_s.size)
        self.sources["band"].data = {"time_s": b.time_s[k], "lower": b.prediction_lower[k] * scale,
                                     "upper": b.prediction_upper[k] * scale}
        self.sources["mean"].data = {"time_s": b.time_s[k], "value": b.mean[k] * scale}
        lo, hi = float(y.min()), float(y.max())
        pad = 0.1 * (hi - lo or 1.0)
        self.figure.x_range.update(start=float(t[0]), end=float(t[-1]))
        self.figure.y_range.update(start=lo - pad, end=hi + pad)
        self.window.left, self.window.right = (float(v) for v in view.setup.window)
