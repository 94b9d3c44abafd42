"""The model-free noise floor against the known noise of simulated records."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from simulated_data import HIDDEN_EFFECTS, random_beam_case

from beam.errors import BeamInputError
from beam.io.measurement import read_measurement
from beam.io.simulation import read_truth
from beam.residuals.noise import difference_noise_sd, noise_floor, record_noise_floor

ASSETS = "assets/measurements"


@pytest.mark.parametrize("name", [f"lab_run_{i}" for i in range(1, 6)])
def test_bundled_records_noise_within_fifteen_percent(name):
    record = read_measurement(f"{ASSETS}/{name}.csv")
    truth = read_truth(f"assets/answers/{name}.truth.toml")
    floor = noise_floor(record.time_s, record.displacement_m)
    assert floor.sd == pytest.approx(truth.noise_m, rel=0.15)


@pytest.mark.parametrize("seed", range(6))
def test_fresh_random_records(seed):
    rng = np.random.default_rng(100 + seed)
    record, _, noise = random_beam_case(rng, HIDDEN_EFFECTS[seed % len(HIDDEN_EFFECTS)])
    floor = noise_floor(record.time_s, record.displacement_m)
    assert floor.sd == pytest.approx(noise, rel=0.2)


def test_pure_white_noise_and_a_loud_tone():
    rng = np.random.default_rng(0)
    t = np.arange(8000) / 1000.0
    noise = 0.3 * rng.standard_normal(t.size)
    assert noise_floor(t, noise).sd == pytest.approx(0.3, rel=0.08)
    tone = 100.0 * np.sin(2 * np.pi * 123.0 * t)  # 300x the noise, inside the searched band
    assert noise_floor(t, tone + noise).sd == pytest.approx(0.3, rel=0.1)


def test_too_short_a_record_is_refused():
    with pytest.raises(BeamInputError, match="at least 64 samples"):
        noise_floor(np.arange(10.0), np.zeros(10))


REAL = "assets/real/adxl_50cm_114759.csv"  # irregular stamps: a logger's jitter and gaps


def _decay_at(t: np.ndarray) -> np.ndarray:
    """Three decaying modes (m/s²) of the real strip's size: 6.05, 39.1 and 106 Hz."""
    return (8 * np.exp(-0.19 * t) * np.sin(2 * np.pi * 6.05 * t) + 3 * np.exp(-1.0 * t) * np.sin(2 * np.pi * 39.1 * t + 1)
            + 0.5 * np.exp(-2 * t) * np.sin(2 * np.pi * 106 * t))


@pytest.mark.parametrize("sd", [0.003, 0.01])
def test_irregular_stamps_known_noise_on_the_record_and_as_calibrated(sd):
    """On a real logger's stamps the smooth signal leaks over the spectrum of the samples taken as
    uniform (the spectrum bound alone: 2.1× and 5.6× at 3 mm/s², as recorded and subsampled by 4);
    the divided differences at the recorded stamps are blind to it."""
    from beam.calibration.records import decimate_measurement

    stamps = read_measurement(REAL).time_s
    record = replace(read_measurement(REAL), acceleration_m_s2=_decay_at(stamps)
                     + sd * np.random.default_rng(7).standard_normal(stamps.size))
    calibrated, factor = decimate_measurement(record)
    assert factor > 1 and not calibrated.uniform
    for r in (record, calibrated):
        floor = record_noise_floor(r)
        assert floor.sd == pytest.approx(sd, rel=0.1)
        assert floor.method == "differences"


def test_a_tone_near_nyquist_is_left_to_the_spectrum_bound():
    """Signal close to the Nyquist frequency passes the 4th differences; the spectrum's quietest band does not."""
    rng = np.random.default_rng(3)
    t = np.arange(4000) / 1000.0
    y = 2e-4 * np.sin(2 * np.pi * 160 * t) + 1e-3 * np.exp(-t) * np.sin(2 * np.pi * 30 * t) + 1e-5 * rng.standard_normal(t.size)
    assert difference_noise_sd(t, y) > 1.5e-5
    floor = noise_floor(t, y)
    assert floor.method == "spectrum" and floor.sd == pytest.approx(1e-5, rel=0.15)


def test_the_shared_real_runs_of_one_sensor_have_one_floor():
    """The bundled runs of one accelerometer on one rig, as calibrated: one sensor, one noise (within
    15 % of their median); the spectrum bound alone gave 0.020 and 0.104 m/s² on these two (signal
    leaking through the logger's jitter on the louder run)."""
    import glob

    from beam.calibration.records import decimate_measurement

    runs = sorted(glob.glob("assets/real/*.csv"))
    floors = np.array([record_noise_floor(decimate_measurement(read_measurement(f))[0]).sd for f in runs])
    assert floors.size >= 2
    assert np.all(np.abs(floors / np.median(floors) - 1) < 0.15), floors
