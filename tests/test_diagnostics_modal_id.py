"""Free-decay modal identification (matrix pencil) against known modes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from beam.errors import BeamInputError
from beam.io.config import load_config
from beam.io.simulation import simulate
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel
from beam.residuals import (
    compare_modes,
    free_decay_start,
    identify_modes,
    matrix_pencil_poles,
)

ROOT = Path(__file__).resolve().parents[1]
RATE = 1000.0
FREQUENCIES = np.array([6.15, 38.5, 107.9, 211.5])
DAMPING = np.array([0.002, 0.003, 0.005, 0.01])
AMPLITUDES = np.array([1e-3, 5e-4, 3e-4, 2e-4])
PHASES = np.array([0.3, 1.0, 2.0, -1.0])
GEOMETRY = BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.27438)
BASE = {"bending_stiffness_Nm2": 0.491, "patch_coupling_NmV": 1.746e-2, "air_damping_Ns_m2": 0.013,
        "kelvin_voigt_Nm2s": 0.649e-5}


def damped_sinusoids(t):
    omega = 2 * np.pi * FREQUENCIES
    phase = omega * np.sqrt(1 - DAMPING**2) * t[:, None] + PHASES
    return (AMPLITUDES * np.exp(-DAMPING * omega * t[:, None]) * np.cos(phase)).sum(axis=1)


def test_noise_free_sum_of_damped_sinusoids_is_recovered_exactly():
    t = np.arange(2000) / RATE
    result = identify_modes(t, damped_sinusoids(t), start_s=0.0)
    np.testing.assert_allclose(result.frequency_Hz, FREQUENCIES, rtol=1e-8)
    np.testing.assert_allclose(result.damping_ratio, DAMPING, rtol=1e-6)
    np.testing.assert_allclose(result.amplitude_m, AMPLITUDES, rtol=1e-6)
    np.testing.assert_allclose(result.phase_rad, PHASES, atol=1e-6)
    np.testing.assert_allclose(result.reconstruct(t), damped_sinusoids(t), atol=1e-12)
    assert result.order == 8 and result.fit_rms_m < 1e-12


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_damped_sinusoids_at_40_dB(seed):
    """Frequencies within 0.5 %, damping within 10 % at an SNR of 40 dB (3 s at 1 kHz)."""
    t = np.arange(3000) / RATE
    clean = damped_sinusoids(t)
    noise = np.sqrt(np.mean(clean**2)) * 10 ** (-40 / 20)
    result = identify_modes(t, clean + np.random.default_rng(seed).normal(0, noise, t.size), start_s=0.0)
    assert result.frequency_Hz.size == 4
    assert np.all(np.abs(result.frequency_Hz / FREQUENCIES - 1) < 0.005)
    assert np.all(np.abs(result.damping_ratio / DAMPING - 1) < 0.10)
    assert np.all(np.abs(result.amplitude_m / AMPLITUDES - 1) < 0.05)
    assert result.fit_rms_m == pytest.approx(noise, rel=0.1)
    assert np.all(result.snr_db > 20)


def test_the_decay_starts_after_the_voltage_stops():
    t = np.arange(3000) / RATE
    voltage = np.where(t < 0.25, 1.0, 0.0)
    assert free_decay_start(t, voltage) == 250
    assert free_decay_start(t, start_s=0.5) == 500
    assert free_decay_start(t, np.zeros_like(t)) == 0
    shifted = np.r_[np.zeros(250), damped_sinusoids(t[:2750])] + np.where(t < 0.25, 5.0, 0.0)
    result = identify_modes(t, shifted, voltage)
    assert result.start_s == pytest.approx(0.25) and result.n_samples == 2750
    np.testing.assert_allclose(result.frequency_Hz, FREQUENCIES, rtol=1e-6)


@pytest.fixture(scope="module")
def chirp_record():
    config = load_config(ROOT / "assets" / "b1tapih.toml")
    simulation = simulate(config)  # all modes, noise 1.2e-5 m (1 % of the RMS), chirp for 1.5 s then free decay
    model = BeamModel(config.geometry, config.effects, config.intervals, config.knots)
    return simulation, model.natural_modes(config.parameters, 6)


def test_beam_model_chirp_record_gives_the_model_modes(chirp_record):
    simulation, (frequencies, damping) = chirp_record
    result = identify_modes(simulation.time_s, simulation.displacement_m, simulation.voltage_V)
    assert result.start_s == pytest.approx(1.5)
    rows = compare_modes(result, frequencies, damping)
    for row in rows[:3]:
        assert row.matched
        assert abs(row.frequency_error_pct) < 0.5
        assert abs(row.damping_error_pct) < 15
    json.dumps(result.to_dict(arrays=True))


def test_beam_model_pulse_record_gives_four_modes():
    t = np.arange(3000) / RATE
    voltage = np.zeros_like(t)
    voltage[:3] = 20.0
    model = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"])
    clean = model.response(BASE, voltage, 1 / RATE, modes=6)
    data = clean + np.random.default_rng(1).normal(0, 0.01 * clean.std(), t.size)
    frequencies, damping = model.natural_modes(BASE, 6)
    rows = compare_modes(identify_modes(t, data, voltage), frequencies, damping)
    assert [row.matched for row in rows] == [True] * 4 + [False] * 2
    assert max(abs(row.frequency_error_pct) for row in rows[:4]) < 0.1
    assert max(abs(row.damping_error_pct) for row in rows[:3]) < 5
    assert abs(rows[3].damping_error_pct) < 15


def test_compare_modes_matches_by_nearest_frequency():
    identified = ([39.0, 6.0, 500.0, 110.0], [0.003, 0.002, 0.01, 0.004])
    rows = compare_modes(identified, [6.15, 38.5, 107.9, 211.5], [0.0021, 0.0019, 0.0046, 0.0088])
    assert [row.mode for row in rows] == [1, 2, 3, 4]
    assert [row.frequency_data_Hz for row in rows[:3]] == [6.0, 39.0, 110.0]
    assert rows[0].frequency_error_pct == pytest.approx(100 * (6.0 / 6.15 - 1))
    assert rows[1].damping_error_pct == pytest.approx(100 * (0.003 / 0.0019 - 1))
    assert not rows[3].matched and np.isnan(rows[3].frequency_error_pct)  # 500 Hz is too far from 211.5 Hz
    rigid = compare_modes(identified, [0.0, 6.15], [0.0, 0.002])
    assert [(row.mode, row.frequency_data_Hz) for row in rigid] == [(1, 6.0)]


def test_pencil_order_from_singular_values():
    t = np.arange(1000) / RATE
    y = damped_sinusoids(t) + np.random.default_rng(0).normal(0, 1e-6, t.size)
    poles, singular, order = matrix_pencil_poles(y)
    assert order == 8 and poles.size == 8 and singular[0] == singular.max()
    assert matrix_pencil_poles(y, order=4)[2] == 4


def test_bad_inputs():
    t = np.arange(3000) / RATE
    y = damped_sinusoids(t)
    with pytest.raises(BeamInputError, match="no free decay"):
        identify_modes(t, y, np.ones_like(t))
    with pytest.raises(BeamInputError, match="free decay too short"):
        identify_modes(t, y, np.where(t < 2.95, 1.0, 0.0))
    with pytest.raises(BeamInputError, match="voltage_V .* or start_s"):
        identify_modes(t, y)
    with pytest.raises(BeamInputError, match="NaN"):
        identify_modes(t, np.where(t > 1, np.nan, y), start_s=0.0)
    with pytest.raises(BeamInputError, match="no vibration mode"):
        identify_modes(t, np.random.default_rng(0).normal(size=t.size), start_s=0.0)
    with pytest.raises(BeamInputError, match="constant"):
        identify_modes(t, np.zeros_like(t), start_s=0.0)
    with pytest.raises(BeamInputError, match="same length"):
        compare_modes(([1.0, 2.0], [0.1]), [1.0], [0.1])
