"""Plots of the diagnosis view (plain bokeh, updated in place when a diagnosis or a ladder rung arrives).

:class:`DiagnosisPlots` holds five figures — residual over time with the 95 % band and the
exceedance intervals, residual and data spectra (Welch) with the model's modal lines, residual
autocorrelation with its ±1.96/√n band, the backbone (instantaneous frequency against
amplitude) of mode 1, and the error ladder — each to be shown in its own pane (no GridPlot:
see :mod:`dashboard.plots.corner`). Displacements in µm, PSDs in m²/Hz.
"""

from __future__ import annotations

import numpy as np
from bokeh.models import ColumnDataSource, FixedTicker, Range1d, Span
from bokeh.plotting import figure

from dashboard.outputs.beam import effect_title as _title
from dashboard.plots.timeseries import COLORS

__all__ = ["DiagnosisPlots"]

UM = 1e6


def _fig(title: str, x: str, y: str, **kw):
    fig = figure(height=270, sizing_mode="stretch_width", title=title, tools="pan,wheel_zoom,box_zoom,reset,save",
                 toolbar_location="above", min_border_left=40, **kw)
    fig.xaxis.axis_label, fig.yaxis.axis_label = x, y
    fig.title.text_font_size = "11pt"
    fig.xaxis.ticker.desired_num_ticks = 5
    return fig


def _empty(*cols) -> dict:
    return {c: [] for c in cols}


class DiagnosisPlots:
    """The figures of the diagnosis view; :meth:`update` shows a diagnosis, :meth:`update_ladder` the ladder."""

    def __init__(self) -> None:
        s = self.sources = {
            "residual": ColumnDataSource(_empty("t", "r"), name="diag-residual"),
            "band": ColumnDataSource(_empty("t", "lo", "hi")),
            "outside": ColumnDataSource(_empty("t", "r")),
            "intervals": ColumnDataSource(_empty("left", "right", "bottom", "top")),
            "psd": ColumnDataSource(_empty("f", "residual", "data")),
            "modes": ColumnDataSource(_empty("f", "y0", "y1")),
            "acf": ColumnDataSource(_empty("lag", "acf")),
            "backbone": ColumnDataSource(_empty("a", "f", "lo", "hi")),
            "ladder": ColumnDataSource(_empty("rung", "label", "rmse", "coverage", "bottom"), name="diag-ladder"),
        }
        #: Titles are short (they are drawn on the canvas and would be cut, not wrapped, in a
        #: narrow column); the verdicts in words are HTML under the plots.
        self.residual = _fig("Residual: data − model mean", "Time (s)", "Residual (µm)")
        self.residual.quad(left="left", right="right", bottom="bottom", top="top", source=s["intervals"],
                           color="#d62728", alpha=0.12, legend_label="exceedance intervals")
        self.residual.varea("t", "lo", "hi", source=s["band"], color=COLORS["prediction"], alpha=0.45,
                            legend_label="95 % prediction band")
        self.residual.line("t", "r", source=s["residual"], color=COLORS["calibration"], legend_label="residual")
        self.residual.scatter("t", "r", source=s["outside"], color="#d62728", size=3, legend_label="outside the band")
        # after Reveal: ± 1.96 × the true noise sd (where a right model's residual stays)
        self.true_noise = [Span(dimension="width", location=0.0, line_dash="dotted", line_width=2,
                                line_color=COLORS["truth"], visible=False) for _ in range(2)]
        for span in self.true_noise:
            self.residual.add_layout(span)
        self.spectrum = _fig("Spectra of data and residual", "Frequency (Hz)",
                             "PSD (m²/Hz)", y_axis_type="log", y_range=Range1d(1e-20, 1.0))
        self.spectrum.line("f", "data", source=s["psd"], color="#7f7f7f", legend_label="data")
        self.spectrum.line("f", "residual", source=s["psd"], color="#d62728", legend_label="residual")
        self.spectrum.segment("f", "y0", "f", "y1", source=s["modes"], color=COLORS["truth"], line_dash="dashed",
                              legend_label="model natural frequencies")
        self.acf = _fig("Residual autocorrelation (window)", "Lag (s)", "Autocorrelation")
        self.acf.vbar(x="lag", top="acf", width=0.0, source=s["acf"], line_color=COLORS["calibration"])
        self.acf.scatter("lag", "acf", source=s["acf"], size=2, color=COLORS["calibration"])
        self.acf_band = [Span(dimension="width", location=v, line_dash="dashed", line_color="#d62728") for v in (0.0, 0.0)]
        for span in self.acf_band:
            self.acf.add_layout(span)
        self.backbone = _fig("Mode 1: frequency vs amplitude", "Amplitude (µm)",
                             "Frequency (Hz)")
        self.backbone.segment("a", "lo", "a", "hi", source=s["backbone"], color="#7f7f7f")
        self.backbone.line("a", "f", source=s["backbone"], color=COLORS["mean"])
        self.backbone.scatter("a", "f", source=s["backbone"], color=COLORS["mean"], size=6)
        self.ladder = _fig("Held-out error per step", "Effect added", "Held-out error (µm)",
                           x_range=Range1d(-0.6, 3.6), y_axis_type="log",
                           y_range=Range1d(0.1, 10.0))
        self.ladder.css_classes = ["diag-ladder-plot"]  # found by the layout tests
        # one tick per rung; the ticker is made once and its ticks change (assigning a list to
        # ``xaxis.ticker`` would make a new bokeh model per ladder update)
        self._ladder_ticks = FixedTicker(ticks=[0])
        self.ladder.xaxis.ticker = self._ladder_ticks
        self.ladder.vbar(x="rung", top="rmse", bottom="bottom", width=0.6, source=s["ladder"], color=COLORS["mean"], alpha=0.7)
        self.ladder.text(x="rung", y="rmse", text="label", source=s["ladder"], text_font_size="8pt", text_align="center",
                         text_baseline="top", y_offset=4)
        for fig in (self.residual, self.spectrum):
            fig.legend.label_text_font_size = "8pt"
            fig.legend.click_policy = "hide"

    @property
    def figures(self) -> list:
        """The five figures, in display order."""
        return [self.residual, self.spectrum, self.acf, self.backbone, self.ladder]

    def update(self, diagnosis) -> None:
        """Show a :class:`~dashboard.jobs.beam.Diagnosis` (None clears)."""
        s = self.sources
        if diagnosis is None:
            for name, src in s.items():
                if name != "ladder":
                    src.data = {k: [] for k in src.data}
            return
        rep = diagnosis.residuals
        band = rep.band
        b = diagnosis.base.bands
        s["residual"].data = {"t": band.time_s, "r": band.residual_m * UM}
        s["band"].data = {"t": b.time_s, "lo": (b.prediction_lower - b.mean) * UM, "hi": (b.prediction_upper - b.mean) * UM}
        s["outside"].data = {"t": band.time_s[band.outside], "r": band.residual_m[band.outside] * UM}
        top = float(np.max(np.abs(band.residual_m))) * UM if band.residual_m.size else 1.0
        s["intervals"].data = {"left": [i.start_s for i in band.intervals], "right": [i.end_s for i in band.intervals],
                               "bottom": [-top] * len(band.intervals), "top": [top] * len(band.intervals)}
        sp = rep.spectrum
        keep = sp.frequency_Hz > 0
        s["psd"].data = {"f": sp.frequency_Hz[keep], "residual": sp.residual_psd_m2_Hz[keep], "data": sp.data_psd_m2_Hz[keep]}
        positive = sp.data_psd_m2_Hz[keep]
        positive = positive[positive > 0]
        y0, y1 = (float(positive.min()), float(positive.max())) if positive.size else (1e-20, 1.0)
        # explicit range: a log axis over a data range with no positive value yet logs a console warning
        self.spectrum.y_range.update(start=y0 / 2, end=y1 * 2)
        fm = [float(f) for f in rep.model_frequencies_Hz if f < sp.frequency_Hz[-1]]
        s["modes"].data = {"f": fm, "y0": [y0] * len(fm), "y1": [y1] * len(fm)}
        w = rep.whiteness
        lag = w.lag_s if np.all(np.isfinite(w.lag_s)) else w.lags.astype(float)
        s["acf"].data = {"lag": lag, "acf": w.acf}
        self.acf_band[0].location, self.acf_band[1].location = float(w.band), -float(w.band)
        bb = rep.mode1.backbone if rep.mode1 is not None else None
        if bb is None:
            s["backbone"].data = _empty("a", "f", "lo", "hi")
            self.backbone.title.text = "Mode 1: no free decay on this record"
        else:
            s["backbone"].data = {"a": bb.amplitude_m * UM, "f": bb.frequency_Hz, "lo": bb.frequency_Hz - bb.frequency_std_Hz,
                                  "hi": bb.frequency_Hz + bb.frequency_std_Hz}
            self.backbone.title.text = "Mode 1: frequency vs amplitude"

    def show_true_noise(self, noise_m: float | None) -> None:
        """Mark ± 1.96 × the true noise sd on the residual plot (after Reveal; None hides the lines)."""
        for span, sign in zip(self.true_noise, (1.0, -1.0)):
            span.visible = noise_m is not None
            span.location = sign * 1.959964 * (noise_m or 0.0) * UM

    def update_ladder(self, rungs: list[dict]) -> None:
        """Show the error ladder rows (:func:`dashboard.state.beam.ladder_rung`)."""
        rmse = [max(r["rmse_prediction_um"], 1e-3) for r in rungs]
        bottom = min(rmse, default=1.0) / 4
        self.sources["ladder"].data = {
            "rung": [r["rung"] for r in rungs], "bottom": [bottom] * len(rungs),
            "label": [f"{r['rmse_prediction_um']:.3g} µm" for r in rungs],
            "rmse": rmse,
            "coverage": [r["coverage95_pct"] for r in rungs]}
        self.ladder.x_range.update(start=-0.6, end=max(len(rungs), 4) - 0.4)
        self.ladder.y_range.update(start=bottom / 2, end=max(rmse, default=1.0) * 3)
        self.ladder.xaxis.major_label_overrides = {r["rung"]: "start" if r["rung"] == 0 else _title(r["added"])
                                                   for r in rungs}
        self._ladder_ticks.ticks = [r["rung"] for r in rungs] or [0]
