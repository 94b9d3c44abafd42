"""One-page printable summary of a beam calibration (self-contained HTML; numpy and the standard library only).

:func:`calibration_handout` is shared by ``beam calibrate --report FILE.html`` and the dashboard's
"Summary for print (HTML)" download of the beam view (which adds its judged read-outs as notes).
Lengths in µm (the record and bands in mm), coverage in %.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from beam.io.handout import Series, band_svg, handout_html, micrometres
from beam.physics.effects import EFFECTS, parameter_spec

__all__ = ["calibration_handout"]

_EXTRA = {"noise_sd": "noise sd σ (m)", "ar1_coefficient": "AR(1) coefficient ρ"}


def _label(name: str) -> str:
    if name in _EXTRA:
        return _EXTRA[name]
    try:
        spec = parameter_spec(name)
    except ValueError:
        return name
    return f"{spec.symbol} — {spec.description} ({spec.unit})"


def _g(value: float, digits: int = 4) -> str:
    return f"{value:.{digits}g}" if math.isfinite(value) else "–"


def calibration_handout(result, notes: Sequence[str] = ()) -> str:
    """The HTML text of a one-page summary of ``result`` (a :class:`beam.calibration.CalibrationResult`).

    Parameters
    ----------
    result : CalibrationResult
        Preview or MCMC result.
    notes : sequence of str
        Extra sentences (e.g. read-outs judged in words), listed before the generated ones.

    Returns
    -------
    str
        A complete HTML document: key numbers (held-out RMSE in µm, coverage of the 95 %
        prediction band in %, noise sd in µm, convergence), the record with the model mean and
        bands (mm, inline SVG, window shaded) and the parameter table.
    """
    s = result.setup
    m, b = s.measurement, result.bands
    mm = 1e3
    stats = result.summary()
    noise = stats.get("noise_sd", {}).get("mean", math.nan)
    post = result.posterior
    if post is None:
        conv = "preview (MAP + Laplace, no MCMC)"
    else:
        d = post.diagnostics
        conv = f"{'converged' if d.converged else 'NOT converged'} (min ESS {d.ess_min:.0f}, max R-hat {d.rhat_max:.3f})"
    effects = ", ".join(EFFECTS[e].title if e in EFFECTS else e for e in s.effects) or "bare beam"
    lo, hi = (float(v) for v in s.window)
    figure = band_svg([
        Series("95 % prediction band", b.time_s, np.asarray(b.prediction_lower) * mm,
               np.asarray(b.prediction_upper) * mm, colour="#ff9896", opacity=0.6),
        Series("95 % credible band", b.time_s, np.asarray(b.credible_lower) * mm, np.asarray(b.credible_upper) * mm,
               colour="#d62728", opacity=0.35),
        Series("model mean", b.time_s, np.asarray(b.mean) * mm, colour="#d62728"),
        Series("measurement", m.time_s, np.asarray(m.displacement_m) * mm, colour="#08306b", style="dots",
               opacity=0.7)],
        title="Measurement and calibrated model (calibration window shaded)", x_label="Time (s)",
        y_label="Displacement (mm)", window_s=(lo, hi))
    rows = [[_label(n), _g(v["mean"]), _g(v["sd"], 2), f"[{_g(v['q025'])}, {_g(v['q975'])}]"] for n, v in stats.items()]
    generated = [f"{100 * result.held_out_mask.mean():.0f} % of the record was held out (not used for calibration).",
                 f"Convergence: {conv}."]
    return handout_html(
        f"Beam calibration: {m.name}",
        f"window {lo:.3g}–{hi:.3g} s, {s.modes} modes, effects: {effects}, likelihood {s.likelihood}",
        [("error on held-out data", micrometres(result.rmse_prediction)),
         ("error in the window", micrometres(result.rmse_calibration)),
         ("held-out data in the 95 % band", f"{100 * result.coverage95_prediction:.1f} %"),
         ("noise the model needs (sd)", micrometres(noise))],
        tables=[("Parameters: posterior", ["parameter", "mean", "sd", "95 % interval"], rows)],
        figures=[figure], notes=[*notes, *generated])
