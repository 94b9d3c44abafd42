"""The stand-in record families (``tests/record_families.py``) and the release they start from
(:mod:`beam.io.release`): deterministic by seed, physical, and their truth followed by the
amplitude-resolved identification."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

import record_families as families
from beam.io.release import release_state, simulate_release
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel
from beam.residuals import record_backbone


def test_a_release_is_the_static_tip_deflection_and_mostly_mode_1():
    """A uniform cantilever's static tip-load shape w = P x² (3L - x) / 6 EI projected on the
    clamped-free modes (closed form, integrated by quad): mode 1 carries 0.9707 of its tip
    deflection; the release state of the Galerkin model gives the same shares and, with every
    mode, the tip at the deflection asked."""
    length, ei, rho = 0.5, 2.333, 0.27
    model = BeamModel(BeamGeometry(length, rho, None, None, length), ["modal_damping"], input_kind=None)
    values = {"bending_stiffness_Nm2": ei, "damping_ratio_mode_1": 0.002}
    modes = model.size
    eta, rate = release_state(model, values, 0.02, modes)
    _, shapes = model.mode_shapes(values, modes)
    tip = model.parts.tip_values @ shapes
    assert float(tip @ eta) == pytest.approx(0.02, rel=1e-9)
    assert np.all(rate == 0)

    roots = [1.8751040687, 4.6940911330]

    def shape(x, b):
        s = (math.cosh(b) + math.cos(b)) / (math.sinh(b) + math.sin(b))
        return math.cosh(b * x / length) - math.cos(b * x / length) - s * (math.sinh(b * x / length) - math.sin(b * x / length))

    static = lambda x: x**2 * (3 * length - x)  # noqa: E731 (any scale)
    for k, b in enumerate(roots):
        coefficient = quad(lambda x: static(x) * shape(x, b), 0, length)[0] / quad(lambda x: shape(x, b) ** 2, 0, length)[0]
        share = coefficient * shape(length, b) / static(length)
        assert float(tip[k] * eta[k]) / 0.02 == pytest.approx(share, abs=2e-4)
    assert float(tip[0] * eta[0]) / 0.02 == pytest.approx(0.9707, abs=2e-4)
    record = simulate_release(model, values, np.arange(0.0, 0.5, 1e-3), 0.02, modes=2, output="displacement")
    assert abs(record[0]) < 0.02  # the sensor (the tip) starts at rest near the deflection


def test_family_records_are_deterministic_and_carry_their_truth():
    """The same (family, effect, seed) gives the same samples; each family's records are what its
    table says (output, rate, sensor, artifacts)."""
    first = families.make_record("phone", "quadratic_drag", 1)
    again = families.make_record("phone", "quadratic_drag", 1)
    assert np.array_equal(first.measurement.time_s, again.measurement.time_s)
    assert np.array_equal(first.measurement.output, again.measurement.output)
    assert not first.measurement.uniform and 100 <= 1 / np.median(np.diff(first.measurement.time_s)) <= 500
    assert first.parameters["drag_coefficient"] >= 5 and first.measurement.geometry.width_m is not None
    strain = families.make_record("strain", "none", 0)
    assert strain.measurement.output_kind == "strain" and strain.measurement.geometry.sensor_position_m <= 0.05
    node = families.make_record("node", "sensor_mass", 2)
    assert node.measurement.geometry.sensor_position_m == pytest.approx(0.7834 * node.measurement.geometry.length_m)
    clipped = families.make_record("phone-artifacts", "none", 3)
    assert clipped.measurement.clipped_count > 0
    friction = families.make_record("accelerometer", "clamp_friction", 4)
    omega, shapes, _ = friction.modal()
    root = abs(float(friction.model.parts.basis.evaluate(np.zeros(1), 1)[0] @ shapes[:, 0] * friction.release_eta[0]))
    slip = 2 * friction.parameters["clamp_slip_moment_Nm"] / friction.parameters["clamp_friction_stiffness_Nm_rad"]
    assert 0.3 < root / slip < 0.9  # microslip at the release, where the describing function holds


@pytest.mark.slow
@pytest.mark.parametrize("family", families.FAMILIES)
def test_the_identification_follows_each_familys_truth(family):
    """One seed of every hidden effect of a family: mode 1's backbone and damping curve agree with
    the describing function (:meth:`FamilyRecord.agreement`) on every record, and no resolved
    mode disagrees (the benchmark scores all five seeds)."""
    for effect in families.EFFECTS:
        record = families.make_record(family, effect, 0)
        identified = record_backbone(record.measurement, frequencies_Hz=record.frequencies_Hz())
        agreement = record.agreement(identified)
        assert agreement.get(1) is True, (record.name, agreement)
        assert False not in agreement.values(), (record.name, agreement)
