"""Downloads: of a toy result (JSON summary, predictive-band CSV, printable summary), and the ones
every result shares (:func:`jsonable`, :func:`posterior_netcdf`, used by :mod:`dashboard.outputs.beam` too).

Pure Python. Each function returns the file content (``io.BytesIO`` for
:class:`panel.widgets.FileDownload`) or None when the result cannot provide it.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import tempfile

import numpy as np

__all__ = ["CSV_COLUMNS", "bands_csv", "filename", "jsonable", "posterior_netcdf", "summary_html", "summary_json"]

#: Columns of the band CSV (units in the names; du = data unit).
CSV_COLUMNS = (
    "time_s", "data_du", "truth_du", "in_calibration_window", "posterior_mean_du",
    "credible95_lower_du", "credible95_upper_du", "prediction95_lower_du", "prediction95_upper_du",
)


def jsonable(obj):
    """Plain JSON types; non-finite floats become None."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        value = float(obj)
        return value if math.isfinite(value) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    return obj


def filename(result, extension: str) -> str:
    """A descriptive file name, e.g. ``toy_w5_d0.3_harmonic_iid_seed0.json``."""
    sc = result.scenario
    return f"toy_w{sc.window_s:g}_d{sc.discrepancy:g}_{sc.kind}_{sc.likelihood}_seed{sc.seed}.{extension}"


def summary_json(result) -> io.BytesIO | None:
    """The result's :meth:`~beam.toy.ToyResult.to_json` report (plus its stage and sweep) as UTF-8 JSON."""
    if result is None:
        return None
    report = result.to_json()
    report["stage"] = result.extra.get("stage", "final")
    text = json.dumps(jsonable(report), indent=1, allow_nan=False)
    return io.BytesIO(text.encode("utf-8"))


def bands_csv(result) -> io.BytesIO | None:
    """Data, truth and the 95 % credible / prediction bands on the full horizon as CSV."""
    if result is None:
        return None
    d, b = result.data, result.bands
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    cols = (d.time_s, d.data, d.truth, d.calibration.astype(int), b.mean, b.credible_lower, b.credible_upper,
            b.prediction_lower, b.prediction_upper)
    for row in zip(*cols):
        writer.writerow([f"{v:.6g}" if isinstance(v, float) else int(v) for v in map(_scalar, row)])
    return io.BytesIO(out.getvalue().encode("utf-8"))


def _scalar(v):
    return float(v) if isinstance(v, (float, np.floating)) else int(v)


def posterior_netcdf(result) -> io.BytesIO | None:
    """The MCMC posterior of a result (toy or beam: its ``posterior``) as an ArviZ netCDF-4 file, or None
    (a preview or an intermediate result)."""
    posterior = None if result is None else result.posterior
    if posterior is None:
        return None
    fd, path = tempfile.mkstemp(suffix=".nc", prefix="beam-posterior-")
    os.close(fd)
    try:
        posterior.to_netcdf(path)
        with open(path, "rb") as fh:
            return io.BytesIO(fh.read())
    finally:
        os.unlink(path)


def summary_html(result) -> io.BytesIO | None:
    """A one-page printable summary (self-contained HTML, :func:`beam.io.handout.handout_html`): the
    scenario, the read-outs judged in words, data / truth / bands drawn as inline SVG, and the
    parameters against the truth. None without a result."""
    if result is None:
        return None
    from beam.io.handout import Series, band_svg, handout_html
    from dashboard.outputs.toy import compare_table, judge, readouts, result_label

    d, b, r = result.data, result.bands, readouts(result)
    stage = result.extra.get("stage", "final")
    figure = band_svg([
        Series("95 % prediction band", b.time_s, b.prediction_lower, b.prediction_upper, colour="#ff9896", opacity=0.6),
        Series("95 % credible band", b.time_s, b.credible_lower, b.credible_upper, colour="#d62728", opacity=0.35),
        Series("data (calibration)", d.time_s[d.calibration], d.data[d.calibration], colour="#1f77b4", style="dots"),
        Series("data (held out)", d.time_s[d.held_out], d.data[d.held_out], colour="#7f7f7f", style="dots"),
        Series("truth (noise-free)", d.time_s, d.truth, colour="#2ca02c", style="dashed"),
        Series("posterior mean", b.time_s, b.mean, colour="#d62728")],
        title="Data, truth and the calibrated model (calibration window shaded)", x_label="Time (s)",
        y_label="Signal (du)", window_s=(0.0, float(result.scenario.window_s)))
    table = compare_table(result)
    rows = [[str(index), *map(str, row)] for index, row in zip(table.index, table.to_numpy())]
    _, lines = judge(result)
    text = handout_html(
        "Toy periodic model: one calibration", f"{result_label(result)}; {'MCMC posterior' if stage == 'final' else stage}",
        [("held-out RMSE", f"{r['rmse_du']:.3g} du"), ("held-out data in the 95 % band", f"{r['coverage_pct']:.0f} %"),
         ("estimated noise sd", f"{r['noise_sd_du']:.3g} du (true {r['noise_sd_truth_du']:.3g} du)"),
         ("sd of the frequency f", f"{r['frequency_sd_mHz']:.3g} mHz")],
        tables=[("Parameters: posterior mean ± sd [95 % interval] and the truth", ["quantity", *map(str, table.columns)],
                 rows)],
        figures=[figure], notes=lines)
    return io.BytesIO(text.encode("utf-8"))
