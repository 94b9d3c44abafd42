"""Main plot of the toy view: data, truth, posterior predictive mean and bands over the horizon.

HoloViews: four :class:`holoviews.DynamicMap` layers overlaid, fed by three
:class:`holoviews.streams.Pipe` — ``scenario`` (data, truth, calibration window, axis ranges;
sent when the scenario changes), ``result`` (the bands and the mean; sent at every streamed
stage) and ``pinned`` — so that a new stage sends only the bands and the mean to the browser.
The pinned layers are invisible (and out of the legend) while nothing is pinned.

Data sources are named ``prediction-band``, ``credible-band``, ``posterior-mean``,
``calibration-data``, ``held-out-data``, ``truth``, ``pinned-band`` and ``pinned-mean``, so
that browser tests and benchmarks can read what is drawn via
``Bokeh.documents[0].get_model_by_name``. A band's source is HoloViews' polygon: columns ``x``
and ``y`` of length 2 n, ``y[:n]`` the upper edge and ``y[n:]`` the lower edge reversed.
"""

from __future__ import annotations

import numpy as np

from dashboard.plots.elements import hide_on_click, hv, name_source

__all__ = ["COLORS", "TimeSeriesPlot"]

COLORS = {
    "calibration": "#1f77b4",
    "held_out": "#7f7f7f",
    "truth": "#2ca02c",
    "mean": "#d62728",
    "credible": "#d62728",
    "prediction": "#ff9896",
    "pinned": "#9467bd",
    "window": "#fdd49e",
}
_T = hv.Dimension("time_s", label="Time (s)")
_V = hv.Dimension("value", label="Signal (du)")
_NO_BANDS = {"time_s": np.zeros(0), "prediction": (np.zeros(0), np.zeros(0)), "credible": (np.zeros(0), np.zeros(0)),
             "mean": np.zeros(0)}


def _area(t, lower, upper, label: str, name: str, color: str, alpha: float):
    return hv.Area((t, lower, upper), _T, ["lower", "upper"], label=label).opts(
        color=color, alpha=alpha, line_alpha=0.0, hooks=[name_source(name)])


def _bands_of(bands) -> dict:
    if bands is None:
        return dict(_NO_BANDS)
    return {"time_s": bands.time_s, "prediction": (bands.prediction_lower, bands.prediction_upper),
            "credible": (bands.credible_lower, bands.credible_upper), "mean": bands.mean}


class TimeSeriesPlot:
    """A HoloViews overlay whose :meth:`update` shows a toy result (and a pinned one).

    Parameters
    ----------
    height : int
        Figure height in pixels (the width follows the container).

    Attributes
    ----------
    pipes : dict of str to holoviews.streams.Pipe
        ``scenario``, ``result``, ``pinned``: what is drawn.
    figure : holoviews.DynamicMap
        What a ``pn.pane.HoloViews`` shows.
    """

    def __init__(self, height: int = 380) -> None:
        empty = np.zeros(0)
        self.pipes = {
            "scenario": hv.streams.Pipe(data={"calibration": (empty, empty), "held_out": (empty, empty),
                                              "truth": (empty, empty), "window_s": 0.0, "xlim": (0.0, 20.0),
                                              "ylim": (-1.5, 1.5)}),
            "result": hv.streams.Pipe(data=dict(_NO_BANDS)),
            "pinned": hv.streams.Pipe(data=dict(_NO_BANDS)),
        }
        layers = [hv.DynamicMap(self._bands, streams=[self.pipes["result"]]),
                  hv.DynamicMap(self._scenario, streams=[self.pipes["scenario"]]),
                  hv.DynamicMap(self._mean, streams=[self.pipes["result"]]),
                  hv.DynamicMap(self._pinned, streams=[self.pipes["pinned"]])]
        self.figure = (layers[0] * layers[1] * layers[2] * layers[3]).opts(
            responsive=True, height=height, legend_position="right",
            default_tools=["pan", "wheel_zoom", "box_zoom", "reset", "save"], toolbar="above",
            title="Data, truth and posterior predictive (calibration window shaded)", hooks=[hide_on_click])
        self._scenario_key = None
        self._pinned_result = None

    @property
    def window_s(self) -> float:
        """Right edge of the shaded calibration window (s)."""
        return self.pipes["scenario"].data["window_s"]

    # -- elements ---------------------------------------------------------------------------------
    @staticmethod
    def _bands(data: dict):
        t = data["time_s"]
        return (_area(t, *data["prediction"], "95 % prediction band", "prediction-band", COLORS["prediction"], 0.45)
                * _area(t, *data["credible"], "95 % credible band", "credible-band", COLORS["credible"], 0.35))

    @staticmethod
    def _scenario(data: dict):
        window = hv.VSpan(0.0, data["window_s"]).opts(color=COLORS["window"], alpha=0.35, line_alpha=0.0)
        cal = hv.Scatter(data["calibration"], _T, _V, label="data (calibration)").opts(
            color=COLORS["calibration"], size=3, framewise=True, xlim=data["xlim"], ylim=data["ylim"],
            hooks=[name_source("calibration-data")])
        held = hv.Scatter(data["held_out"], _T, _V, label="data (held out)").opts(color=COLORS["held_out"], size=3, alpha=0.6,
                                                         hooks=[name_source("held-out-data")])
        truth = hv.Curve(data["truth"], _T, _V, label="truth (noise-free)").opts(color=COLORS["truth"], line_dash="dashed", line_width=1.5,
                                                     hooks=[name_source("truth")])
        return window * cal * held * truth

    @staticmethod
    def _mean(data: dict):
        return hv.Curve((data["time_s"], data["mean"]), _T, _V, label="posterior predictive mean").opts(color=COLORS["mean"], line_width=2,
                                                                     hooks=[name_source("posterior-mean")])

    @staticmethod
    def _pinned(data: dict):
        t = data["time_s"]
        shown = bool(t.size)  # hidden layers are left out of the legend
        return (_area(t, *data["prediction"], "pinned: 95 % prediction band", "pinned-band", COLORS["pinned"],
                      0.15).opts(visible=shown)
                * hv.Curve((t, data["mean"]), _T, _V, label="pinned: mean").opts(
                    color=COLORS["pinned"], line_width=1.5, line_dash="dotdash", visible=shown,
                    hooks=[name_source("pinned-mean")]))

    # -- updates ----------------------------------------------------------------------------------
    def update(self, result=None, pinned=None) -> None:
        """Show ``result`` (data, truth, bands) and ``pinned`` (its band and mean, purple).

        The axis ranges are reset when the scenario changes, not between the stages of one
        run, so a zoom survives the arrival of the MCMC result.
        """
        if result is None:
            if self._scenario_key is not None:
                empty = np.zeros(0)
                self.pipes["scenario"].send({**self.pipes["scenario"].data, "calibration": (empty, empty),
                                             "held_out": (empty, empty), "truth": (empty, empty)})
                self._scenario_key = None
            self.pipes["result"].send(dict(_NO_BANDS))
        else:
            d, b = result.data, result.bands
            self.pipes["result"].send(_bands_of(b))
            if result.scenario != self._scenario_key:
                lo = float(min(d.data.min(), b.prediction_lower.min()))
                hi = float(max(d.data.max(), b.prediction_upper.max()))
                pad = 0.08 * (hi - lo)
                self.pipes["scenario"].send({
                    "calibration": (d.time_s[d.calibration], d.data[d.calibration]),
                    "held_out": (d.time_s[d.held_out], d.data[d.held_out]), "truth": (d.time_s, d.truth),
                    "window_s": float(result.scenario.window_s), "xlim": (0.0, float(d.time_s[-1])),
                    "ylim": (lo - pad, hi + pad)})
                self._scenario_key = result.scenario
        if pinned is not self._pinned_result:
            self.pipes["pinned"].send(_bands_of(None if pinned is None else pinned.bands))
            self._pinned_result = pinned
