"""Residuals against the prediction band, window scores, autocorrelation and the Ljung–Box test."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.stats

from beam.errors import BeamInputError
from beam.residuals import (
    autocorrelation,
    band_residuals,
    default_max_lag,
    jsonable,
    ljung_box,
    residual_whiteness,
    window_scores,
)

DT = 0.01


def constructed():
    """100 samples, band ±1 about a zero mean, with known excursions."""
    time = np.arange(100) * DT
    data = np.zeros(100)
    data[10:13] = [1.2, 1.5, 1.1]  # above, max excess 0.5
    data[14] = 1.3  # above after a 1-sample gap: merged with the run above
    data[40:42] = [-3.0, -2.0]  # below, max excess 2.0
    data[60] = 1.0  # on the edge: inside
    data[80] = 1.4  # above, then below 3 samples later: separate with merge_gap 3
    data[84] = -1.2
    mean = np.zeros(100)
    return time, data, mean, mean - 1.0, mean + 1.0


def test_exceedance_intervals_of_a_constructed_record():
    result = band_residuals(*constructed())
    spans = [(i.start_s, i.end_s, i.n_samples, i.n_outside, i.side) for i in result.intervals]
    assert spans == [
        (pytest.approx(0.10), pytest.approx(0.14), 5, 4, "above"),
        (pytest.approx(0.40), pytest.approx(0.41), 2, 2, "below"),
        (pytest.approx(0.80), pytest.approx(0.80), 1, 1, "above"),
        (pytest.approx(0.84), pytest.approx(0.84), 1, 1, "below"),
    ]
    assert [i.max_excess_m for i in result.intervals] == pytest.approx([0.5, 2.0, 0.4, 0.2])
    assert result.outside.sum() == 8 and not result.outside[60]
    assert result.coverage == pytest.approx(0.92)
    assert result.excess_m[41] == pytest.approx(1.0)
    np.testing.assert_allclose(result.residual_m, constructed()[1])


def test_merge_gap_controls_merging():
    time, data, mean, lower, upper = constructed()
    assert len(band_residuals(time, data, mean, lower, upper, merge_gap=0).intervals) == 5
    merged = band_residuals(time, data, mean, lower, upper, merge_gap=4).intervals
    assert [(i.start_s, i.end_s, i.side) for i in merged][-1] == (pytest.approx(0.80), pytest.approx(0.84), "both")


def test_intervals_at_the_record_ends_and_none_outside():
    time = np.arange(10) * DT
    data = np.array([2.0, 0, 0, 0, 0, 0, 0, 0, 0, -2.0])
    result = band_residuals(time, data, np.zeros(10), -np.ones(10), np.ones(10))
    assert [(i.start_s, i.end_s) for i in result.intervals] == [(0.0, 0.0), (pytest.approx(0.09), pytest.approx(0.09))]
    quiet = band_residuals(time, np.zeros(10), np.zeros(10), -np.ones(10), np.ones(10))
    assert quiet.intervals == () and quiet.coverage == 1.0
    json.dumps(result.to_dict(arrays=True))


def test_window_scores_split_calibration_and_prediction():
    time = np.arange(200) * DT
    residual = np.where(np.arange(200) % 2 == 0, 0.1, -0.1)
    residual[100:] = 0.3
    mean = np.sin(time)
    scores = window_scores(time, mean + residual, mean, (0.0, 0.995), mean - 0.2, mean + 0.2)
    assert scores.calibration.n_samples == 100 and scores.prediction.n_samples == 100
    assert scores.calibration.rmse_m == pytest.approx(0.1)
    assert scores.prediction.rmse_m == pytest.approx(0.3)
    assert scores.prediction.bias_m == pytest.approx(0.3)
    assert scores.rmse_ratio == pytest.approx(3.0)
    assert scores.calibration.coverage == 1.0 and scores.prediction.coverage == 0.0
    no_band = window_scores(time, mean + residual, mean, (0.5, 1.0))
    assert np.isnan(no_band.calibration.coverage)
    assert no_band.prediction.n_samples == 149  # before and after the window
    json.dumps(scores.to_dict())


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda a: a.__setitem__(1, a[1].copy() * np.nan), "NaN"),
        (lambda a: a.__setitem__(2, a[2][:-1]), "samples but time_s has"),
        (lambda a: a.__setitem__(3, a[4] + 1), "inverted"),
        (lambda a: a.__setitem__(0, a[0] ** 2), "uniformly sampled"),
        (lambda a: a.__setitem__(1, a[1].reshape(10, 10)), "1-d"),
    ],
)
def test_bad_band_inputs(change, message):
    arrays = list(constructed())
    change(arrays)
    with pytest.raises(BeamInputError, match=message):
        band_residuals(*arrays)


def test_bad_windows():
    time, data, mean, lower, _upper = constructed()
    with pytest.raises(BeamInputError, match="holds 0 samples"):
        window_scores(time, data, mean, (5.0, 6.0))
    with pytest.raises(BeamInputError, match="start_s < end_s"):
        window_scores(time, data, mean, (0.5, 0.2))
    with pytest.raises(BeamInputError, match="both lower_m and upper_m"):
        window_scores(time, data, mean, (0.0, 0.5), lower)


# ---------------------------------------------------------------- autocorrelation and Ljung–Box
def test_autocorrelation_and_ljung_box_by_hand():
    x = np.array([1.0, 3.0, 2.0, 5.0, 4.0, 4.0, 6.0, 3.0, 2.0, 5.0, 1.0, 0.0])
    n, m = x.size, x.mean()
    r = [sum((x[t] - m) * (x[t + k] - m) for t in range(n - k)) / sum((x - m) ** 2) for k in range(4)]
    np.testing.assert_allclose(autocorrelation(x, 3), r, atol=1e-12)
    q_hand = n * (n + 2) * sum(r[k] ** 2 / (n - k) for k in (1, 2, 3))
    q, p = ljung_box(x, 3)
    assert q == pytest.approx(q_hand, rel=1e-12)
    assert p == pytest.approx(scipy.stats.chi2.sf(q_hand, 3), rel=1e-12)
    _, p_fitted = ljung_box(x, 3, fitted_parameters=1)
    assert p_fitted == pytest.approx(scipy.stats.chi2.sf(q_hand, 2), rel=1e-12)


def test_ljung_box_size_under_white_noise():
    """p-values uniform, rejection rate about 5 % at 0.05 (2000 series of 500 samples)."""
    rng = np.random.default_rng(2024)
    p_values = np.array([ljung_box(rng.normal(size=500), 20)[1] for _ in range(2000)])
    rate = np.mean(p_values < 0.05)
    assert 0.035 < rate < 0.065, rate  # binomial sd 0.5 %
    assert scipy.stats.kstest(p_values, "uniform").pvalue > 0.01


def test_ljung_box_power_against_ar1():
    rng = np.random.default_rng(7)
    rejected = []
    for _ in range(200):
        e = rng.normal(size=500)
        x = np.empty(500)
        x[0] = e[0]
        for t in range(1, 500):
            x[t] = 0.3 * x[t - 1] + e[t]
        rejected.append(ljung_box(x, 20)[1] < 0.05)
    assert np.mean(rejected) > 0.95


def test_residual_whiteness_fields():
    rng = np.random.default_rng(3)
    white = residual_whiteness(rng.normal(size=1000) * 1e-5, sample_interval_s=1e-3)
    assert white.lags.size == default_max_lag(1000) == 30
    assert white.band == pytest.approx(1.96 / np.sqrt(1000))
    assert white.fraction_outside <= 0.15 and white.white
    assert white.lag_s[0] == pytest.approx(1e-3)
    t = np.arange(1000) * 1e-3
    coloured = residual_whiteness(1e-5 * np.sin(2 * np.pi * 12 * t) + rng.normal(size=1000) * 1e-6)
    assert not coloured.white and coloured.p_value < 1e-10 and coloured.fraction_outside > 0.5
    assert np.isnan(coloured.lag_s[0])
    json.dumps(jsonable(coloured.to_dict(arrays=True)))


def test_whiteness_bad_inputs():
    with pytest.raises(BeamInputError, match="too short"):
        residual_whiteness(np.ones(10))
    with pytest.raises(BeamInputError, match="constant"):
        residual_whiteness(np.ones(100))
    with pytest.raises(BeamInputError, match="NaN"):
        residual_whiteness(np.r_[np.zeros(50), np.nan, np.zeros(50)])
    with pytest.raises(BeamInputError, match="max_lag"):
        residual_whiteness(np.arange(100.0) % 7, max_lag=100)
