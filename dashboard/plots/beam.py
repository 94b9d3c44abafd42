"""Main plot of the beam calibration view: measurement, model mean and 95 % bands over the record.

HoloViews: five :class:`holoviews.DynamicMap` layers overlaid, fed by four
:class:`holoviews.streams.Pipe` — ``record`` (the measurement and the axis ranges; sent when the
record changes), ``result`` (bands, mean and window; sent at every streamed stage), ``pinned``
(grey; drawn only for the same record) and ``truth`` (mean ± 1.96 × the true noise sd, after
Reveal) — so that a new stage sends only the bands and the mean. Hidden layers are left out of
the legend. Displacements are drawn in mm.

Data sources are named ``beam-prediction-band``, ``beam-credible-band``, ``beam-mean``,
``beam-data``, ``beam-pinned-band``, ``beam-pinned-mean`` and ``beam-true-noise`` (unique in the
document, so that browser tests can read them with ``get_model_by_name``). A band's source is
HoloViews' polygon (columns ``x``, ``y``: the upper edge, then the lower one reversed); the true
noise is a two-line path (columns ``xs``, ``ys``).
"""

from __future__ import annotations

import numpy as np

from dashboard.plots.elements import css_class, hide_on_click, hv, name_source
from dashboard.plots.timeseries import COLORS

#: The pinned result (grey: the pink bands are the current result's) and the measurement (dark blue).
PINNED = "#555555"
MEASUREMENT = "#08306b"

__all__ = ["MM", "BeamTimeSeriesPlot"]

#: Metres -> millimetres.
MM = 1e3
#: Samples drawn per series at most (a record has a few thousand; more would slow the browser).
MAX_POINTS = 4000
_T = hv.Dimension("time_s", label="Time (s)")
_Y = hv.Dimension("value", label="Displacement (mm)")
_EMPTY = np.zeros(0)
_NO_BANDS = {"time_s": _EMPTY, "prediction": (_EMPTY, _EMPTY), "credible": (_EMPTY, _EMPTY), "mean": _EMPTY,
             "window_s": (0.0, 0.0)}


def _every(n: int) -> slice:
    return slice(None, None, max(1, -(-n // MAX_POINTS)))


def _bands_of(result) -> dict:
    if result is None:
        return dict(_NO_BANDS)
    b = result.bands
    k = _every(b.time_s.size)
    return {"time_s": b.time_s[k], "prediction": (b.prediction_lower[k] * MM, b.prediction_upper[k] * MM),
            "credible": (b.credible_lower[k] * MM, b.credible_upper[k] * MM), "mean": np.asarray(b.mean[k]) * MM,
            "window_s": tuple(float(v) for v in result.setup.window)}


def _area(t, lower, upper, label: str, name: str, color: str, alpha: float, visible: bool = True):
    return hv.Area((t, lower, upper), _T, ["lower", "upper"], label=label).opts(
        color=color, alpha=alpha, line_alpha=0.0, visible=visible, hooks=[name_source(name)])


def _room_for_ticks(plot, element) -> None:
    """A hook: room for the y tick labels, six x ticks."""
    fig = plot.state
    if fig.min_border_left != 50:
        fig.min_border_left = 50
        fig.xaxis.ticker.desired_num_ticks = 6


class BeamTimeSeriesPlot:
    """A HoloViews overlay whose :meth:`update` shows a calibration (and a pinned one).

    Parameters
    ----------
    height : int
        Figure height in pixels (the width follows the container).

    Attributes
    ----------
    pipes : dict of str to holoviews.streams.Pipe
        ``record``, ``result``, ``pinned``, ``truth``: what is drawn.
    figure : holoviews.DynamicMap
        What a ``pn.pane.HoloViews`` shows.
    """

    def __init__(self, height: int = 380) -> None:
        self.pipes = {
            "record": hv.streams.Pipe(data={"time_s": _EMPTY, "value": _EMPTY, "xlim": (0.0, 1.0), "ylim": (-1.0, 1.0)}),
            "result": hv.streams.Pipe(data=dict(_NO_BANDS)),
            "pinned": hv.streams.Pipe(data=dict(_NO_BANDS)),
            "truth": hv.streams.Pipe(data={"time_s": _EMPTY, "lower": _EMPTY, "upper": _EMPTY}),
        }
        maps = [hv.DynamicMap(self._pinned, streams=[self.pipes["pinned"]]),
                hv.DynamicMap(self._bands, streams=[self.pipes["result"]]),
                hv.DynamicMap(self._mean, streams=[self.pipes["result"]]),
                hv.DynamicMap(self._record, streams=[self.pipes["record"]]),
                hv.DynamicMap(self._truth, streams=[self.pipes["truth"]])]
        overlay = maps[0]
        for layer in maps[1:]:
            overlay = overlay * layer
        self.figure = overlay.opts(
            responsive=True, height=height, legend_position="bottom",
            default_tools=["pan", "wheel_zoom", "box_zoom", "reset", "save"], toolbar="above",
            title="Measurement and calibrated model (window shaded)",
            fontsize={"title": "12pt", "labels": "11pt", "xticks": "10pt", "yticks": "10pt", "legend": "10pt"},
            legend_opts={"spacing": 14, "padding": 4, "margin": 4, "glyph_width": 18},
            hooks=[hide_on_click, css_class("beam-plot"), _room_for_ticks])  # the class: found by the layout tests
        self._measurement = None
        self._result = None
        self._pinned_shown = None
        self._true_noise_m: float | None = None

    @property
    def window_s(self) -> tuple[float, float]:
        """The shaded calibration window (s)."""
        return self.pipes["result"].data["window_s"]

    # -- elements ---------------------------------------------------------------------------------
    @staticmethod
    def _pinned(data: dict):
        t = data["time_s"]
        shown = bool(t.size)  # hidden layers are left out of the legend
        return (_area(t, *data["prediction"], "pinned: 95 % band", "beam-pinned-band", PINNED, 0.25, shown)
                * hv.Curve((t, data["mean"]), _T, _Y, label="pinned: mean").opts(
                    color=PINNED, line_width=2, line_dash="dashed", visible=shown, hooks=[name_source("beam-pinned-mean")]))

    @staticmethod
    def _bands(data: dict):
        t = data["time_s"]
        lo, hi = data["window_s"]
        window = hv.VSpan(lo, hi).opts(color=COLORS["window"], alpha=0.35, line_alpha=0.0)
        return (window * _area(t, *data["prediction"], "95 % prediction band", "beam-prediction-band",
                               COLORS["prediction"], 0.45)
                * _area(t, *data["credible"], "95 % credible band", "beam-credible-band", COLORS["credible"], 0.35))

    @staticmethod
    def _mean(data: dict):
        return hv.Curve((data["time_s"], data["mean"]), _T, _Y, label="model mean").opts(
            color=COLORS["mean"], line_width=1.5, hooks=[name_source("beam-mean")])

    @staticmethod
    def _record(data: dict):
        # the measurement over the model mean (dots, so the mean shows between them)
        return hv.Scatter((data["time_s"], data["value"]), _T, _Y, label="measurement").opts(
            color=MEASUREMENT, size=2.5, alpha=0.7, framewise=True, xlim=data["xlim"], ylim=data["ylim"],
            hooks=[name_source("beam-data")])

    @staticmethod
    def _truth(data: dict):
        t = data["time_s"]
        return hv.Path([(t, data["lower"]), (t, data["upper"])], [_T, _Y], label="mean ± 1.96 × true noise").opts(
            color=COLORS["truth"], line_width=1.5, line_dash="dotted", visible=bool(t.size), show_legend=True,
            hooks=[name_source("beam-true-noise")])

    # -- updates ----------------------------------------------------------------------------------
    def show_measurement(self, measurement) -> None:
        """Draw a record (before any result) and reset the axes to it."""
        if measurement is None or measurement is self._measurement:
            return
        t, y = measurement.time_s, measurement.displacement_m * MM
        k = _every(t.size)
        lo, hi = float(y.min()), float(y.max())
        pad = 0.1 * (hi - lo or 1.0)
        self.pipes["record"].send({"time_s": t[k], "value": y[k], "xlim": (float(t[0]), float(t[-1])),
                                   "ylim": (lo - pad, hi + pad)})
        self._measurement = measurement
        self.pipes["result"].send(dict(_NO_BANDS))

    def update(self, result=None, pinned=None) -> None:
        """Show ``result`` (its bands and window; its record if new) and ``pinned`` (grey; its legend
        entries only while there is one)."""
        if result is not None:
            self.show_measurement(result.setup.measurement)
            self.pipes["result"].send(_bands_of(result))
        same_record = pinned is not None and result is not None and pinned.setup.measurement is result.setup.measurement
        shown = pinned if same_record else None
        if shown is not self._pinned_shown:
            self.pipes["pinned"].send(_bands_of(shown))
            self._pinned_shown = shown
        self._show_truth(result)

    def show_true_noise(self, noise_m: float | None) -> None:
        """Draw the model mean ± 1.96 × the true noise sd (after Reveal; None hides it)."""
        self._true_noise_m = noise_m
        self._show_truth(self._result)

    def _show_truth(self, result) -> None:
        self._result = result
        noise = self._true_noise_m
        if result is None or noise is None:
            if self.pipes["truth"].data["time_s"].size:
                self.pipes["truth"].send({"time_s": _EMPTY, "lower": _EMPTY, "upper": _EMPTY})
            return
        b = result.bands
        k = _every(b.time_s.size)
        mean = np.asarray(b.mean[k]) * MM
        half = 1.959964 * noise * MM
        self.pipes["truth"].send({"time_s": b.time_s[k], "lower": mean - half, "upper": mean + half})
