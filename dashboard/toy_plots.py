"""HoloViews (bokeh backend) plots of the window sweep, as DynamicMaps driven by the session state.

The plot functions return overlays of *always the same layers* (empty when there is nothing to
show), so that the DynamicMaps update their bokeh data sources in place. The sweep changes
rarely (once per scenario, not per streamed result); the plots that receive every streamed
result are plain bokeh (:mod:`dashboard.timeseries`, :mod:`dashboard.corner`) for speed.
"""

from __future__ import annotations

import holoviews as hv
import numpy as np

from dashboard.timeseries import COLORS

__all__ = ["sweep_curves", "sweep_plot"]


def sweep_curves(quantity: str, rows=None, window_s: float = 0.0) -> hv.Overlay:
    """Coverage (%) or RMSE (du) of the Laplace preview against the calibration window.

    Parameters
    ----------
    quantity : {"coverage", "rmse"}
        What to plot.
    rows : list of dict, optional
        :func:`beam.toy.sweep_windows` rows.
    window_s : float
        Current window, marked by a vertical line.
    """
    key, label, title, unit, scale = {
        "coverage": ("coverage95_prediction", "Held-out coverage", "Coverage of the 95 % prediction band", "%", 100.0),
        "rmse": ("rmse_prediction", "Held-out RMSE", "Held-out RMSE", "du", 1.0),
    }[quantity]
    window = hv.Dimension("window_s", label="Calibration window", unit="s")
    value = hv.Dimension(quantity, label=label, unit=unit)
    xy = ([r["window_s"] for r in rows or []], [scale * r[key] for r in rows or []])
    layers = [
        hv.Curve(xy, window, value).opts(color=COLORS["mean"], line_width=2),
        hv.Scatter(xy, window, value).opts(color=COLORS["mean"], size=6),
        hv.VLine(window_s).opts(color=COLORS["calibration"], line_dash="dashed"),
    ]
    if quantity == "coverage":
        layers.append(hv.HLine(95.0).opts(color=COLORS["truth"], line_dash="dotted"))
    else:
        layers.append(hv.HLine(np.nan).opts(alpha=0))
    return hv.Overlay([layer.opts(framewise=True) for layer in layers]).opts(responsive=True, height=280, show_grid=True,
                                   title=f"{title} ({unit}) vs window", toolbar=None)


def _stream(toy, *names):
    return [hv.streams.Params(parameterized=toy, parameters=list(names))]


def sweep_plot(toy, quantity: str) -> hv.DynamicMap:
    """:func:`sweep_curves` of ``toy.sweep`` with the window of the latest final result marked.

    The marker follows ``toy.final``, not the slider: redrawing the two sweep plots at every
    slider step (~30 ms each on the event loop) delayed the preview of the new scenario.
    One DynamicMap per quantity, to be shown in separate panes: an ``hv.Layout`` renders as a
    bokeh ``GridPlot``, which beside another plot keeps the document from ever becoming idle
    (Panel 1.9 / Bokeh 3.9; see :mod:`dashboard.corner`).
    """
    def plot(sweep, final):
        return sweep_curves(quantity, sweep, 0.0 if final is None else final.scenario.window_s)

    return hv.DynamicMap(plot, streams=_stream(toy, "sweep", "final"))
