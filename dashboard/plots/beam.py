"""Main plot of the beam calibration view: measurement, model mean and 95 % bands over the record.

Plain bokeh updated in place (it receives every streamed result; see
:mod:`dashboard.plots.timeseries` for the measured reasons). Displacements are drawn in mm. Data
sources are named ``beam-prediction-band``, ``beam-mean``, ``beam-pinned-mean`` ... (unique in the
document, so that browser tests can read them with ``get_model_by_name``).
"""

from __future__ import annotations

import numpy as np
from bokeh.models import BoxAnnotation, ColumnDataSource, Legend, LegendItem, Range1d
from bokeh.plotting import figure

from dashboard.plots.timeseries import COLORS

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
                     tools="pan,wheel_zoom,box_zoom,reset,save", toolbar_location="above",
                     title="Measured displacement and calibrated model (calibration window shaded)")
        fig.xaxis.axis_label = "Time (s)"
        fig.yaxis.axis_label = "Displacement at the sensor (mm)"
        self.window = BoxAnnotation(left=0.0, right=0.0, fill_color=COLORS["window"], fill_alpha=0.35, level="underlay")
        fig.add_layout(self.window)
        names = ("pinned-band", "prediction-band", "credible-band", "data", "pinned-mean", "mean")
        src = self.sources = {n: ColumnDataSource(dict(_BAND if "band" in n else _XY), name=f"beam-{n}") for n in names}
        items = [
            ("95 % prediction band", fig.varea("time_s", "lower", "upper", source=src["prediction-band"],
                                               color=COLORS["prediction"], alpha=0.45)),
            ("95 % credible band", fig.varea("time_s", "lower", "upper", source=src["credible-band"],
                                             color=COLORS["credible"], alpha=0.35)),
            ("measurement", fig.line("time_s", "value", source=src["data"], color=COLORS["calibration"],
                                     line_width=1)),
            ("model: posterior mean", fig.line("time_s", "value", source=src["mean"], color=COLORS["mean"],
                                               line_width=1.5)),
            ("pinned: 95 % prediction band", fig.varea("time_s", "lower", "upper", source=src["pinned-band"],
                                                       color=COLORS["pinned"], alpha=0.15)),
            ("pinned: mean", fig.line("time_s", "value", source=src["pinned-mean"], color=COLORS["pinned"],
                                      line_width=1.5, line_dash="dotdash")),
        ]
        fig.add_layout(Legend(items=[LegendItem(label=label, renderers=[r]) for label, r in items], click_policy="hide",
                              label_text_font_size="9pt", spacing=0), "right")
        self.figure = fig
        self._measurement = None

    def show_measurement(self, measurement) -> None:
        """Draw a record (before any result) and reset the axes to it."""
        if measurement is None or measurement is self._measurement:
            return
        t, y = measurement.time_s, measurement.displacement_m * MM
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
        """Show ``result`` (its bands and window; its record if new) and ``pinned`` (purple)."""
        src = self.sources
        if result is not None:
            self.show_measurement(result.setup.measurement)
            b = result.bands
            k = _every(b.time_s.size)
            t = b.time_s[k]
            src["prediction-band"].data = {"time_s": t, "lower": b.prediction_lower[k] * MM, "upper": b.prediction_upper[k] * MM}
            src["credible-band"].data = {"time_s": t, "lower": b.credible_lower[k] * MM, "upper": b.credible_upper[k] * MM}
            src["mean"].data = {"time_s": t, "value": b.mean[k] * MM}
            self.window.left, self.window.right = (float(v) for v in result.setup.window)
        same_record = pinned is not None and result is not None and pinned.setup.measurement is result.setup.measurement
        if same_record:
            pb = pinned.bands
            k = _every(pb.time_s.size)
            src["pinned-band"].data = {"time_s": pb.time_s[k], "lower": pb.prediction_lower[k] * MM,
                                       "upper": pb.prediction_upper[k] * MM}
            src["pinned-mean"].data = {"time_s": pb.time_s[k], "value": np.asarray(pb.mean[k]) * MM}
        else:
            src["pinned-band"].data = dict(_BAND)
            src["pinned-mean"].data = dict(_XY)
