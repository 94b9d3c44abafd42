"""Modes the sensor cannot see are named from the model's own mode shapes."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from simulated_data import GEOMETRY, TRUE_BASE, simulated_measurement

from beam.residuals import unseen_reason

#: beta_n L and sigma_n of the clamped-free Euler-Bernoulli beam (closed form, modes 1-3).
BETA_L = (1.875104069, 4.694091133, 7.854757438)
SIGMA = (0.734095514, 1.018467319, 0.999224497)


def _clamped_free(n: int, x_over_l: np.ndarray) -> np.ndarray:
    b, s = BETA_L[n - 1], SIGMA[n - 1]
    z = b * x_over_l
    return np.cosh(z) - np.cos(z) - s * (np.sinh(z) - np.sin(z))


def test_a_sensor_at_the_closed_form_node_of_mode_2_is_named():
    x = np.linspace(0.0, 0.3, 601)  # a 0.30 m strip
    shape = _clamped_free(2, x / 0.3)
    words = unseen_reason(x, shape, 0.24, 150.0, 2000.0)  # sensor at 0.80 L; mode 2's node is at 0.7834 L
    assert "near its node at 0.78 L" in words and "0.80 L" in words
    assert "not found" in unseen_reason(x, shape, 0.15, 150.0, 2000.0)  # mid-span: no node there
    assert "Nyquist" in unseen_reason(x, shape, 0.24, 1200.0, 1000.0)


def test_a_node_is_never_the_clamp():
    x = np.linspace(0.0, 1.0, 201)
    words = unseen_reason(x, _clamped_free(1, x), 0.01, 5.0, 500.0)  # next to the clamp: small, but no node
    assert "node" not in words


@pytest.mark.slow
def test_a_simulated_sensor_at_mode_2_node_is_named_in_the_modes_table():
    """B1TAPIH with the sensor moved to its own mode-2 node (from its model at the true values):
    the record shows modes 1 and 3, and the table says why mode 2 is missing."""
    from beam.calibration import calibration_preview
    from beam.discovery.report import residual_report
    from beam.physics.model import BeamModel

    effects = ("air_damping", "kelvin_voigt")
    model = BeamModel(GEOMETRY, effects)
    x = np.linspace(0.0, GEOMETRY.length_m, 2001)
    shapes = model.parts.basis.evaluate(x) @ model.mode_shapes(TRUE_BASE, 3)[1]
    phi = shapes[:, 1]
    k = int(np.flatnonzero((np.sign(phi[:-1]) != np.sign(phi[1:])) & (x[:-1] > 0))[-1])
    node = float(x[k] - phi[k] * (x[k + 1] - x[k]) / (phi[k + 1] - phi[k]))  # linear interpolation of the crossing
    assert node / GEOMETRY.length_m == pytest.approx(0.7834, abs=0.03)  # the uniform beam's node, moved by the patch
    record = simulated_measurement(TRUE_BASE, geometry=replace(GEOMETRY, sensor_position_m=node), noise_m=2e-5, seed=5)
    report = residual_report(calibration_preview(record, window=(0.0, 1.0), effects=effects, modes=4))
    rows = {row.mode: row for row in report.comparison}
    assert rows[1].matched and not rows[2].matched, report.comparison
    assert f"near its node at {node / GEOMETRY.length_m:.2f} L" in rows[2].note
