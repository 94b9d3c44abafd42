"""Plots of the diagnosis view: HoloViews DynamicMaps fed by Pipes, sent when a diagnosis or a ladder rung arrives.

:class:`DiagnosisPlots` holds five plots — residual over time with the 95 % band and the
exceedance intervals, residual and data spectra (Welch) with the model's modal lines, residual
autocorrelation with its ±1.96/√n band, the backbone (instantaneous frequency against
amplitude) of mode 1, and the error ladder — each a :class:`holoviews.DynamicMap` with its own
:class:`holoviews.streams.Pipe`, shown in its own ``pn.pane.HoloViews`` (no ``hv.Layout``: a
bokeh GridPlot beside another plot never lets the document go idle, see the dashboard README).
They change a few times per session (a diagnosis, an added effect, Reveal), so the tens of
milliseconds of a ``Pipe.send`` of a record's ~5,000 residual samples do not matter.
The segments' and rectangles' key dimensions are named as the axes they are drawn on (``t``,
``lag``, ``a``, ``f``, ``rung``; as ``x0``, ``y0`` or ``left``, ``bottom`` they labelled the axes
so), and the views show the plots with ``linked_axes=False``: ``pn.pane.HoloViews`` links the
axes of plots whose dimensions share a name, and the autocorrelation's lag axis took the
backbone's amplitude range and the backbone's frequency axis the spectrum's 0-500 Hz.
Residuals and amplitudes in the record's read-out unit (:func:`dashboard.outputs.beam.output_units`:
µm for displacement, mm/s for velocity, m/s² for acceleration), PSDs in the output's SI unit² /Hz. The residual's data source is named ``diag-residual``, the
ladder's ``diag-ladder``; the ladder figure carries the CSS class ``diag-ladder-plot``.
"""

from __future__ import annotations

import math

import numpy as np

from dashboard.outputs.beam import effect_title as _title
from dashboard.outputs.beam import output_units
from dashboard.plots.elements import HIDE_ON_CLICK, css_class, hv, name_source
from dashboard.plots.fonts import HV_ACTIVE_TOOLS, HV_FONTSIZE, TICKS_PX
from dashboard.plots.timeseries import COLORS

__all__ = ["DiagnosisPlots"]

UM = 1e6
RED = "#d62728"
_TOOLS = {"default_tools": ["pan", "wheel_zoom", "box_zoom", "reset", "save"], "active_tools": HV_ACTIVE_TOOLS,
          "toolbar": "above", "height": 270, "responsive": True, "fontsize": HV_FONTSIZE}


def _empty_residual() -> dict:
    return {"t": [], "r": [], "band_t": [], "lo": [], "hi": [], "out_t": [], "out_r": [], "intervals": [], "unit": "µm"}


def _psd_unit(si_unit: str) -> str:
    """``"m²/Hz"``, ``"(m/s²)²/Hz"``: the PSD unit of an output in ``si_unit``."""
    return f"{si_unit}²/Hz" if "/" not in si_unit else f"({si_unit})²/Hz"


def _overlay(layers: list, **opts):
    """The layers (each framewise: their ranges follow every new frame) overlaid with ``opts``."""
    return hv.Overlay([layer.opts(framewise=True) for layer in layers]).opts(**opts)


def _hline(y: float | None, **style):
    """A horizontal line at ``y`` (transparent when ``y`` is None, so the layers stay the same)."""
    return hv.HLine(math.nan if y is None else y).opts(line_alpha=0.0 if y is None else 1.0, **style)


class DiagnosisPlots:
    """The plots of the diagnosis view; :meth:`update` shows a diagnosis, :meth:`update_ladder` the ladder.

    Attributes
    ----------
    pipes : dict of str to holoviews.streams.Pipe
        ``residual``, ``true_noise``, ``spectrum``, ``acf``, ``backbone``, ``ladder``: their ``data`` is what
        is drawn.
    residual, spectrum, acf, backbone, ladder : holoviews.DynamicMap
        What the ``pn.pane.HoloViews`` panes show.
    """

    def __init__(self) -> None:
        self.pipes = {
            "residual": hv.streams.Pipe(data=_empty_residual()),
            "true_noise": hv.streams.Pipe(data={"noise_um": None}),
            "spectrum": hv.streams.Pipe(data={"f": [], "residual": [], "data": [], "modes": [], "ylim": (1e-20, 1.0)}),
            "acf": hv.streams.Pipe(data={"lag": [], "acf": [], "band": None}),
            "backbone": hv.streams.Pipe(data={"a": [], "f": [], "lo": [], "hi": [], "title": "Mode 1: frequency vs amplitude"}),
            "ladder": hv.streams.Pipe(data=[]),
        }
        #: Titles are short (they are drawn on the canvas and would be cut, not wrapped, in a
        #: narrow column); the verdicts in words are HTML under the plots.
        # the true noise lines in their own layer: Reveal sends two lines, not the record's residual
        self.residual = (hv.DynamicMap(self._residual, streams=[self.pipes["residual"]])
                         * hv.DynamicMap(self._true_noise, streams=[self.pipes["true_noise"]])).opts(
            title="Residual: data − model mean", legend_position="top_right", **HIDE_ON_CLICK, **_TOOLS)
        self.spectrum = hv.DynamicMap(self._spectrum, streams=[self.pipes["spectrum"]])
        self.acf = hv.DynamicMap(self._acf, streams=[self.pipes["acf"]])
        self.backbone = hv.DynamicMap(self._backbone, streams=[self.pipes["backbone"]])
        self.ladder = hv.DynamicMap(self._ladder, streams=[self.pipes["ladder"]])
        self._shown_key, self._cleared = None, False  # the diagnosis key on the plots; whether they are empty

    @property
    def figures(self) -> list:
        """The five plots, in display order."""
        return [self.residual, self.spectrum, self.acf, self.backbone, self.ladder]

    @property
    def data(self) -> dict:
        """What each plot draws (its pipe's data), by name."""
        return {name: pipe.data for name, pipe in self.pipes.items()}

    # -- elements ---------------------------------------------------------------------------------
    @staticmethod
    def _residual(data: dict):
        t, r = hv.Dimension("t", label="Time (s)"), hv.Dimension("r", label=f"Residual ({data.get('unit', 'µm')})")
        intervals = hv.Rectangles(data["intervals"], kdims=[t, r, "t_end", "r_end"],
                                  label="exceedance intervals").opts(color=RED, alpha=0.12, line_alpha=0.0)
        band = hv.Area({"t": data["band_t"], "lo": data["lo"], "hi": data["hi"]}, t, ["lo", "hi"],
                       label="95 % prediction band").opts(color=COLORS["prediction"], alpha=0.45, line_alpha=0.0)
        line = hv.Curve({"t": data["t"], "r": data["r"]}, t, r, label="residual").opts(
            color=COLORS["calibration"], hooks=[name_source("diag-residual")])
        outside = hv.Scatter({"t": data["out_t"], "r": data["out_r"]}, t, r, label="outside the band").opts(
            color=RED, size=3)
        return _overlay([intervals, band, line, outside])

    @staticmethod
    def _true_noise(data: dict):
        """After Reveal: ± 1.96 × the true noise sd (where a right model's residual stays)."""
        half = None if data["noise_um"] is None else 1.959964 * data["noise_um"]
        return _overlay([_hline(None if half is None else sign * half, color=COLORS["truth"], line_dash="dotted",
                                line_width=2) for sign in (1.0, -1.0)])

    @staticmethod
    def _spectrum(data: dict):
        f, psd = hv.Dimension("f", label="Frequency (Hz)"), hv.Dimension("psd", label=f"PSD ({data.get('psd_unit', 'm²/Hz')})")
        y0, y1 = data["ylim"]
        # explicit range: a log axis over a data range with no positive value yet logs a console warning
        lines = [hv.Curve({"f": data["f"], "psd": data[key]}, f, psd, label=key).opts(color=color, logy=True,
                                                                                          ylim=(y0 / 2, y1 * 2))
                 for key, color in (("data", "#7f7f7f"), ("residual", RED))]
        fm = data["modes"]
        modes = hv.Segments({"f": fm, "psd": [y0] * len(fm), "f_end": fm, "psd_end": [y1] * len(fm)},
                            kdims=[f, psd, "f_end", "psd_end"], label="model natural frequencies").opts(
            color=COLORS["truth"], line_dash="dashed")
        return _overlay([*lines, modes]).opts(title="Spectra of data and residual", logy=True,
                                                legend_position="top_right", **HIDE_ON_CLICK, **_TOOLS)

    @staticmethod
    def _acf(data: dict):
        lag, acf = hv.Dimension("lag", label="Lag (s)"), hv.Dimension("acf", label="Autocorrelation")
        n = len(data["lag"])
        stems = hv.Segments({"lag": data["lag"], "acf": [0.0] * n, "lag_end": data["lag"], "acf_end": data["acf"]},
                            kdims=[lag, acf, "lag_end", "acf_end"]).opts(color=COLORS["calibration"])
        dots = hv.Scatter({"lag": data["lag"], "acf": data["acf"]}, lag, acf).opts(color=COLORS["calibration"], size=2)
        band = [_hline(None if data["band"] is None else s * data["band"], color=RED, line_dash="dashed")
                for s in (1.0, -1.0)]
        return _overlay([stems, dots, *band]).opts(title="Residual autocorrelation (window)", show_legend=False,
                                                     **_TOOLS)

    @staticmethod
    def _backbone(data: dict):
        a, f = hv.Dimension("a", label=f"Amplitude ({data.get('unit', 'µm')})"), hv.Dimension("f", label="Frequency (Hz)")
        bars = hv.Segments({"a": data["a"], "f": data["lo"], "a_end": data["a"], "f_end": data["hi"]},
                           kdims=[a, f, "a_end", "f_end"]).opts(color="#7f7f7f")
        frame = {"a": data["a"], "f": data["f"]}
        return _overlay([bars, hv.Curve(frame, a, f).opts(color=COLORS["mean"]),
                           hv.Scatter(frame, a, f).opts(color=COLORS["mean"], size=6)]).opts(
            title=data["title"], show_legend=False, **_TOOLS)

    @staticmethod
    def _ladder(data: list[dict]):
        rungs = data
        unit = rungs[-1].get("unit", "µm") if rungs else "µm"
        rmse = [max(r["rmse_prediction"], 1e-12) for r in rungs]
        x = [float(r["rung"]) for r in rungs]
        # whole decades, ticked at the decades only: over a range of less than a decade (one bar)
        # the log axis ticked 2000, 2500, 3000 ... and their labels ran into one another
        bottom = 10.0 ** math.floor(math.log10(min(rmse, default=1.0) / 4))
        top = 10.0 ** math.ceil(math.log10(max(rmse, default=1.0) * 3))
        decades = [10.0 ** k for k in range(round(math.log10(bottom)), round(math.log10(top)) + 1)]
        step, error = hv.Dimension("rung", label="Effect added"), hv.Dimension("rmse", label=f"Held-out error ({unit})")
        bars = hv.Rectangles({"rung": [v - 0.3 for v in x], "rmse": [bottom] * len(x), "rung_end": [v + 0.3 for v in x],
                              "rmse_end": rmse, "coverage": [r["coverage95_pct"] for r in rungs]},
                             kdims=[step, error, "rung_end", "rmse_end"],
                             vdims=["coverage"]).opts(color=COLORS["mean"], alpha=0.7, logy=True,
                                                      xlim=(-0.6, max(len(rungs), 4) - 0.4), ylim=(bottom, top),
                                                      hooks=[name_source("diag-ladder")])
        # the value above its bar, dark on the white plot (inside the bar it was hard to read)
        labels = hv.Labels({"rung": x, "rmse": rmse, "label": [f"{_amount(r['rmse_prediction'])} {r.get('unit', unit)}" for r in rungs]},
                           [step, error], "label").opts(text_font_size=f"{TICKS_PX}px", text_baseline="bottom",
                                                        text_color="#222222")
        # an effect's title on two lines (four rungs of one-line titles ran into one another at 1024 px)
        ticks = [(v, "start" if r["rung"] == 0 else _two_lines(_title(r["added"]))) for v, r in zip(x, rungs)] or [(0.0, "start")]
        return _overlay([bars, labels]).opts(
            title="Held-out error per step", logy=True, xticks=ticks, yticks=[(d, f"{d:g}") for d in decades],
            show_legend=False, hooks=[css_class("diag-ladder-plot")], **_TOOLS)

    # -- updates ----------------------------------------------------------------------------------
    def update(self, diagnosis) -> None:
        """Show a :class:`~dashboard.jobs.diagnosis.Diagnosis` (None clears).

        A diagnosis arrives several times (its residual report first, then after every two ranked
        candidates, then final; each a new object, unpickled from the worker) with the same
        residual report, which depends only on the diagnosis key (dataset, window, effects, modes):
        the plots are sent only when the key changes. Measured with ``BEAM_DASHBOARD_LAG_LOG`` under a load average of ~9, each
        send of the four plots held the event loop 0.6–1.5 s.
        """
        pipes = self.pipes
        key = None if diagnosis is None else diagnosis.key
        if key == self._shown_key and (key is not None or self._cleared):
            return
        self._shown_key, self._cleared = key, diagnosis is None
        if diagnosis is None:
            pipes["residual"].send(_empty_residual())
            pipes["spectrum"].send({"f": [], "residual": [], "data": [], "modes": [], "ylim": (1e-20, 1.0)})
            pipes["acf"].send({"lag": [], "acf": [], "band": None})
            pipes["backbone"].send({"a": [], "f": [], "lo": [], "hi": [], "title": "Mode 1: frequency vs amplitude"})
            return
        rep = diagnosis.residuals
        band = rep.band
        b = diagnosis.base.bands
        u = output_units(diagnosis)
        scale = u.scale  # SI -> the read-out unit (µm for displacement)
        top = float(np.max(np.abs(band.residual_m))) * scale if band.residual_m.size else 1.0
        pipes["residual"].send({"unit": u.unit,
            "t": band.time_s, "r": band.residual_m * scale,
            "band_t": b.time_s, "lo": (b.prediction_lower - b.mean) * scale, "hi": (b.prediction_upper - b.mean) * scale,
            "out_t": band.time_s[band.outside], "out_r": band.residual_m[band.outside] * scale,
            "intervals": [(i.start_s, -top, i.end_s, top) for i in band.intervals]})
        sp = rep.spectrum
        keep = sp.frequency_Hz > 0
        positive = sp.data_psd_m2_Hz[keep]
        positive = positive[positive > 0]
        ylim = (float(positive.min()), float(positive.max())) if positive.size else (1e-20, 1.0)
        pipes["spectrum"].send({"psd_unit": _psd_unit(u.si_unit), "f": sp.frequency_Hz[keep], "residual": sp.residual_psd_m2_Hz[keep],
                                "data": sp.data_psd_m2_Hz[keep], "ylim": ylim,
                                "modes": [float(f) for f in rep.model_frequencies_Hz if f < sp.frequency_Hz[-1]]})
        w = rep.whiteness
        lag = w.lag_s if np.all(np.isfinite(w.lag_s)) else w.lags.astype(float)
        pipes["acf"].send({"lag": np.asarray(lag, float), "acf": np.asarray(w.acf, float), "band": float(w.band)})
        bb = rep.mode1.backbone if rep.mode1 is not None else None
        if bb is None:
            pipes["backbone"].send({"a": [], "f": [], "lo": [], "hi": [], "title": "Mode 1: no free decay on this record"})
        else:
            pipes["backbone"].send({"unit": u.unit, "a": bb.amplitude_m * scale, "f": bb.frequency_Hz, "lo": bb.frequency_Hz - bb.frequency_std_Hz,
                                    "hi": bb.frequency_Hz + bb.frequency_std_Hz, "title": "Mode 1: frequency vs amplitude"})

    def show_true_noise(self, noise_m: float | None) -> None:
        """Mark ± 1.96 × the true noise sd on the residual plot (after Reveal; None hides the lines)."""
        noise_um = None if noise_m is None else float(noise_m) * UM
        if noise_um != self.pipes["true_noise"].data["noise_um"]:
            self.pipes["true_noise"].send({"noise_um": noise_um})

    def update_ladder(self, rungs: list[dict]) -> None:
        """Show the error ladder rows (:func:`dashboard.state.beam.ladder_rung`)."""
        self.pipes["ladder"].send(list(rungs))


def _two_lines(text: str) -> str:
    """``text`` broken at the space nearest its middle (a tick label on two lines)."""
    spaces = [i for i, c in enumerate(text) if c == " "]
    if not spaces:
        return text
    cut = min(spaces, key=lambda i: abs(i - len(text) / 2))
    return f"{text[:cut]}\n{text[cut + 1:]}"


def _amount(value: float) -> str:
    """Three significant digits without an exponent up to 10⁶ ("1150", "46.5", "0.0123")."""
    return f"{value:.0f}" if 100 <= abs(value) < 1e6 else f"{value:.3g}"
