"""Read-outs and comparison tables of toy results (pure Python: numpy and pandas).

All figures come from the public :class:`beam.toy.ToyResult` API and carry their unit in
their label.
"""

from __future__ import annotations

import math
import re

import pandas as pd

__all__ = [
    "PAIR_PARAMETERS",
    "PARAMETER_LABELS",
    "STAGE_LABELS",
    "compare_table",
    "readouts",
    "result_label",
    "user_message",
]

#: Display label (with unit) of each toy parameter.
PARAMETER_LABELS = {
    "amplitude": "Amplitude A (du)",
    "frequency_Hz": "Frequency f (Hz)",
    "phase_rad": "Phase φ (rad)",
    "noise_sd": "Noise sd σ (du)",
    "ar1_coefficient": "AR(1) coefficient ρ (1)",
}
#: Parameters of the pair plot.
PAIR_PARAMETERS = ("amplitude", "frequency_Hz", "phase_rad", "noise_sd")
#: What each result stage means, for status lines and tables.
STAGE_LABELS = {
    "preview": "preview (MAP + Laplace)",
    "partial": "MCMC in progress",
    "final": "posterior (MCMC)",
}


def user_message(message: str) -> str:
    """A library message without command-line option names, for the dashboard.

    ``"window (--window 12 s) must be shorter than the horizon (--horizon 10 s)"`` becomes
    ``"window (12 s) must be shorter than the horizon (10 s)"``; ``"noise sd (--noise) must
    not be negative"`` becomes ``"noise sd must not be negative"``.
    """
    text = re.sub(r"\s*\(--[\w-]+\)", "", message)
    return re.sub(r"\(--[\w-]+\s+", "(", text)


def _stage(result) -> str:
    return result.extra.get("stage", "final" if result.posterior is not None else "preview")


def result_label(result) -> str:
    """Short description of a result's scenario, e.g. ``"window 5 s, δ 0.3 du harmonic, iid"``."""
    sc = result.scenario
    disc = f"δ {sc.discrepancy:g} du {sc.kind}" if sc.discrepancy else "no discrepancy"
    return f"window {sc.window_s:g} s, {disc}, {sc.likelihood}, noise {sc.noise_sd:g} du, seed {sc.seed}"


def readouts(result) -> dict[str, float]:
    """Scores of a result on the held-out part of the record.

    Returns
    -------
    dict
        ``rmse_du`` (RMSE of the posterior mean against held-out data), ``coverage_pct``
        (held-out data inside the 95 % prediction band, %), ``credible_truth_pct`` (held-out
        noise-free truth inside the 95 % credible band, %), ``frequency_sd_mHz`` (posterior
        sd of f), ``noise_sd_du`` (posterior mean of σ), ``noise_sd_truth_du``. NaN when no
        result.
    """
    if result is None:
        return dict.fromkeys(("rmse_du", "coverage_pct", "credible_truth_pct", "frequency_sd_mHz", "noise_sd_du",
                              "noise_sd_truth_du"), math.nan)
    data, bands = result.data, result.bands
    return {
        "rmse_du": result.rmse_prediction,
        "coverage_pct": 100.0 * result.coverage95_prediction,
        "credible_truth_pct": 100.0 * bands.credible_coverage(data.truth, data.held_out),
        "frequency_sd_mHz": 1000.0 * result.summary["frequency_Hz"]["sd"],
        "noise_sd_du": result.summary["noise_sd"]["mean"],
        "noise_sd_truth_du": result.truth["noise_sd"],
    }


def _estimate(summary: dict, name: str) -> str:
    if name not in summary:
        return "–"
    s = summary[name]
    return f"{s['mean']:.4g} ± {s['sd']:.2g}  [{s['q025']:.4g}, {s['q975']:.4g}]"


def compare_table(current, pinned=None) -> pd.DataFrame:
    """Side-by-side table of parameters (mean ± sd [95 % interval]), RMSE and coverage.

    Parameters
    ----------
    current : ToyResult or None
        The result shown.
    pinned : ToyResult, optional
        The pinned result.

    Returns
    -------
    pandas.DataFrame
        Index: quantities with units; columns ``Pinned`` (if any), ``Current``, ``Truth``
        (truth of the current scenario). Empty when ``current`` is None.
    """
    if current is None:
        return pd.DataFrame()
    columns = {}
    if pinned is not None:
        columns["Pinned"] = pinned
    columns["Current"] = current
    names = [n for n in PARAMETER_LABELS if any(n in r.summary for r in columns.values())]
    rows = ["Scenario", "Stage"] + [PARAMETER_LABELS[n] for n in names] + [
        "Held-out RMSE (du)", "Held-out coverage, 95 % prediction band (%)", "Truth inside 95 % credible band (%)"]
    table = {}
    for label, res in columns.items():
        r = readouts(res)
        table[label] = [result_label(res), STAGE_LABELS.get(_stage(res), _stage(res))] + [
            _estimate(res.summary, n) for n in names] + [
            f"{r['rmse_du']:.3f}", f"{r['coverage_pct']:.1f}", f"{r['credible_truth_pct']:.1f}"]
    truth = current.truth
    table["Truth"] = ["", ""] + [f"{truth[n]:.4g}" if n in truth else "–" for n in names] + ["", "95 (nominal)", "95 (nominal)"]
    return pd.DataFrame(table, index=rows)
