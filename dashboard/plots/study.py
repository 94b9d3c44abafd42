"""Plots of the "Window study" view: held-out error, coverage and credible intervals against the window.

Plain bokeh updated in place (:class:`StudyPlots`): one figure per quantity and likelihood
(i.i.d. and AR(1) side by side), the windows along x in study order (tick labels
``"0–0.35"``, s), one line per effect set, the sets a little apart at each window so that their
intervals do not overlap. :meth:`StudyPlots.show` redraws every figure from the finished cells
(a few hundred points at most: each source is replaced, not patched). The points' data sources
are named ``study-points-{quantity}-{likelihood}`` (found by the browser tests), and their
``position`` column is the cell's position in the study, what a click on a point reports
(:attr:`StudyPlots.on_tap`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from functools import partial

from bokeh.models import ColumnDataSource, FixedTicker, HoverTool, Range1d, Span, TapTool, Whisker
from bokeh.palettes import Category10_10
from bokeh.plotting import figure

from dashboard.plots.fonts import style_figure

__all__ = ["LIKELIHOOD_TITLES", "QUANTITIES", "StudyPlots", "set_colours", "window_label"]

#: Figures per likelihood: (quantity, title).
QUANTITIES = (("error", "Held-out error"), ("coverage", "Band coverage"), ("interval", "95 % interval"))
LIKELIHOOD_TITLES = {"iid": "i.i.d. noise", "ar1": "AR(1) noise"}
#: Horizontal distance between two effect sets at one window (in windows).
DODGE = 0.12
_POINTS = {"x": [], "y": [], "lower": [], "upper": [], "colour": [], "set": [], "window": [], "position": [],
           "text": []}
_LINES = {"xs": [], "ys": [], "colour": []}


def window_label(window: Sequence[float]) -> str:
    """``"0–0.35"``: a window's bounds (s)."""
    return f"{window[0]:g}–{window[1]:g}"


def set_colours(sets: Sequence[tuple[str, ...]]) -> dict[tuple[str, ...], str]:
    """A colour per effect set, in order (the default model first: blue)."""
    return {s: Category10_10[i % 10] for i, s in enumerate(sets)}


class StudyPlots:
    """The study's figures, ``figures[quantity][likelihood]``, and :meth:`show` to fill them.

    Parameters
    ----------
    height : int
        Height of each figure (px); the width follows the container.
    """

    def __init__(self, height: int = 250) -> None:
        self.figures: dict[str, dict[str, object]] = {}
        self.points: dict[str, dict[str, ColumnDataSource]] = {}
        self.lines: dict[str, dict[str, ColumnDataSource]] = {}
        #: Called with a cell's position when its point is clicked.
        self.on_tap: Callable[[int], None] | None = None
        self.parameter: str | None = None
        for quantity, title in QUANTITIES:
            self.figures[quantity], self.points[quantity], self.lines[quantity] = {}, {}, {}
            for likelihood, words in LIKELIHOOD_TITLES.items():
                fig = figure(height=height, sizing_mode="stretch_width", tools="pan,wheel_zoom,reset,save",
                             toolbar_location="above", title=f"{title}, {words}", min_border_left=60,
                             x_range=Range1d(-0.5, 0.5))
                fig.css_classes = [f"study-plot-{quantity}-{likelihood}"]
                points = ColumnDataSource(dict(_POINTS), name=f"study-points-{quantity}-{likelihood}")
                lines = ColumnDataSource(dict(_LINES), name=f"study-lines-{quantity}-{likelihood}")
                fig.multi_line("xs", "ys", source=lines, color="colour", line_width=2, alpha=0.8)
                if quantity == "interval":
                    fig.add_layout(Whisker(base="x", lower="lower", upper="upper", source=points, line_color="colour",
                                           line_width=2, upper_head=None, lower_head=None))
                dots = fig.scatter("x", "y", source=points, color="colour", size=10, line_color="white",
                                   nonselection_alpha=1.0, selection_line_color="black")
                fig.add_tools(HoverTool(renderers=[dots], tooltips=[("", "@text")]),
                              TapTool(renderers=[dots]))
                if quantity == "coverage":
                    span = Span(location=95.0, dimension="width", line_dash="dashed", line_color="#555555",
                                line_width=1.5)
                    fig.add_layout(span)
                    fig.y_range = Range1d(0.0, 102.0)  # the whole scale: how far below 95 % a band falls
                    fig.yaxis.axis_label = "In the 95 % band (%)"
                fig.xaxis.axis_label = "Calibration window (s)"
                fig.xaxis.ticker = FixedTicker(ticks=[])
                fig.xaxis.major_label_orientation = 0.5
                points.selected.on_change("indices", partial(self._tapped, points))
                style_figure(fig)
                self.figures[quantity][likelihood] = fig
                self.points[quantity][likelihood] = points
                self.lines[quantity][likelihood] = lines

    def _tapped(self, source: ColumnDataSource, attr, old, new) -> None:
        if not new or new[0] >= len(source.data["position"]):
            return
        position = int(source.data["position"][new[0]])
        source.selected.indices = []
        if self.on_tap is not None:
            self.on_tap(position)

    def show(self, layout: Sequence[tuple[int, object]], entries: Sequence[dict], *, unit_scale: float,
             unit: str, parameter: str | None, parameter_label: str, set_labels: dict[tuple[str, ...], str]) -> None:
        """Draw the finished ``entries`` of a study laid out as ``layout`` ((window index, StudyCell) in
        table order); the error in ``unit`` (``unit_scale`` × SI), ``parameter``'s interval (SI)."""
        windows = list(dict.fromkeys(cell.window for _, cell in layout))
        sets = list(dict.fromkeys(cell.effects for _, cell in layout))
        colours = set_colours(sets)
        ticks = list(range(len(windows)))
        overrides = {i: window_label(w) for i, w in enumerate(windows)}
        centre = (len(sets) - 1) / 2
        offset = {s: (i - centre) * DODGE for i, s in enumerate(sets)}
        for quantity in self.figures:
            for likelihood, fig in self.figures[quantity].items():
                fig.xaxis.ticker = FixedTicker(ticks=ticks)
                fig.x_range.update(start=-0.5, end=max(len(windows), 1) - 0.5)
                fig.xaxis.major_label_overrides = overrides
                if quantity == "error":
                    fig.yaxis.axis_label = f"Held-out RMSE ({unit})"
                elif quantity == "interval":
                    fig.yaxis.axis_label = parameter_label
                data = {k: [] for k in _POINTS}
                by_set: dict[tuple[str, ...], list[tuple[float, float]]] = {}
                for entry in entries:
                    cell, row = entry["cell"], entry["row"]
                    if cell.likelihood != likelihood or row["error"]:
                        continue
                    value = _value(quantity, row, unit_scale, parameter)
                    if value is None:
                        continue
                    y, lower, upper = value
                    x = windows.index(cell.window) + offset.get(cell.effects, 0.0)
                    data["x"].append(x)
                    data["y"].append(y)
                    data["lower"].append(lower)
                    data["upper"].append(upper)
                    data["colour"].append(colours.get(cell.effects, "#333333"))
                    data["set"].append(set_labels.get(cell.effects, ", ".join(cell.effects)))
                    data["window"].append(window_label(cell.window))
                    data["position"].append(int(entry["position"]))
                    data["text"].append(_hover(row, unit_scale, unit, data["set"][-1]))
                    by_set.setdefault(cell.effects, []).append((x, y))
                lines = {"xs": [], "ys": [], "colour": []}
                for effects, pts in by_set.items():
                    pts.sort()
                    lines["xs"].append([p[0] for p in pts])
                    lines["ys"].append([p[1] for p in pts])
                    lines["colour"].append(colours.get(effects, "#333333"))
                self.points[quantity][likelihood].data = data
                self.lines[quantity][likelihood].data = lines


def _value(quantity: str, row: dict, scale: float, parameter: str | None) -> tuple[float, float, float] | None:
    if quantity == "error":
        v = row.get("rmse_prediction")
        return None if v is None else (scale * v, math.nan, math.nan)
    if quantity == "coverage":
        v = row.get("coverage95_prediction")
        return None if v is None else (100.0 * v, math.nan, math.nan)
    s = row.get("parameters", {}).get(parameter or "")
    if not s or s.get("mean") is None:
        return None
    return s["mean"], s["q025"], s["q975"]


def _hover(row: dict, scale: float, unit: str, set_label: str) -> str:
    rmse, cover = row.get("rmse_prediction"), row.get("coverage95_prediction")
    parts = [f"{window_label(row['window'])} s, {set_label}, {row['likelihood']}"]
    if rmse is not None:
        parts.append(f"held-out RMSE {scale * rmse:.3g} {unit}")
    if cover is not None:
        parts.append(f"coverage {100 * cover:.0f} %")
    parts.append("click: open in the beam view")
    return "; ".join(parts)
