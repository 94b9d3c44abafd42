"""Main plot of the beam calibration view: measurement, model mean and 95 % bands over the record.

Plain bokeh updated in place: it receives every streamed result, and in the browser the
HoloViews version (DynamicMaps fed by Pipes for the record, the result, the pinned result and
the true noise) drew the beam preview in 0.82 and 0.92 s median (1.34, 1.39 s max) after a
window move in two runs, against 0.49 and 0.55 s (0.68, 0.66 s max) for this module in runs
just after them (target 0.5 s; table and conditions in :mod:`dashboard.plots.timeseries`).
The output is drawn in its plot unit (:func:`dashboard.outputs.beam.output_units`: displacement in
mm, velocity in mm/s, acceleration in m/s²), the y axis labelled with it. Data sources are named ``beam-prediction-band``, ``beam-mean``,
``beam-pinned-mean`` ... (unique in the document, so that browser tests can read them with
``get_model_by_name``).
"""

from __future__ import annotations

import numpy as np
from bokeh.models import BoxAnnotation, ColumnDataSource, Legend, LegendItem, Range1d
from bokeh.plotting import figure

from dashboard.outputs.beam import output_units
from dashboard.plots.fonts import style_figure
from dashboard.plots.timeseries import COLORS

#: The pinned result (grey: the pink bands are the current result's) and the measurement (dark blue).
PINNED = "#555555"
MEASUREMENT = "#08306b"

__all__ = ["MM", "BeamTimeSeriesPlot"]

#: Metres -> millimetres.
MM = 1e3
#: Samples drawn per series at most (a record has a few thousand; more would slow the browser).
MAX_POINTS = 4000
_BAND = {"time_s": [], "lower": [], "upper": []}
_XY = {"time_s": [], "value": []}


def _every(n: int) -> slice:
    return slice(None, None, max(1, -(-n // MAX_POINTS)))


class BeamTimeSeriesPlot:
    """A bokeh figure whose :meth:`update` shows a calibration (and a pinned one) in place.

    Parameters
    ----------
    height : int
        Figure height in pixels (the width follows the container).
    """

    def __init__(self, height: int = 380) -> None:
        fig = figure(height=height, sizing_mode="stretch_width", x_range=Range1d(0.0, 1.0), y_range=Range1d(-1.0, 1.0),
                     tools="pan,wheel_zoom,box_zoom,reset,save", toolbar_location="above", min_border_left=50,
                     title="Measurement and calibrated model (window shaded)")
        fig.css_classes = ["beam-plot"]  # found by the layout tests
        fig.xaxis.ticker.desired_num_ticks = 6
        fig.xaxis.axis_label = "Time (s)"
        fig.yaxis.axis_label = output_units(None).axis_label()  # "Displacement (mm)" until a record is shown
        self.window = BoxAnnotation(left=0.0, right=0.0, fill_color=COLORS["window"], fill_alpha=0.35, level="underlay")
        fig.add_layout(self.window)
        names = ("pinned-band", "prediction-band", "credible-band", "data", "pinned-mean", "mean", "true-noise")
        src = self.sources = {n: ColumnDataSource(dict(_BAND if "band" in n or n == "true-noise" else _XY),
                                                  name=f"beam-{n}") for n in names}
        # drawn in this order: bands, the measurement, the model mean on top. The measurement's
        # dots are small and light: dense and dark (size 2.5, opacity 0.7, drawn over the mean)
        # they hid the red model line on a projector. The pinned result in grey, far from the pink bands.
        pinned_band = fig.varea("time_s", "lower", "upper", source=src["pinned-band"], color=PINNED, alpha=0.25)
        prediction = fig.varea("time_s", "lower", "upper", source=src["prediction-band"], color=COLORS["prediction"],
                               alpha=0.45)
        credible = fig.varea("time_s", "lower", "upper", source=src["credible-band"], color=COLORS["credible"], alpha=0.35)
        measured = fig.scatter("time_s", "value", source=src["data"], color=MEASUREMENT, size=2, alpha=0.35,
                               line_alpha=0)
        mean = fig.line("time_s", "value", source=src["mean"], color=COLORS["mean"], line_width=2.5)
        items = [("95 % prediction band", prediction), ("95 % credible band", credible), ("model mean", mean),
                 ("measurement", measured)]
        pinned_mean = fig.line("time_s", "value", source=src["pinned-mean"], color=PINNED, line_width=2,
                               line_dash="dashed")
        true_noise = [fig.line("time_s", edge, source=src["true-noise"], color=COLORS["truth"], line_width=1.5,
                               line_dash="dotted") for edge in ("lower", "upper")]
        self._pinned_items = [LegendItem(label="pinned: 95 % band", renderers=[pinned_band], visible=False),
                              LegendItem(label="pinned: mean", renderers=[pinned_mean], visible=False)]
        self._truth_item = LegendItem(label="mean ± 1.96 × true noise", renderers=true_noise, visible=False)
        legend = Legend(items=[LegendItem(label=label, renderers=[r]) for label, r in items] + self._pinned_items
                        + [self._truth_item], click_policy="hide", spacing=14,
                        orientation="horizontal", padding=4, margin=4, glyph_width=18)
        fig.add_layout(legend, "below")
        style_figure(fig)
        self.figure = fig
        self._measurement = None
        self._result = None
        self._true_noise_m: float | None = None
        self._scale = MM  # SI -> the plot unit of the record shown

    def show_measurement(self, measurement) -> None:
        """Draw a record (before any result) and reset the axes to it."""
        if measurement is None or measurement is self._measurement:
            return
        u = output_units(measurement)
        self._scale = u.plot_scale
        self.figure.yaxis.axis_label = u.axis_label()
        t, y = measurement.time_s, measurement.output * u.plot_scale
        k = _every(t.size)
        self.sources["data"].data = {"time_s": t[k], "value": y[k]}
        lo, hi = float(y.min()), float(y.max())
        pad = 0.1 * (hi - lo or 1.0)
        self.figure.x_range.update(start=float(t[0]), end=float(t[-1]))
        self.figure.y_range.update(start=lo - pad, end=hi + pad)
        self._measurement = measurement
        for name in ("prediction-band", "credible-band", "mean"):
            self.sources[name].data = dict(_BAND if "band" in name else _XY)

    def update(self, result=None, pinned=None) -> None:
        """Show ``result`` (its bands and window; its record if new) and ``pinned`` (grey; its legend
        entries only while there is one)."""
        src = self.sources
        if result is not None:
            self.show_measurement(result.setup.measurement)
            b = result.bands
            k = _every(b.time_s.size)
            t = b.time_s[k]
            src["prediction-band"].data = {"time_s": t, "lower": b.prediction_lower[k] * self._scale, "upper": b.prediction_upper[k] * self._scale}
            src["credible-band"].data = {"time_s": t, "lower": b.credible_lower[k] * self._scale, "upper": b.credible_upper[k] * self._scale}
            src["mean"].data = {"time_s": t, "value": b.mean[k] * self._scale}
            self.window.left, self.window.right = (float(v) for v in result.setup.window)
        same_record = pinned is not None and result is not None and pinned.setup.measurement is result.setup.measurement
        if same_record:
            pb = pinned.bands
            k = _every(pb.time_s.size)
            src["pinned-band"].data = {"time_s": pb.time_s[k], "lower": pb.prediction_lower[k] * self._scale,
                                       "upper": pb.prediction_upper[k] * self._scale}
            src["pinned-mean"].data = {"time_s": pb.time_s[k], "value": np.asarray(pb.mean[k]) * self._scale}
        else:
            src["pinned-band"].data = dict(_BAND)
            src["pinned-mean"].data = dict(_XY)
        for item in self._pinned_items:
            item.visible = same_record
        self._show_truth(result)

    def show_true_noise(self, noise_m: float | None) -> None:
        """Draw the model mean ± 1.96 × the true noise sd (after Reveal; None hides it)."""
        self._true_noise_m = noise_m
        self._show_truth(self._result)

    def _show_truth(self, result) -> None:
        self._result = result
        noise = getattr(self, "_true_noise_m", None)
        if result is None or noise is None:
            self.sources["true-noise"].data = dict(_BAND)
            self._truth_item.visible = False
            return
        b = result.bands
        k = _every(b.time_s.size)
        mean = np.asarray(b.mean[k]) * self._scale
        half = 1.959964 * noise * self._scale
        self.sources["true-noise"].data = {"time_s": b.time_s[k], "lower": mean - half, "upper": mean + half}
        self._truth_item.visible = True
