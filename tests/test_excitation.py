"""Excitation signals against their closed forms, sampled as the zero-order hold sees them."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from beam.errors import BeamInputError
from beam.physics.excitation import Excitation

RATE_HZ = 1000.0
TIME_S = np.arange(2000) / RATE_HZ  # t_k = k / rate, the grid simulations use


def test_pulse_sample_values_and_edge_at_width():
    pulse = Excitation("pulse", amplitude_V=3.5, width_s=0.01)
    voltage = pulse.voltage(TIME_S)
    # 0 <= t < width: exactly 10 samples (k = 0..9) at 1 kHz, t = width itself is off
    np.testing.assert_array_equal(voltage[:10], 3.5)
    np.testing.assert_array_equal(voltage[10:], 0.0)
    assert pulse.voltage(0.01) == 0.0
    assert pulse.voltage(np.nextafter(0.01, 0.0)) == 3.5
    assert pulse.voltage(-1e-12) == 0.0
    assert pulse.end_s == 0.01


def test_burst_matches_closed_form_and_stops_after_cycles():
    burst = Excitation("burst", amplitude_V=2.0, frequency_Hz=40.0, cycles=3)
    voltage = burst.voltage(TIME_S)
    end = 3 / 40.0
    expected = np.where(TIME_S < end, 2.0 * np.sin(2 * np.pi * 40.0 * TIME_S), 0.0)
    np.testing.assert_allclose(voltage, expected, rtol=0, atol=1e-13)
    assert np.count_nonzero(TIME_S < end) == 75
    assert voltage[74] != 0.0 and np.all(voltage[75:] == 0.0)
    # a quarter period in: the crest
    assert burst.voltage(1 / 160.0) == pytest.approx(2.0, abs=1e-15)


def test_chirp_matches_closed_form_and_instantaneous_frequency():
    chirp = Excitation("chirp", amplitude_V=10.0, start_Hz=2.0, stop_Hz=250.0, duration_s=1.5)
    voltage = chirp.voltage(TIME_S)
    t = TIME_S
    expected = np.where(t < 1.5, 10.0 * np.sin(2 * np.pi * (2.0 * t + (250.0 - 2.0) * t**2 / (2 * 1.5))), 0.0)
    np.testing.assert_allclose(voltage, expected, rtol=0, atol=1e-10)
    assert np.count_nonzero(voltage[1500:]) == 0 and np.count_nonzero(voltage[:1500]) > 1400
    # phase(t) = f0 t + (f1 - f0) t²/(2T): its slope is f0 at t = 0 and f1 at t = T
    phase = lambda s: 2.0 * s + 248.0 * s**2 / 3.0  # noqa: E731
    h = 1e-6
    assert (phase(h) - phase(0)) / h == pytest.approx(2.0, rel=1e-4)
    assert (phase(1.5) - phase(1.5 - h)) / h == pytest.approx(250.0, rel=1e-4)
    assert np.max(np.abs(voltage)) <= 10.0


def test_downward_chirp_is_allowed():
    chirp = Excitation("chirp", amplitude_V=1.0, start_Hz=100.0, stop_Hz=10.0, duration_s=0.5)
    t = np.array([0.0, 0.1, 0.49, 0.5])
    expected = np.sin(2 * np.pi * (100.0 * t - 90.0 * t**2 / 1.0))
    expected[-1] = 0.0
    np.testing.assert_allclose(chirp.voltage(t), expected, atol=1e-12)


def test_recorded_voltage_is_held_per_sample_and_zero_after():
    recorded = np.array([1.0, -2.0, 3.0, 0.5])
    excitation = Excitation.from_recording(recorded, 0.002, file="lab.csv")
    # the simulation grid may be finer than the recording: each value is held for 2 ms
    t = np.arange(10) / 1000.0
    np.testing.assert_array_equal(excitation.voltage(t), [1, 1, -2, -2, 3, 3, 0.5, 0.5, 0, 0])
    # same grid as the recording: sample k exactly, even when k dt rounds a hair low
    t_same = np.arange(4) * 0.002
    np.testing.assert_array_equal(excitation.voltage(t_same), recorded)
    assert excitation.voltage(-0.001) == 0.0
    assert excitation.end_s == pytest.approx(0.008)


@settings(max_examples=50, deadline=None)
@given(
    amplitude=st.floats(1e-3, 1e3),
    width=st.floats(1e-4, 1.0),
    rate=st.sampled_from([100.0, 1000.0, 2048.0, 10000.0]),
)
def test_pulse_holds_amplitude_on_exactly_the_samples_before_width(amplitude, width, rate):
    t = np.arange(int(2 * width * rate) + 5) / rate
    voltage = Excitation("pulse", amplitude_V=amplitude, width_s=width).voltage(t)
    np.testing.assert_array_equal(voltage, np.where(t < width, amplitude, 0.0))
    assert voltage.shape == t.shape


def test_voltage_keeps_the_shape_of_time():
    pulse = Excitation("pulse", amplitude_V=1.0, width_s=0.5)
    assert pulse.voltage(np.zeros((2, 3))).shape == (2, 3)
    assert pulse.voltage(0.25).shape == ()


@pytest.mark.parametrize(
    "arguments, key",
    [
        ({"kind": "step", "amplitude_V": 1.0}, "kind"),
        ({"kind": "pulse", "width_s": 0.1}, "amplitude_V"),
        ({"kind": "pulse", "amplitude_V": 1.0}, "width_s"),
        ({"kind": "pulse", "amplitude_V": 1.0, "width_s": 0.1, "frequency_Hz": 5.0}, "frequency_Hz"),
        ({"kind": "pulse", "amplitude_V": -1.0, "width_s": 0.1}, "amplitude_V"),
        ({"kind": "pulse", "amplitude_V": 1.0, "width_s": 0.0}, "width_s"),
        ({"kind": "pulse", "amplitude_V": float("nan"), "width_s": 0.1}, "amplitude_V"),
        ({"kind": "pulse", "amplitude_V": True, "width_s": 0.1}, "amplitude_V"),
        ({"kind": "burst", "amplitude_V": 1.0, "frequency_Hz": 10.0}, "cycles"),
        ({"kind": "burst", "amplitude_V": 1.0, "frequency_Hz": float("inf"), "cycles": 2}, "frequency_Hz"),
        ({"kind": "chirp", "amplitude_V": 1.0, "start_Hz": 1.0, "stop_Hz": 5.0}, "duration_s"),
        ({"kind": "chirp", "amplitude_V": 1.0, "start_Hz": "1", "stop_Hz": 5.0, "duration_s": 1.0}, "start_Hz"),
        ({"kind": "file", "amplitude_V": 1.0, "file": "x.csv"}, "amplitude_V"),
    ],
)
def test_invalid_excitation_names_the_key(arguments, key):
    with pytest.raises(BeamInputError, match=key):
        Excitation(**arguments)


def test_recording_must_be_finite_with_a_positive_step():
    with pytest.raises(BeamInputError, match="non-finite value at sample 1"):
        Excitation.from_recording(np.array([0.0, np.nan]), 0.001)
    with pytest.raises(BeamInputError, match="sample interval"):
        Excitation.from_recording(np.array([0.0, 1.0]), 0.0)
    with pytest.raises(BeamInputError, match="non-empty"):
        Excitation.from_recording(np.array([]), 0.001)


def test_to_table_lists_the_kind_and_its_keys():
    chirp = Excitation("chirp", amplitude_V=10, start_Hz=2, stop_Hz=250, duration_s=1.5)
    assert chirp.to_table() == {"kind": "chirp", "amplitude_V": 10.0, "start_Hz": 2.0, "stop_Hz": 250.0,
                                "duration_s": 1.5}
    assert all(isinstance(v, float) for k, v in chirp.to_table().items() if k != "kind")
    assert "2 -> 250 Hz" in chirp.describe()
