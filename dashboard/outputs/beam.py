"""Read-outs, tables and downloads of beam calibration results (pure Python: numpy and pandas).

Everything comes from the public :class:`beam.calibration.CalibrationResult` API; every
quantity carries its unit in its label (displacements and RMSE in µm, coverage in %).
"""

from __future__ import annotations

import io
import json
import math
import os
import tempfile
import threading

import numpy as np
import pandas as pd

from beam.physics.effects import parameter_spec
from dashboard.outputs.exports import _jsonable

__all__ = [
    "bands_csv",
    "compare_table",
    "convergence",
    "correlation_table",
    "filename",
    "parameter_label",
    "parameter_table",
    "posterior_netcdf",
    "readouts",
    "result_label",
    "summary",
    "summary_json",
]

_EXTRA_LABELS = {"noise_sd": "Noise sd σ (m)", "ar1_coefficient": "AR(1) coefficient ρ (1)"}


def parameter_label(name: str) -> str:
    """``"EI — bending stiffness (N m²)"`` for a catalogue parameter, ``"Noise sd σ (m)"`` for noise."""
    if name in _EXTRA_LABELS:
        return _EXTRA_LABELS[name]
    try:
        spec = parameter_spec(name)
    except ValueError:
        return name
    return f"{spec.symbol} — {spec.description} ({spec.unit})"


def short_label(name: str) -> str:
    """``"EI (N m²)"``: short axis label with unit."""
    if name in _EXTRA_LABELS:
        return _EXTRA_LABELS[name].replace("Noise sd ", "").replace("AR(1) coefficient ", "")
    try:
        return parameter_spec(name).label
    except ValueError:
        return name


def result_label(result) -> str:
    """``"lab_run_1, window 0–1.05 s, 4 modes, air_damping + kelvin_voigt, iid"``."""
    s = result.setup
    lo, hi = s.window
    return f"{s.measurement.name}, window {lo:g}–{hi:g} s, {s.modes} modes, {' + '.join(s.effects) or 'bare beam'}, {s.likelihood}"


def convergence(result) -> dict:
    """``{"mcmc", "converged", "ess_min", "rhat_max", "warnings"}`` (preview: not converged, NaN)."""
    post = None if result is None else result.posterior
    if post is None:
        return {"mcmc": False, "converged": False, "ess_min": math.nan, "rhat_max": math.nan, "warnings": []}
    d = post.diagnostics
    return {"mcmc": True, "converged": bool(d.converged), "ess_min": float(d.ess_min), "rhat_max": float(d.rhat_max),
            "warnings": list(d.warnings)}


_memo: dict[tuple[int, str], tuple[object, object]] = {}
_memo_lock = threading.Lock()


def _memoised(result, what: str, compute):
    """``compute()`` once per result object (a result feeds several read-outs and tables at each update)."""
    key = (id(result), what)
    with _memo_lock:
        hit = _memo.get(key)
        if hit is not None and hit[0] is result:
            return hit[1]
    value = compute()
    with _memo_lock:
        _memo[key] = (result, value)
        while len(_memo) > 16:
            _memo.pop(next(iter(_memo)))
    return value


def summary(result) -> dict[str, dict[str, float]]:
    """``result.summary()``, computed once per result."""
    return _memoised(result, "summary", result.summary)


def readouts(result) -> dict[str, float]:
    """RMSE in the window and held out (µm), held-out 95 % coverage (%), noise sd (µm); NaN without a result."""
    keys = ("rmse_calibration_um", "rmse_prediction_um", "coverage_pct", "noise_sd_um")
    if result is None:
        return dict.fromkeys(keys, math.nan)

    def compute():
        noise = summary(result).get("noise_sd", {}).get("mean", math.nan)
        return {"rmse_calibration_um": 1e6 * result.rmse_calibration, "rmse_prediction_um": 1e6 * result.rmse_prediction,
                "coverage_pct": 100.0 * result.coverage95_prediction, "noise_sd_um": 1e6 * noise}

    return dict(_memoised(result, "readouts", compute))


def _estimate(s: dict | None) -> str:
    if s is None:
        return "–"
    return f"{s['mean']:.4g} ± {s['sd']:.2g}  [{s['q025']:.4g}, {s['q975']:.4g}]"


def parameter_table(result) -> pd.DataFrame:
    """Parameters (mean ± sd [95 % interval]) with units; empty without a result."""
    if result is None:
        return pd.DataFrame()
    stats = summary(result)
    rows = {parameter_label(n): {"posterior mean ± sd [95 % interval]": _estimate(stats[n]),
                                 "relative sd (%)": f"{100 * stats[n]['sd'] / abs(stats[n]['mean']):.2g}"
                                 if stats[n]["mean"] else "–"} for n in stats}
    return pd.DataFrame.from_dict(rows, orient="index")


def correlation_table(result) -> pd.DataFrame:
    """Posterior correlations (sampling coordinates, 1), rounded to two decimals."""
    if result is None:
        return pd.DataFrame()
    corr = result.correlation()
    names = list(corr)
    return pd.DataFrame([[round(corr[a][b], 2) for b in names] for a in names],
                        index=[short_label(n) for n in names], columns=[short_label(n) for n in names])


def compare_table(current, pinned=None) -> pd.DataFrame:
    """Side by side: set-up, stage, parameters, RMSE (µm), coverage (%), convergence; columns Pinned, Current."""
    if current is None:
        return pd.DataFrame()
    columns = ({"Pinned": pinned} if pinned is not None else {}) | {"Current": current}
    names: list[str] = []
    for res in columns.values():
        names += [n for n in summary(res) if n not in names]
    index = (["Set-up", "Stage"] + [parameter_label(n) for n in names] + [
        "RMSE in the window (µm)", "Held-out RMSE (µm)", "Held-out coverage, 95 % prediction band (%)",
        "Converged (min ESS, max R-hat)"])
    table = {}
    for label, res in columns.items():
        r, c, s = readouts(res), convergence(res), summary(res)
        conv = (f"{'yes' if c['converged'] else 'NO'} ({c['ess_min']:.0f}, {c['rhat_max']:.3f})" if c["mcmc"]
                else "preview (no MCMC)")
        table[label] = [result_label(res), "preview (MAP + Laplace)" if res.is_preview else "posterior (MCMC)"] + [
            _estimate(s.get(n)) for n in names] + [
            f"{r['rmse_calibration_um']:.4g}", f"{r['rmse_prediction_um']:.4g}", f"{r['coverage_pct']:.1f}", conv]
    return pd.DataFrame(table, index=index)


# -- downloads ------------------------------------------------------------------------------------
def filename(result, extension: str) -> str:
    """e.g. ``lab_run_1_w0-1.05_m4_air_damping+kelvin_voigt_iid.json``."""
    s = result.setup
    effects = "+".join(s.effects) or "bare"
    return f"{s.measurement.name}_w{s.window[0]:g}-{s.window[1]:g}_m{s.modes}_{effects}_{s.likelihood}.{extension}"


def summary_json(result) -> io.BytesIO | None:
    """:meth:`CalibrationResult.to_json` as UTF-8 JSON (non-finite numbers as null)."""
    if result is None:
        return None
    text = json.dumps(_jsonable(result.to_json()), indent=1, allow_nan=False)
    return io.BytesIO(text.encode("utf-8"))


def bands_csv(result) -> io.BytesIO | None:
    """:meth:`CalibrationResult.band_table` (time, data, window flag, mean and 95 % bands, SI units)."""
    return None if result is None else io.BytesIO(result.band_table().encode("utf-8"))


def posterior_netcdf(result) -> io.BytesIO | None:
    """The MCMC posterior as an ArviZ netCDF-4 file; None for a preview."""
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


def thinned_draws(result, n: int = 500) -> dict[str, np.ndarray]:
    """At most ``n`` evenly spaced posterior draws per parameter (for the pair plot)."""
    if result is None:
        return {}
    draws = result.draws()
    size = min(len(v) for v in draws.values())
    idx = np.linspace(0, size - 1, min(n, size)).astype(int)
    return {k: np.asarray(v)[idx] for k, v in draws.items()}
