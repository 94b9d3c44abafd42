"""The science of the toy: calibration without discrepancy, and what a discrepancy breaks.

Figures quoted in comments were measured with these seeds (see the final report / README).
Multi-seed studies use the MAP + Laplace preview (validated against MCMC in
test_inference_sampling.py and by the MCMC spot checks below); the no-discrepancy calibration
test uses the full MCMC.
"""

from __future__ import annotations

import numpy as np
import pytest

from beam.inference import preview
from beam.toy import ToyScenario, calibration_problem, run_toy, simulate, sweep_windows

SEEDS = range(10)
NAMES = ("amplitude", "frequency_Hz", "phase_rad", "noise_sd")


def _preview_stats(kind, delta, likelihood, window, seeds=SEEDS):
    """Frequency z-scores / interval hits and held-out coverage over seeds (Laplace preview)."""
    z, sd, outside, cover, noise = [], [], 0, [], []
    for seed in seeds:
        sc = ToyScenario(kind=kind, discrepancy=delta, likelihood=likelihood, window_s=window, seed=seed)
        data = simulate(sc)
        problem, _ = calibration_problem(sc, data)
        lap = preview(problem)
        s = lap.summary(seed=seed)
        f = s["frequency_Hz"]
        z.append((f["mean"] - 1.0) / f["sd"])
        sd.append(f["sd"])
        outside += not (f["q025"] <= 1.0 <= f["q975"])
        noise.append(s["noise_sd"]["mean"])
        held = data.held_out
        cover.append(lap.predict(data.time_s[held], n_draws=400, seed=seed).coverage(data.data[held]))
    return {"z": np.mean(z), "sd": np.mean(sd), "outside": outside, "coverage": np.mean(cover), "noise_sd": np.mean(noise)}


@pytest.mark.slow
def test_without_discrepancy_the_posterior_is_calibrated():
    """δ = 0: truth inside the 95 % interval for most seeds; prediction band covers ~95 %."""
    inside = {n: 0 for n in NAMES}
    coverage = []
    for seed in SEEDS:
        result = run_toy(ToyScenario(seed=seed))
        assert result.posterior.diagnostics.converged, result.posterior.diagnostics.warnings
        for n in NAMES:
            s = result.summary[n]
            inside[n] += s["q025"] <= result.truth[n] <= s["q975"]
        coverage.append(result.coverage95_prediction)
    # measured: inside = {amplitude: 10, frequency_Hz: 8, phase_rad: 10, noise_sd: 9}; coverage 0.937
    assert all(count >= 8 for count in inside.values()), inside
    assert 0.90 <= np.mean(coverage) <= 0.98, coverage


def test_drift_destroys_coverage_and_ar1_does_not_rescue_a_trend():
    """A baseline drift is absorbed into noise_sd in the window and then extrapolates badly."""
    clean = _preview_stats("drift", 0.0, "iid", 5.0, seeds=range(4))
    iid = _preview_stats("drift", 0.5, "iid", 5.0, seeds=range(4))
    ar1 = _preview_stats("drift", 0.5, "ar1", 5.0, seeds=range(4))
    # measured: coverage 0.94 clean -> 0.10 (iid) and 0.11 (ar1); noise_sd 0.10 -> 0.31
    assert clean["coverage"] > 0.9
    assert iid["coverage"] < 0.3
    assert iid["noise_sd"] > 2.5 * 0.1  # the estimated noise absorbs the drift
    assert ar1["coverage"] < 0.5  # a stationary error model cannot follow a trend out of the window
    assert ar1["coverage"] >= iid["coverage"] - 0.02


def test_tone_biases_frequency_with_overconfident_iid_intervals_and_ar1_restores_them():
    """Unmodelled second mode at 1.37 f: iid intervals exclude the true frequency at every window
    tried while their width shrinks; the AR(1) likelihood widens them and restores coverage."""
    iid = {w: _preview_stats("tone", 0.3, "iid", w) for w in (3.0, 5.0, 8.0)}
    ar1 = {w: _preview_stats("tone", 0.3, "ar1", w) for w in (3.0, 5.0, 8.0)}
    # measured (10 seeds): iid mean z = -2.9, -2.4, -2.3; truth outside 8, 8, 9 /10;
    # sd 0.0065 -> 0.0035 -> 0.0018 Hz; coverage 0.60, 0.78, 0.89.
    # ar1: mean z = -1.4, -1.4, -1.3; outside 1, 0, 0 /10; coverage 0.91, 0.92, 0.95.
    for w, i in iid.items():
        a = ar1[w]
        assert i["z"] < -2.0 and i["outside"] >= 7, (w, i)
        assert a["outside"] <= 2 and abs(a["z"]) < 1.7, (w, a)
        assert a["sd"] > 1.4 * i["sd"]
        assert a["coverage"] > i["coverage"] + 0.03
    # longer windows: the posterior sd shrinks 3.6x, the bias stays above two posterior sds
    assert iid[8.0]["sd"] < 0.35 * iid[3.0]["sd"]
    assert iid[8.0]["z"] < -2.0


def test_harmonic_distortion_coverage_iid_versus_ar1():
    """Distortion at 2 f: iid prediction bands under-cover on short windows; AR(1) restores them."""
    for w in (2.0, 3.0):
        iid = _preview_stats("harmonic", 0.3, "iid", w)
        ar1 = _preview_stats("harmonic", 0.3, "ar1", w)
        # measured: w=2: 0.84 -> 0.95; w=3: 0.87 -> 0.97
        assert iid["coverage"] < 0.9
        assert ar1["coverage"] > iid["coverage"] + 0.05
        assert 0.92 < ar1["coverage"] <= 1.0


@pytest.mark.slow
def test_mcmc_confirms_the_tone_damage_and_the_ar1_repair():
    iid = run_toy(ToyScenario(kind="tone", discrepancy=0.3, window_s=5.0, seed=0, target_ess=600))
    ar1 = run_toy(ToyScenario(kind="tone", discrepancy=0.3, window_s=5.0, seed=0, likelihood="ar1", target_ess=600))
    fi, fa = iid.summary["frequency_Hz"], ar1.summary["frequency_Hz"]
    # measured: iid 0.9888 ± 0.0038 Hz (truth outside), coverage 0.71; ar1 0.9896 ± 0.0063, coverage 0.93
    assert not fi["q025"] <= 1.0 <= fi["q975"]
    assert fa["q025"] <= 1.0 <= fa["q975"]
    assert fa["sd"] > 1.4 * fi["sd"]
    assert ar1.coverage95_prediction > iid.coverage95_prediction + 0.1
    assert ar1.summary["ar1_coefficient"]["mean"] > 0.5  # strongly correlated residuals


def test_window_sweep_shows_the_window_dependence():
    windows = [2.0, 5.0, 10.0]
    clean = np.array([[r["coverage95_prediction"] for r in sweep_windows(ToyScenario(seed=s), windows)] for s in range(4)])
    drift_rows = [sweep_windows(ToyScenario(seed=s, kind="drift", discrepancy=0.5), windows) for s in range(4)]
    drift = np.array([[r["coverage95_prediction"] for r in rows] for rows in drift_rows])
    # measured (mean of seeds 0-3): clean 0.98, 0.90, 0.95; drift 0.23, 0.09, 0.20
    assert np.all(clean.mean(axis=0) >= 0.85), clean
    assert np.all(drift.mean(axis=0) < 0.35), drift
    rmse_drift = np.array([[r["rmse_prediction"] for r in rows] for rows in drift_rows])
    assert np.all(rmse_drift > 1.0)  # vs ~0.1-0.3 du without the drift
