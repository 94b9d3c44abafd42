"""Envelope, instantaneous frequency, backbone and decay law of one mode in the free decay."""

from __future__ import annotations

import json

import numpy as np
import pytest

from beam.errors import BeamInputError
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel
from beam.residuals import (
    analyse_mode,
    backbone,
    decay_law,
    extrapolate,
    mode_envelope,
)

RATE = 1000.0
GEOMETRY = BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.27438)
#: More air damping than the published beam, so that mode 1 decays tenfold in 3 s.
DAMPED = {"bending_stiffness_Nm2": 0.491, "patch_coupling_NmV": 1.746e-2, "air_damping_Ns_m2": 0.1,
          "kelvin_voigt_Nm2s": 0.649e-5}


def release(volts: float, n: int = 4000) -> np.ndarray:
    """Ramp the voltage up smoothly over 0.5 s, hold it 0.3 s, switch it off: the beam rings down from a static bend."""
    voltage = np.zeros(n)
    ramp = int(0.5 * RATE)
    voltage[:ramp] = volts * 0.5 * (1 - np.cos(np.pi * np.arange(ramp) / ramp))
    voltage[ramp : ramp + int(0.3 * RATE)] = volts
    return voltage


def ring_down(cubic_N_m3: float, volts: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    effects = ["air_damping", "kelvin_voigt"] + (["tip_cubic_spring"] if cubic_N_m3 > 0 else [])
    parameters = dict(DAMPED, **({"tip_cubic_stiffness_N_m3": cubic_N_m3} if cubic_N_m3 > 0 else {}))
    voltage = release(volts)
    clean = BeamModel(GEOMETRY, effects).response(parameters, voltage, 1 / RATE, modes=4)
    noise = 0.01 * clean[800:].std()
    t = np.arange(voltage.size) / RATE
    return t, clean + np.random.default_rng(seed).normal(0, noise, t.size), voltage


def test_extrapolation_continues_damped_sinusoids():
    t = np.arange(600) / RATE
    y = np.exp(-2 * t) * np.cos(2 * np.pi * 20 * t) + 0.3 * np.exp(-5 * t) * np.sin(2 * np.pi * 90 * t)
    future = np.arange(600, 800) / RATE
    expected = np.exp(-2 * future) * np.cos(2 * np.pi * 20 * future) + 0.3 * np.exp(-5 * future) * np.sin(
        2 * np.pi * 90 * future)
    np.testing.assert_allclose(extrapolate(y, 200, order=8), expected, atol=1e-8)
    grow = extrapolate(np.exp(0.01 * np.arange(100.0)) * np.cos(0.3 * np.arange(100.0)), 500, order=2)
    assert np.abs(grow).max() < 10  # a growing series is continued without growth


def test_envelope_of_a_single_damped_sinusoid():
    t = np.arange(3000) / RATE
    sigma, f_d = 0.8, 12.0
    y = 2e-3 * np.exp(-sigma * t) * np.cos(2 * np.pi * f_d * t + 0.4)
    envelope = mode_envelope(t, y, 12.0, start_s=0.0)
    np.testing.assert_allclose(envelope.envelope_m, 2e-3 * np.exp(-sigma * envelope.time_s), rtol=5e-3)
    np.testing.assert_allclose(envelope.frequency_Hz, f_d, rtol=2e-3)
    decay = decay_law(envelope)
    assert decay.decay_rate_1_s == pytest.approx(sigma, rel=5e-3)
    assert decay.damping_ratio == pytest.approx(sigma / (2 * np.pi * f_d), rel=5e-3)
    assert decay.r_squared > 0.9999 and abs(decay.decay_rate_change) < 0.02
    np.testing.assert_allclose(decay.damping_ratio_by_amplitude, sigma / (2 * np.pi * f_d), rtol=0.03)
    assert envelope.time_s[0] == pytest.approx(1 / 12.0, abs=2e-3)  # one period trimmed


def test_linear_beam_has_a_flat_backbone_and_a_straight_log_envelope():
    t, y, voltage = ring_down(0.0, 5.0)
    analysis = analyse_mode(t, y, 6.15, voltage)
    frequencies, damping = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"]).natural_modes(DAMPED, 1)
    assert analysis.backbone.verdict == "linear"
    assert abs(analysis.backbone.relative_shift) < 1e-3
    assert analysis.backbone.intercept_Hz == pytest.approx(frequencies[0], rel=1e-3)
    assert analysis.decay.r_squared > 0.999 and analysis.decay.rms_log_residual < 0.005
    assert abs(analysis.decay.decay_rate_change) < 0.05
    assert analysis.decay.damping_ratio == pytest.approx(damping[0], rel=0.02)
    assert analysis.envelope.start_s == pytest.approx(0.8)
    json.dumps(analysis.to_dict(arrays=True))


def test_cubic_tip_spring_hardens_the_backbone():
    """k3 = 1e7 N/m³: mode 1 starts about 7 % above its linear frequency and falls back as it decays."""
    t, y, voltage = ring_down(1e7, 1.2)
    analysis = analyse_mode(t, y, 6.15, voltage)
    b = analysis.backbone
    assert b.verdict == "hardening"
    assert b.relative_shift > 0.03 and b.slope_Hz_per_m > 0 and b.slope_Hz_per_m > 5 * b.slope_stderr_Hz_per_m
    assert b.frequency_Hz[-1] > 1.04 * 6.148  # top amplitude bin
    assert b.frequency_at_zero_amplitude_Hz == pytest.approx(6.148, rel=0.01) and b.duffing_Hz_per_m2 > 0
    assert np.all(np.diff(b.frequency_Hz) > 0)


def test_bad_inputs():
    t, y, voltage = ring_down(0.0, 5.0)
    with pytest.raises(BeamInputError, match="does not fit"):
        mode_envelope(t, y, 700.0, voltage)
    with pytest.raises(BeamInputError, match="frequency_Hz must be a positive number"):
        mode_envelope(t, y, -6.0, voltage)
    with pytest.raises(BeamInputError, match="free decay too short for a 6.15 Hz envelope"):
        mode_envelope(t, y, 6.15, start_s=3.8)
    with pytest.raises(BeamInputError, match="no free decay"):
        mode_envelope(t, y, 6.15, np.ones_like(t))
    with pytest.raises(BeamInputError, match="NaN"):
        mode_envelope(t, np.where(t > 2, np.nan, y), 6.15, voltage)
    with pytest.raises(BeamInputError, match="nothing rings"):
        mode_envelope(t, np.zeros_like(t), 6.15, voltage)
    envelope = mode_envelope(t, y, 6.15, voltage)
    with pytest.raises(BeamInputError, match="bins"):
        backbone(envelope, bins=1)
