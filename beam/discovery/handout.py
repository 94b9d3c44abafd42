"""One-page printable summary of a diagnosis (self-contained HTML; numpy and the standard library only).

:func:`diagnosis_handout` is shared by ``beam diagnose --report FILE.html`` (through
:func:`report_handout`) and the dashboard's "Diagnosis for print (HTML)" download, so that both
print the same page: the key numbers, the error ladder (bars on a log axis), the residual of the
current model over the record with its 95 % band, the residual and data spectra, the ranked
candidates with their explanations, the ladder and the modes as tables, the verdict. It is made
with the page machinery of :mod:`beam.io.handout` (the one ``beam calibrate --report`` uses).
Lengths in µm; a velocity or acceleration record in its own SI unit (as ``beam calibrate`` prints
them); coverage in %.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence

import numpy as np

from beam.discovery.judgement import ORDER_WORDS, STATUS_WORDS
from beam.io.handout import Series, band_svg, handout_html, micrometres
from beam.physics.effects import EFFECTS

__all__ = ["diagnosis_handout", "ladder_svg", "report_handout"]


def _title(effect: str | None) -> str:
    if effect is None:
        return "(starting model)"
    return EFFECTS[effect].title if effect in EFFECTS else effect


def _unit(unit: str) -> tuple[float, str]:
    """(scale, label) of the read-out: µm for a length, the SI unit otherwise."""
    return (1e6, "µm") if unit == "m" else (1.0, unit)


def _amount(value: float, unit: str) -> str:
    """A length in µm (:func:`beam.io.handout.micrometres`), another quantity with 4 significant digits."""
    if unit == "m":
        return micrometres(value)
    return f"{value:.4g} {unit}" if math.isfinite(value) else "–"


def _pct(fraction: float) -> str:
    return f"{100 * fraction:.1f} %" if math.isfinite(fraction) else "–"


def ladder_svg(labels: Sequence[str], values: Sequence[float], *, unit: str, title: str,
               width_px: int = 720, row_px: int = 30) -> str:
    """Horizontal bars on a log axis, one per rung, each labelled with its value.

    Parameters
    ----------
    labels : sequence of str
        One per bar, top to bottom (plain text).
    values : sequence of float
        Positive values in ``unit`` (a bar of a non-finite or non-positive value is left out,
        its label stays).
    unit, title : str
        Axis unit and figure title.

    Returns
    -------
    str
        An ``<svg>`` element. The axis shows decades only (1, 10, 100, …; with a single decade
        or less in range, its two bounding decades), so tick labels never run into one another.
    """
    left, right, top, bottom = 200, 70, 28, 40
    n = max(len(values), 1)
    height = top + bottom + row_px * n
    w = width_px - left - right
    ok = [v for v in values if math.isfinite(v) and v > 0]
    lo = 10.0 ** math.floor(math.log10(min(ok))) if ok else 1.0
    hi = 10.0 ** math.ceil(math.log10(max(ok))) if ok else 10.0
    if hi <= lo:
        hi = lo * 10.0
    a, b = math.log10(lo), math.log10(hi)

    def px(v: float) -> float:
        return left + (math.log10(v) - a) / (b - a) * w

    e = html.escape
    out = [(f'<svg class="figure" viewBox="0 0 {width_px} {height}" width="100%" role="img" aria-label="{e(title)}" '
            f'font-family="sans-serif" font-size="11">'),
           f'<text x="{width_px / 2:.0f}" y="16" text-anchor="middle" font-size="13" font-weight="bold">{e(title)}</text>']
    for i, (label, value) in enumerate(zip(labels, values)):
        y = top + row_px * i
        out.append(f'<text x="{left - 6}" y="{y + row_px / 2 + 4:.1f}" text-anchor="end">{e(label)}</text>')
        if math.isfinite(value) and value > 0:
            x = px(value)
            out.append(f'<rect x="{left}" y="{y + 5}" width="{max(x - left, 1):.1f}" height="{row_px - 10}" '
                       f'fill="#2f6f9f"/><text x="{x + 4:.1f}" y="{y + row_px / 2 + 4:.1f}">{value:.3g} {e(unit)}</text>')
    base_y = top + row_px * n
    out.append(f'<line x1="{left}" y1="{base_y}" x2="{left + w}" y2="{base_y}" stroke="#444"/>')
    for k in range(round(a), round(b) + 1):
        x = px(10.0 ** k)
        out.append(f'<line x1="{x:.1f}" y1="{base_y}" x2="{x:.1f}" y2="{base_y + 4}" stroke="#444"/>'
                   f'<text x="{x:.1f}" y="{base_y + 16}" text-anchor="middle">{10.0 ** k:g}</text>')
    out.append(f'<text x="{left + w / 2:.0f}" y="{base_y + 32}" text-anchor="middle">{e(unit)} (log scale)</text></svg>')
    return "".join(out)


def diagnosis_handout(base, residuals, candidates: Sequence, ladder: Sequence, verdict: str,
                      notes: Sequence[str] = ()) -> str:
    """The HTML text of a one-page summary of a diagnosis.

    Parameters
    ----------
    base : CalibrationResult
        The current model's calibration (what the diagnosis examined).
    residuals : ResidualReport
        :func:`beam.discovery.report.residual_report` of ``base``.
    candidates : sequence of Candidate
        Ranked best first.
    ladder : sequence of LadderStep
        The rungs, the starting model first (errors in the output's SI unit).
    verdict : str
        The diagnosis in one sentence.
    notes : sequence of str
        Further sentences, listed after the verdict.

    Returns
    -------
    str
        A complete HTML document (no script, no external reference).
    """
    s = base.setup
    m = s.measurement
    unit = m.output_unit
    scale, shown = _unit(unit)
    free = s.is_free
    error_name = "calibration-window error" if free else "held-out error"
    lo, hi = (float(v) for v in s.window)
    last = ladder[-1] if ladder else None

    def error_of(step) -> float:
        return step.rmse_calibration if free else step.rmse_prediction

    bars = ladder_svg([_title(step.added) for step in ladder], [scale * error_of(step) for step in ladder],
                      unit=shown, title=f"Error ladder: {error_name} after each added effect")
    band, bands = residuals.band, base.bands
    residual_fig = band_svg([
        Series("95 % prediction band (about the model mean)", bands.time_s,
               (np.asarray(bands.prediction_lower) - bands.mean) * scale,
               (np.asarray(bands.prediction_upper) - bands.mean) * scale, colour="#ff9896", opacity=0.6),
        Series("residual: data − model mean", band.time_s, np.asarray(band.residual_m) * scale, colour="#08306b",
               style="dots", opacity=0.5)],
        title="Residual of the starting model over the record (calibration window shaded)", x_label="Time (s)",
        y_label=f"Residual ({shown})", window_s=(lo, hi))
    spectrum = residuals.spectrum
    f = np.asarray(spectrum.frequency_Hz)
    keep = f > 0

    def db(psd) -> np.ndarray:
        psd = np.asarray(psd, float)[keep]
        return 10.0 * np.log10(np.maximum(psd, np.finfo(float).tiny))

    spectrum_fig = band_svg([
        Series("data", f[keep], db(spectrum.data_psd_m2_Hz), colour="#9ecae1"),
        Series("residual", f[keep], db(spectrum.residual_psd_m2_Hz), colour="#d62728")],
        title="Spectra of the data and of the residual (Welch)", x_label="Frequency (Hz)",
        y_label=f"PSD (dB re 1 {unit}²/Hz)")
    candidate_rows = [[_title(c.effect),
                       f"{c.delta_log_evidence:+.1f}" if math.isfinite(c.delta_log_evidence) else "failed",
                       _amount(c.rmse_calibration if free else c.rmse_prediction, unit),
                       STATUS_WORDS.get(c.status, "missing" if c.material else "not material"), c.explanation]
                      for c in candidates]
    ladder_rows = [[str(i), _title(step.added), _amount(step.rmse_calibration, unit),
                    _amount(step.rmse_prediction, unit), _pct(step.coverage95_prediction),
                    "full (MCMC)" if step.mcmc else "preview"] for i, step in enumerate(ladder)]
    mode_rows = [[str(row.mode), _g(row.frequency_data_Hz), _g(row.frequency_model_Hz),
                  f"{row.frequency_error_pct:+.1f} %" if math.isfinite(row.frequency_error_pct)
                  else "not resolved by the record" if not row.resolved else "–"]
                 for row in residuals.comparison]
    tables = [(f"Candidate effects, best first ({ORDER_WORDS})", ["effect", "evidence gain (nats)", error_name,
                                                                 "judged", "why"], candidate_rows),
              ("Error ladder", ["step", "added", "error in the window", "held-out error", "held-out in the 95 % band",
                                "posterior"], ladder_rows)]
    if mode_rows:
        tables.append(("Modes: measured against the starting model",
                       ["mode", "measured f (Hz)", "model f (Hz)", "measured f relative to the model"], mode_rows))
    effects = ", ".join(_title(e) for e in s.effects) or "bare beam"
    return handout_html(
        f"Beam diagnosis: {m.name}",
        f"window {lo:.3g}–{hi:.3g} s, {s.modes} modes, starting model: {effects}",
        [(f"{error_name}, starting model", _amount(error_of(ladder[0]) if ladder else math.nan, unit)),
         (f"{error_name}, last rung", _amount(error_of(last) if last is not None else math.nan, unit)),
         ("held-out data in the 95 % band, last rung", _pct(last.coverage95_prediction if last is not None else math.nan)),
         ("best candidate", _title(candidates[0].effect) if candidates else "–")],
        tables=tables, figures=[bars, residual_fig, spectrum_fig], notes=[verdict, *notes])


def _g(value: float) -> str:
    return f"{value:.4g}" if math.isfinite(value) else "–"


def report_handout(report) -> str:
    """:func:`diagnosis_handout` of a :class:`beam.discovery.report.DiagnosisReport` (``beam diagnose --report``)."""
    return diagnosis_handout(report.base, report.residuals, report.ranking.candidates, report.ladder, report.verdict,
                             [*report.residuals.notes, *report.bound_notes])
