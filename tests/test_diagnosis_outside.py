"""An honest verdict: what the catalogue cannot explain is called so, measured against the noise floor.

The records are simulated here with discrepancies that no catalogue effect can represent (a
first-order lag of the sensor; a sensor 7.6 cm from where the sidecar says), and a control with
nothing missing. The noise floor comes from the record alone (:mod:`beam.residuals.noise`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import signal
from simulated_data import GEOMETRY, TRUE_BASE, simulated_measurement

from beam.discovery.report import OUTSIDE_CATALOGUE_RATIO, diagnose
from beam.physics.geometry import BeamGeometry
from beam.residuals.noise import record_noise_floor

NOISE = 1e-5


def test_a_sensor_lag_is_outside_the_catalogue():
    clean = simulated_measurement(TRUE_BASE, noise_m=0.0, seed=1)
    decay = np.exp(-clean.sample_interval_s / 0.002)  # first-order sensor with a 2 ms time constant
    lagged = signal.lfilter([1 - decay], [1, -decay], clean.displacement_m)
    record = replace(clean, displacement_m=lagged + NOISE * np.random.default_rng(1).standard_normal(lagged.size))
    report = diagnose(record, window=(0.0, 1.0))
    assert report.remaining.noise_floor.sd == pytest.approx(NOISE, rel=0.2)
    assert report.remaining.remaining_error_ratio > 10 * OUTSIDE_CATALOGUE_RATIO
    assert report.outside_catalogue and "outside the catalogue" in report.verdict
    summary = report.to_json()
    assert summary["outside_catalogue"] is True and summary["remaining_error_ratio"] > 20
    assert summary["noise_floor"] == pytest.approx(NOISE, rel=0.2)
    # the one floor of the record as calibrated, the beam view's (dashboard.outputs.beam.noise_floor_m)
    assert summary["noise_floor"] == record_noise_floor(report.base.setup.measurement).sd


def test_a_misplaced_sensor_is_outside_the_catalogue_even_when_an_effect_helps():
    true_geometry = BeamGeometry(GEOMETRY.length_m, GEOMETRY.linear_density_kg_m, GEOMETRY.patch_start_m,
                                 GEOMETRY.patch_end_m, 0.35)
    record = replace(simulated_measurement(TRUE_BASE, geometry=true_geometry, noise_m=NOISE, seed=2), geometry=GEOMETRY)
    report = diagnose(record, window=(0.0, 1.0))
    assert report.outside_catalogue
    assert report.remaining.remaining_error_ratio > 10 * OUTSIDE_CATALOGUE_RATIO
    if report.missing is not None:  # an effect may take part of the misfit; the verdict says it is not all
        assert "explains part of the misfit" in report.verdict


def test_nothing_missing_reaches_the_noise():
    report = diagnose(simulated_measurement(TRUE_BASE, noise_m=NOISE, seed=3), window=(0.0, 1.0))
    assert report.missing is None and not report.outside_catalogue
    assert report.remaining.remaining_error_ratio < 1.3
    assert report.verdict.startswith("nothing in the catalogue is missing")
