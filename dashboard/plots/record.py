"""Plots of the "Your record" view: the beam as described, and the record's spectrum with the
ideal beam's modes. Plain bokeh updated in place (one data source change per input).

Data sources are named ``record-spectrum``, ``record-peaks``, ``record-modes``, ``record-beam``
and ``record-sensor`` (unique in the document: the browser tests read them with
``get_model_by_name``).
"""

from __future__ import annotations

import numpy as np
from bokeh.models import ColumnDataSource, HoverTool, LabelSet, Range1d
from bokeh.plotting import figure

from dashboard.plots.fonts import style_figure

__all__ = ["BeamSketch", "SpectrumPlot"]

#: Fraction of the record's dB range left empty above it, for the modes' labels.
HEADROOM = 0.22
#: Colours: the record, its peaks, the ideal beam's modes, the beam, the clamp, the sensor.
RECORD, PEAK, MODE, BEAM, CLAMP, SENSOR = "#08306b", "#08306b", "#c62828", "#6c757d", "#343a40", "#e6550d"


class BeamSketch:
    """A side view of the cantilever: the clamp, the beam to scale in length (its thickness drawn
    thicker so that it shows) and the sensor where it sits, with the lengths written on it."""

    def __init__(self, height: int = 170) -> None:
        fig = figure(height=height, sizing_mode="stretch_width", x_range=Range1d(-0.2, 1.15), y_range=Range1d(-1.4, 1.6),
                     tools="", toolbar_location=None, title="Your beam (side view, to scale in length)")
        fig.axis.visible = False
        fig.grid.visible = False
        fig.outline_line_alpha = 0
        fig.css_classes = ["record-beam-sketch"]
        self.figure = fig
        self.clamp = ColumnDataSource({"left": [-0.12], "right": [0.0], "bottom": [-0.9], "top": [0.9]})
        fig.quad("left", "right", "bottom", "top", source=self.clamp, color=CLAMP, hatch_pattern="/", hatch_color="white",
                 hatch_alpha=0.5)
        self.beam = ColumnDataSource({"left": [0.0], "right": [1.0], "bottom": [-0.08], "top": [0.08]}, name="record-beam")
        fig.quad("left", "right", "bottom", "top", source=self.beam, color=BEAM)
        self.sensor = ColumnDataSource({"x": [], "y": [], "size": []}, name="record-sensor")
        fig.scatter("x", "y", source=self.sensor, marker="square", size="size", color=SENSOR)
        self.labels = ColumnDataSource({"x": [], "y": [], "text": [], "align": []})
        fig.add_layout(LabelSet(x="x", y="y", text="text", text_align="align", source=self.labels,
                                text_font_size="14px", text_baseline="middle"))
        style_figure(fig)
        self.update(None, None, None)

    def update(self, length_m: float | None, position_m: float | None, mass_kg: float | None) -> None:
        """Draw a beam of ``length_m`` (m; None: unknown, drawn at unit length) with the sensor at
        ``position_m`` (m from the clamp; None: not drawn)."""
        length = float(length_m) if length_m else 1.0
        fig = self.figure
        fig.x_range.update(start=-0.2 * length, end=1.15 * length)
        self.clamp.data = {"left": [-0.12 * length], "right": [0.0], "bottom": [-0.9], "top": [0.9]}
        self.beam.data = {"left": [0.0], "right": [length], "bottom": [-0.08], "top": [0.08]}
        texts = {"x": [0.5 * length], "y": [-0.6],
                 "text": [f"free length {length_m:g} m" if length_m else "free length ? m"], "align": ["center"]}
        texts["x"].append(-0.06 * length)
        texts["y"].append(1.25)
        texts["text"].append("clamp")
        texts["align"].append("center")
        if position_m is not None and 0 < position_m <= 1.5 * length:
            self.sensor.data = {"x": [float(position_m)], "y": [0.3], "size": [18]}
            mass = f", {mass_kg:g} kg" if mass_kg else ""
            right = position_m > 0.6 * length
            texts["x"].append(float(position_m) + (-0.04 if right else 0.04) * length)
            texts["y"].append(0.85)
            texts["text"].append(f"sensor at {position_m:g} m{mass}")
            texts["align"].append("right" if right else "left")
        else:
            self.sensor.data = {"x": [], "y": [], "size": []}
        self.labels.data = texts


class SpectrumPlot:
    """The record's Welch spectrum (dB, log frequency) with its peaks, and the ideal beam's modes
    as vertical red lines labelled ``mode k`` above the record (their frequencies on hover)."""

    def __init__(self, height: int = 330) -> None:
        fig = figure(height=height, sizing_mode="stretch_width", x_axis_type="log", x_range=Range1d(1.0, 1000.0),
                     y_range=Range1d(-100.0, 0.0), tools="pan,wheel_zoom,box_zoom,reset,save", toolbar_location="above",
                     min_border_left=50, title="The record's spectrum and the ideal beam's modes")
        fig.css_classes = ["record-spectrum-plot"]
        fig.xaxis.axis_label = "Frequency (Hz)"
        fig.yaxis.axis_label = "Power spectral density (dB)"
        self.figure = fig
        self.spectrum = ColumnDataSource({"frequency_Hz": [], "psd_db": []}, name="record-spectrum")
        self.peaks = ColumnDataSource({"frequency_Hz": [], "psd_db": []}, name="record-peaks")
        self.modes = ColumnDataSource({"frequency_Hz": [], "bottom": [], "top": [], "label": [], "text": [], "y": []},
                                      name="record-modes")
        spectrum = fig.line("frequency_Hz", "psd_db", source=self.spectrum, color=RECORD, line_width=1.5,
                            legend_label="record (Welch PSD)")
        peaks = fig.scatter("frequency_Hz", "psd_db", source=self.peaks, size=9, color=PEAK, fill_alpha=0,
                            line_width=2, legend_label="record's peaks")
        modes = fig.segment("frequency_Hz", "bottom", "frequency_Hz", "top", source=self.modes, color=MODE, line_width=2,
                            line_dash="dashed", legend_label="ideal beam's modes")
        fig.add_tools(HoverTool(renderers=[peaks], tooltips=[("record's peak", "@frequency_Hz{0.00} Hz")]),
                      HoverTool(renderers=[modes], tooltips=[("ideal beam", "@text")], line_policy="interp"))
        fig.add_layout(LabelSet(x="frequency_Hz", y="y", text="label", source=self.modes, text_color=MODE,
                                text_font_size="14px", angle=np.pi / 2, x_offset=-4, text_align="right"))
        fig.legend.location = "bottom_left"
        fig.legend.background_fill_alpha = 0.8
        self._renderer = spectrum
        style_figure(fig)

    def show_record(self, frequency_Hz: np.ndarray, psd_db: np.ndarray, peaks, unit: str) -> None:
        """Draw a record's spectrum (dB re 1 ``unit``²/Hz) and its peaks (:class:`beam.io.anchor.Peak`)."""
        self.spectrum.data = {"frequency_Hz": np.asarray(frequency_Hz), "psd_db": np.asarray(psd_db)}
        if frequency_Hz.size:
            located = np.array([p.frequency_Hz for p in peaks]) if peaks else np.empty(0)
            self.peaks.data = {"frequency_Hz": located, "psd_db": np.interp(located, frequency_Hz, psd_db)}
            low, high = float(psd_db.min()) - 5.0, float(psd_db.max()) + 5.0
            # headroom above the record for the modes' labels: they never cross its line
            self.figure.y_range.update(start=low, end=high + HEADROOM * (high - low))
        else:
            self.peaks.data = {"frequency_Hz": [], "psd_db": []}
        self.figure.yaxis.axis_label = f"PSD (dB re 1 ({unit})²/Hz)"

    def show_modes(self, modes_Hz) -> None:
        """Mark the ideal beam's natural frequencies (Hz); empty to clear."""
        y = self.figure.y_range
        bottom, top = float(y.start), float(y.end)
        f = self.spectrum.data["frequency_Hz"]
        if len(f):  # the record's band, up to half again past the last mode marked
            end = float(f[-1]) if not len(modes_Hz) else min(float(f[-1]), 1.5 * float(modes_Hz[-1]))
            self.figure.x_range.update(start=float(f[0]), end=end)
        n = len(modes_Hz)
        self.modes.data = {"frequency_Hz": list(modes_Hz), "bottom": [bottom] * n, "top": [top] * n,
                           "label": [f"mode {k + 1}" for k in range(n)],
                           "text": [f"mode {k + 1}: {f:.4g} Hz" for k, f in enumerate(modes_Hz)],
                           "y": [top - 0.02 * (top - bottom)] * n}
