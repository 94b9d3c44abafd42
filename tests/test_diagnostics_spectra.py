"""Residual spectrum: Welch PSDs, residual peaks at known frequencies, per-mode power ratios."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.signal

from beam.errors import BeamInputError
from beam.residuals import default_nperseg, residual_spectrum

RATE = 1000.0
MODES = np.array([6.15, 38.5, 107.9, 211.5])


def record(n=4000, seed=0, residual_Hz=(37.3,), residual_m=(2e-5,)):
    """A 'model' of damped modes driven by noise-free sines; data = model + known residual tones + noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE
    model = sum(a * np.sin(2 * np.pi * f * t + k) for k, (f, a) in enumerate(zip(MODES, [1e-3, 3e-4, 1e-4, 5e-5])))
    residual = sum(a * np.sin(2 * np.pi * f * t + 0.4) for f, a in zip(residual_Hz, residual_m))
    return t, model + residual + rng.normal(0, 1e-6, n), model


def test_default_segment_lengths():
    assert [default_nperseg(n) for n in (100, 500, 1000, 4700, 10_000)] == [100, 256, 256, 1024, 2048]


def test_peak_at_the_known_residual_frequency():
    t, data, model = record()
    spectrum = residual_spectrum(t, data, model, MODES)
    top = spectrum.peaks[0]
    assert abs(top.frequency_Hz - 37.3) < 0.25 * spectrum.resolution_Hz
    assert top.nearest_mode == 2 and top.offset_from_mode == pytest.approx(37.3 / 38.5 - 1, abs=0.01)
    assert top.prominence_db > 20
    assert spectrum.nperseg == default_nperseg(4000) == 512 and spectrum.resolution_Hz == pytest.approx(RATE / 512)
    # the residual lives near mode 2 only: residual/data power is large there, tiny elsewhere
    ratios = {m.mode: m.ratio for m in spectrum.modes}
    assert ratios[2] > 1e-3 and ratios[1] < 1e-6 and ratios[3] < 1e-4 and ratios[4] < 1e-3
    assert spectrum.residual_power_fraction == pytest.approx(0.5 * 2e-5**2 / np.var(data), rel=0.05)
    json.dumps(spectrum.to_dict())


def test_two_residual_tones_are_ranked_by_power():
    t, data, model = record(residual_Hz=(18.45, 150.0), residual_m=(1e-5, 3e-5))
    spectrum = residual_spectrum(t, data, model, MODES, max_peaks=3)
    assert spectrum.peak_frequencies_Hz[:2] == pytest.approx([150.0, 18.45], abs=0.3)
    assert spectrum.peaks[1].nearest_mode == 1 and spectrum.peaks[1].offset_from_mode == pytest.approx(2.0, abs=0.1)


def test_psd_settings_match_for_residual_and_data():
    t, data, model = record(n=2000)
    spectrum = residual_spectrum(t, data, model)
    df = spectrum.resolution_Hz
    # the documented Welch settings, for data and residual alike
    settings = {"fs": RATE, "window": "hann", "nperseg": 256, "noverlap": 128, "detrend": "constant"}
    np.testing.assert_allclose(spectrum.data_psd_m2_Hz, scipy.signal.welch(data, **settings)[1])
    np.testing.assert_allclose(spectrum.residual_psd_m2_Hz, scipy.signal.welch(data - model, **settings)[1])
    # Parseval for the residual (a 37 Hz tone in white noise): the PSD integrates to its variance
    assert spectrum.residual_psd_m2_Hz.sum() * df == pytest.approx(np.var(data - model), rel=0.05)
    assert spectrum.modes == () and spectrum.peaks[0].nearest_mode == 0 and np.isnan(spectrum.peaks[0].offset_from_mode)
    assert spectrum.frequency_Hz.shape == spectrum.data_psd_m2_Hz.shape == spectrum.residual_psd_m2_Hz.shape


def test_modes_above_nyquist_are_skipped():
    t, data, model = record(n=1000)
    spectrum = residual_spectrum(t, data, model, [6.15, 38.5, 800.0])
    assert [m.mode for m in spectrum.modes] == [1, 2]


def test_bad_inputs():
    t, data, model = record(n=1000)
    with pytest.raises(BeamInputError, match="too short"):
        residual_spectrum(t[:50], data[:50], model[:50])
    with pytest.raises(BeamInputError, match="NaN"):
        residual_spectrum(t, np.where(t > 0.5, np.nan, data), model)
    with pytest.raises(BeamInputError, match="constant"):
        residual_spectrum(t, np.ones_like(t), model)
    with pytest.raises(BeamInputError, match="model_frequencies_Hz"):
        residual_spectrum(t, data, model, [6.0, -1.0])
    with pytest.raises(BeamInputError, match="nperseg"):
        residual_spectrum(t, data, model, nperseg=5000)
