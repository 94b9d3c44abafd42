"""One-page HTML report of a window study (self-contained; the handout machinery of ``beam calibrate --report``).

For each record: the held-out error and the coverage of the 95 % prediction band against the
calibration window (one line per effect set and likelihood; AR(1) dashed), and each parameter's
95 % credible interval against the window (one band per effect set); then the table of cells
and, for several records, the summary across records.
"""

from __future__ import annotations

import math

import numpy as np

from beam.io.handout import Series, band_svg, handout_html

__all__ = ["study_handout", "window_axis"]

#: Line colours of the effect sets (cycled).
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")


def window_axis(windows) -> tuple[str, np.ndarray]:
    """The abscissa that tells ``windows`` ``[(start_s, end_s), ...]`` apart: their ends when they
    share a start (a growing family), their starts when they share a length (a sliding family),
    else their centres. Returns the axis label and the values (s)."""
    w = np.asarray(windows, dtype=float).reshape(-1, 2)
    if np.allclose(w[:, 0], w[0, 0]):
        return "calibration window end (s)", w[:, 1]
    if np.allclose(w[:, 1] - w[:, 0], w[0, 1] - w[0, 0]):
        return "calibration window start (s)", w[:, 0]
    return "calibration window centre (s)", w.mean(axis=1)


def _scale(unit: str | None) -> tuple[float, str]:
    return (1e3, "mm") if unit in (None, "m") else (1.0, unit)


def _fmt(value, digits: int = 3) -> str:
    return "–" if value is None or (isinstance(value, float) and not math.isfinite(value)) else f"{value:.{digits}g}"


def _label(effects: str, likelihood: str) -> str:
    return f"{effects.replace('+', ', ')} ({likelihood})"


def _record_figures(table) -> tuple[list[str], list[str]]:
    """The figures and the generated sentences of one record's cells (rows of the tidy table)."""
    ok = table[table["error"] == ""]
    if ok.empty:
        return [], [f"{table['record'].iloc[0]}: every cell failed."]
    record = ok["record"].iloc[0]
    x_label, x_all = window_axis(list(zip(ok["window_start_s"], ok["window_end_s"])))
    ok = ok.assign(x=x_all)  # one abscissa for every line of the record's figures
    factor, unit = _scale(ok["output_unit"].iloc[0])
    sets = list(dict.fromkeys(ok["effects"]))
    error, coverage, notes = [], [], []
    for (effects, likelihood), group in ok.groupby(["effects", "likelihood"], sort=False):
        group = group.sort_values(["window_start_s", "window_end_s"])
        x = group["x"].to_numpy(float)
        order = np.argsort(x, kind="stable")
        x = x[order]
        colour = COLOURS[sets.index(effects) % len(COLOURS)]
        style = "dashed" if likelihood == "ar1" else "line"
        rmse = group["rmse_prediction"].to_numpy(float)[order] * factor
        cover = group["coverage95_prediction"].to_numpy(float)[order] * 100
        label = _label(effects, likelihood)
        style = style if x.size > 1 else "dots"  # a single point draws no line
        error.append(Series(label, x, rmse, colour=colour, style=style))
        coverage.append(Series(label, x, cover, colour=colour, style=style))
        if np.isfinite(rmse).any():
            best = int(np.nanargmin(rmse))
            windows = group[["window_start_s", "window_end_s"]].to_numpy(float)[order]
            notes.append(f"{record}, {label}: held-out error {_fmt(np.nanmin(rmse))}–{_fmt(np.nanmax(rmse))} {unit} "
                         f"(smallest with the {windows[best][0]:g}–{windows[best][1]:g} s window), "
                         f"95 % band coverage {_fmt(np.nanmin(cover))}–{_fmt(np.nanmax(cover))} %.")
    reference = Series("95 % (nominal)", np.array([x_all.min(), x_all.max()]), np.array([95.0, 95.0]),
                       colour="#777777", style="dashed")
    figures = [
        band_svg(error, title=f"{record}: error on the held-out record", x_label=x_label,
                 y_label=f"RMSE ({unit})", height_px=240),
        band_svg([reference, *coverage], title=f"{record}: held-out data inside the 95 % prediction band",
                 x_label=x_label, y_label="coverage (%)", height_px=240),
    ]
    names = [c[:-5] for c in ok.columns if c.endswith("_mean") and ok[c].notna().any()]
    for name in names:
        layers = []
        for (effects, likelihood), group in ok.groupby(["effects", "likelihood"], sort=False):
            group = group[group[f"{name}_mean"].notna()]
            if group.empty:
                continue
            x = group["x"].to_numpy(float)
            order = np.argsort(x, kind="stable")
            colour = COLOURS[sets.index(effects) % len(COLOURS)]
            layers.append(Series(_label(effects, likelihood), x[order], group[f"{name}_q025"].to_numpy(float)[order],
                                 group[f"{name}_q975"].to_numpy(float)[order], colour=colour, opacity=0.3))
        figures.append(band_svg(layers, title=f"{record}: {name}, 95 % credible interval",
                                x_label=x_label, y_label=name, height_px=200))
    return figures, notes


def study_handout(table, summary=None, computed: int | None = None, reused: int | None = None) -> str:
    """The HTML text of a study's report.

    Parameters
    ----------
    table : pandas.DataFrame
        The tidy table (:func:`beam.study.store.cell_table`).
    summary : pandas.DataFrame, optional
        The summary across records (:func:`beam.study.store.summary_table`), shown for several records.
    computed, reused : int, optional
        Cells calibrated in this run / reused from the output folder.
    """
    records = list(dict.fromkeys(table["record"]))
    figures, notes = [], []
    for record in records:
        f, n = _record_figures(table[table["record"] == record])
        figures += f
        notes += n
    failed = table[table["error"] != ""]
    notes += [f"failed: {r.record}, {r.window_start_s:g}–{r.window_end_s:g} s, {r.effects} ({r.likelihood}): {r.error}"
              for r in failed.itertuples()]
    seconds = table["seconds"].dropna()
    numbers = [("cells", str(len(table))), ("failed", str(len(failed))),
               ("median time per cell", f"{seconds.median():.1f} s" if len(seconds) else "–")]
    if computed is not None and reused is not None:
        numbers.append(("computed / reused", f"{computed} / {reused}"))
    factor = {r: _scale(u)[0] for r, u in zip(table["record"], table["output_unit"])}
    units = {r: _scale(u)[1] for r, u in zip(table["record"], table["output_unit"])}
    rows = [[r.record, f"{r.window_start_s:g}–{r.window_end_s:g}", r.effects, r.likelihood,
             f"{_fmt(r.rmse_prediction * factor[r.record] if r.rmse_prediction == r.rmse_prediction else None)} "
             f"{units[r.record]}",
             _fmt(100 * r.coverage95_prediction if r.coverage95_prediction == r.coverage95_prediction else None),
             _fmt(r.ess_min, 4), _fmt(r.rhat_max, 4), _fmt(r.seconds), "failed" if r.error else ""]
            for r in table.itertuples()]
    tables = [("Cells", ["record", "window (s)", "effects", "likelihood", "held-out RMSE", "coverage (%)", "ESS min",
                         "R-hat max", "seconds", ""], rows)]
    if summary is not None and len(records) > 1:
        tables.append(("Across records (error relative to each record's best window)",
                       ["window #", "effects", "likelihood", "records", "failed", "coverage (%)", "relative RMSE"],
                       [[str(r.window_index), r.effects, r.likelihood, str(r.records), str(r.failed),
                         _fmt(100 * r.coverage95_prediction_mean), _fmt(r.rmse_prediction_relative_median)]
                        for r in summary.itertuples()]))
    notes.append("Each cell is one full calibration (MAP, then MCMC) on its window; the error and coverage are "
                 "measured on every sample outside the window.")
    return handout_html("Calibration-window study", f"{len(records)} record(s): {', '.join(records)}", numbers,
                        tables=tables, figures=figures, notes=notes)
