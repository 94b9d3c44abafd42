"""The number of modes chosen from the record (:func:`beam.calibration.suggest_modes`) and the honest
verdict of a truncated model ("try more modes", not "outside the catalogue").

Known truth: records simulated here with every mode of the Galerkin model and a chirp whose top
frequency is known.
"""

from __future__ import annotations

import numpy as np
import pytest
from simulated_data import TRUE_BASE, simulated_measurement

from beam.calibration import suggest_modes
from beam.discovery.report import diagnose
from beam.physics.excitation import Excitation
from beam.physics.model import BeamModel

NOISE = 1e-5
#: A chirp up to 400 Hz: modes 1-5 of the B1TAPIH beam (6.2, 38.5, 108, 211, 350 Hz) in the band.
WIDE_CHIRP = Excitation("chirp", amplitude_V=10.0, start_Hz=2.0, stop_Hz=400.0, duration_s=1.0)


def test_the_band_edge_is_the_chirp_top_and_the_truncation_error_stays_under_the_noise():
    record = simulated_measurement(TRUE_BASE, excitation=WIDE_CHIRP, rate_Hz=2000.0, noise_m=NOISE, seed=4, modes=None)
    choice = suggest_modes(record, (0.0, 1.0))
    assert choice.band_edge_Hz == pytest.approx(400.0, rel=0.15)
    assert choice.noise_sd == pytest.approx(NOISE, rel=0.2)
    frequencies, _ = BeamModel(record.geometry, ["air_damping", "kelvin_voigt"]).natural_modes(TRUE_BASE, 12)
    assert frequencies[choice.modes - 1] > 400.0  # every mode of the band, and more
    # at the truth: the chosen count's truncation error in the window is a fraction of the noise
    model = BeamModel(record.geometry, ["air_damping", "kelvin_voigt"])
    window = record.time_s <= 1.0
    every = model.response(TRUE_BASE, record.input, record.sample_interval_s, None)[window]
    kept = model.response(TRUE_BASE, record.input, record.sample_interval_s, choice.modes)[window]
    assert np.sqrt(np.mean((kept - every) ** 2)) <= 0.35 * NOISE
    assert "400 Hz" in choice.reason or "Hz" in choice.reason


def test_a_truncated_model_is_told_to_try_more_modes():
    record = simulated_measurement(TRUE_BASE, excitation=WIDE_CHIRP, rate_Hz=2000.0, noise_m=NOISE, seed=5, modes=None)
    report = diagnose(record, window=(0.0, 1.0), modes=3)
    remaining = report.remaining
    assert remaining.remaining_error_ratio > 2 and not remaining.white
    assert remaining.truncated and not report.outside_catalogue
    assert remaining.more_modes > 3 and "try more modes" in report.verdict
    assert "outside the catalogue" not in report.verdict.split("before looking")[0]
    summary = report.to_json()
    assert summary["outside_catalogue"] is False and summary["try_modes"] == remaining.more_modes
