"""The amplitude-frequency estimate (backbone) against an independent short-time spectral
estimate of the mode's frequency, early against late in the decay."""

from __future__ import annotations

import glob

import numpy as np
import pytest
from scipy import signal

import beam.residuals as dx
from beam.io.measurement import read_measurement
from beam.residuals.envelope import DRIFT_AGREEMENT, DRIFT_FLOOR


def stft_drift(t: np.ndarray, y: np.ndarray, f0: float, start: float, stop: float) -> float:
    """(f_early - f_late) / f_late from scipy's STFT: frames of 3 s (or a third of the stretch),
    the peak near ``f0`` of each frame refined by a parabola through its power, a straight line
    through the peak frequencies against the frame centres, read at the centres of the first and
    last thirds of [start, stop]."""
    fs = 1.0 / float(np.median(np.diff(t)))
    inside = (t >= start) & (t <= stop)
    nperseg = int(min(3.0, (stop - start) / 3) * fs)
    freq, centres, z = signal.stft(y[inside], fs=fs, window="blackman", nperseg=nperseg,
                                   noverlap=nperseg * 3 // 4, nfft=32 * nperseg, detrend="linear", boundary=None)
    power = np.abs(z) ** 2
    band = np.flatnonzero(np.abs(freq - f0) < 0.2 * f0)
    peaks = []
    for column in power.T:
        k = band[np.argmax(column[band])]
        a, b, c = np.log(column[k - 1: k + 2])
        peaks.append(freq[k] + 0.5 * (a - c) / (a - 2 * b + c) * (freq[1] - freq[0]))
    slope, intercept = np.polyfit(centres, peaks, 1)
    third = (stop - start) / 3
    early, late = intercept + slope * third / 2, intercept + slope * (stop - start - third / 2)
    return float((early - late) / late)


def _uniform(path):
    m = read_measurement(path)
    step = float(np.median(np.diff(m.time_s)))
    grid = m.time_s[0] + step * np.arange(int((m.time_s[-1] - m.time_s[0]) / step) + 1)
    return m, grid, np.interp(grid, m.time_s, m.output)


def _backbone_drift(analysis) -> float:
    """The backbone's frequency change between the mean amplitudes of the envelope's first and last thirds."""
    e, bb = analysis.envelope, analysis.backbone
    third = (e.time_s[-1] - e.time_s[0]) / 3
    a_early = e.envelope_m[e.time_s < e.time_s[0] + third].mean()
    a_late = e.envelope_m[e.time_s >= e.time_s[-1] - third].mean()
    return bb.slope_Hz_per_m * (a_early - a_late) / (bb.intercept_Hz + bb.slope_Hz_per_m * a_late)


def _agree(a: float, b: float) -> bool:
    return (abs(a) < DRIFT_FLOOR and abs(b) < DRIFT_FLOOR) or 1 / DRIFT_AGREEMENT <= a / b <= DRIFT_AGREEMENT


@pytest.mark.parametrize("path", sorted(glob.glob("assets/real/*.csv")))
def test_real_strip_drift_agrees_with_the_stft_or_is_unknown(path):
    m, t, y = _uniform(path)
    f1 = float(dx.identify_modes(t[::4], y[::4], None, start_s=float(t[0])).frequency_Hz[0])
    analysis = dx.analyse_mode(t, y, f1, None, start_s=float(t[0]))
    e = analysis.envelope
    reference = stft_drift(t, y, f1, float(e.time_s[0]), float(e.time_s[-1]))
    assert abs(reference) < 0.01  # a real strip drifts by a few tenths of a percent, never by 257 %
    if analysis.backbone.reliable:
        assert _agree(_backbone_drift(analysis), reference), (_backbone_drift(analysis), reference)
        assert abs(analysis.backbone.relative_shift) < 0.02
    else:
        fp = dx.fingerprints([], backbone=analysis.backbone)
        assert np.isnan(fp["amplitude_frequency_shift"])  # reported as unknown


@pytest.mark.parametrize("name", [f"lab_run_{i}" for i in range(1, 6)])
def test_bundled_lab_runs_drift_agrees_or_is_unknown(name):
    m = read_measurement(f"assets/measurements/{name}.csv")
    ident = dx.identify_modes(m.time_s, m.output, m.input)
    analysis = dx.analyse_mode(m.time_s, m.output, float(ident.frequency_Hz[0]), m.input)
    e = analysis.envelope
    if not analysis.backbone.reliable:
        return
    reference = stft_drift(m.time_s, m.output, e.centre_frequency_Hz, float(e.time_s[0]), float(e.time_s[-1]))
    assert _agree(_backbone_drift(analysis), reference), (name, _backbone_drift(analysis), reference)


def test_the_hardening_spring_record_keeps_its_backbone():
    """lab_run_4 is simulated with a hardening tip spring: its backbone stays reliable and hardening."""
    m = read_measurement("assets/measurements/lab_run_4.csv")
    ident = dx.identify_modes(m.time_s, m.output, m.input)
    bb = dx.analyse_mode(m.time_s, m.output, float(ident.frequency_Hz[0]), m.input).backbone
    assert bb.reliable and bb.verdict == "hardening" and bb.relative_shift > 0.01


def test_a_decay_with_a_known_softening_drift():
    """A decay whose frequency rises 0.4 % as the amplitude dies (f = f0 (1 - k A)), plus noise."""
    fs, f0 = 1000.0, 6.0
    t = np.arange(int(20 * fs)) / fs
    amplitude = np.exp(-0.12 * t)
    k = 0.004 / (amplitude[0] - amplitude[-1])
    phase = 2 * np.pi * np.cumsum(f0 * (1 - k * amplitude)) / fs
    y = amplitude * np.sin(phase) + 1e-3 * np.random.default_rng(2).standard_normal(t.size)
    analysis = dx.analyse_mode(t, y, f0, None, start_s=0.0)
    assert analysis.backbone.reliable and analysis.backbone.verdict == "softening"
    e = analysis.envelope
    reference = stft_drift(t, y, f0, float(e.time_s[0]), float(e.time_s[-1]))
    truth = -k * (np.interp(e.time_s[0] + (e.time_s[-1] - e.time_s[0]) / 6, t, amplitude)
                  - np.interp(e.time_s[-1] - (e.time_s[-1] - e.time_s[0]) / 6, t, amplitude))
    assert reference == pytest.approx(truth, rel=0.3)
    assert _agree(_backbone_drift(analysis), reference)


def test_a_noise_peak_gives_no_backbone_shift():
    """Band-passed around a frequency where only noise and a weak harmonic are, the backbone must
    not report a shift: unreliable (the shift unknown) or below the floor."""
    fs = 1000.0
    t = np.arange(int(10 * fs)) / fs
    rng = np.random.default_rng(3)
    y = np.exp(-0.3 * t) * np.sin(2 * np.pi * 16.3 * t) + 0.02 * rng.standard_normal(t.size)
    try:
        bb = dx.analyse_mode(t, y, 2.0, None, start_s=0.0).backbone  # a spurious low pole at 2 Hz
    except Exception:  # noqa: BLE001 - refusing to measure is an answer too
        return
    fp = dx.fingerprints([], backbone=bb)
    assert not bb.reliable or abs(fp["amplitude_frequency_shift"]) < 0.01
