"""The model-free noise floor against the known noise of simulated records."""

from __future__ import annotations

import numpy as np
import pytest
from simulated_data import HIDDEN_EFFECTS, random_beam_case

from beam.errors import BeamInputError
from beam.io.measurement import read_measurement
from beam.io.simulation import read_truth
from beam.residuals.noise import noise_floor

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
