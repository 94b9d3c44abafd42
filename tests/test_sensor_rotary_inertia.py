"""``sensor_rotary_inertia``: the rotary inertia J of a sensor at x_obs, against the exact frequency
equation of a cantilever carrying a point mass and a rotary inertia; J -> 0 is the model without
it; a phone-sized J is recovered from a simulated free decay, where a model without it loses."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from beam.calibration import calibration_preview
from beam.io.measurement import Measurement
from beam.physics.effects import applicable, effect_needs
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

LENGTH, DENSITY, EI = 0.5, 0.27, 2.333  # the shared 50 cm aluminium strip (500 x 50 x 2 mm)
#: A phone taped along the strip: 0.17 kg, ~15 cm long, J = m l² / 12.
PHONE_KG, PHONE_J = 0.17, 0.17 * 0.15**2 / 12
EFFECTS = ("sensor_mass", "sensor_rotary_inertia")


def transfer(beta: float, x: float) -> np.ndarray:
    """(w, w', EI w'', EI w''') at x from their values at 0, of a uniform beam vibrating at
    wavenumber beta (beta⁴ = rho omega² / EI): F(x) F(0)⁻¹ with F the four solutions cosh, sinh,
    cos, sin and their derivatives."""
    def solutions(y: float) -> np.ndarray:
        c, s, cc, ss = np.cosh(beta * y), np.sinh(beta * y), np.cos(beta * y), np.sin(beta * y)
        b, b2, b3 = beta, EI * beta**2, EI * beta**3
        return np.array([[c, s, cc, ss], [b * s, b * c, -b * ss, b * cc], [b2 * c, b2 * s, -b2 * cc, -b2 * ss],
                         [b3 * s, b3 * c, b3 * ss, -b3 * cc]])
    return solutions(x) @ np.linalg.inv(solutions(0.0))


def exact_frequencies(position_m: float, mass_kg: float, inertia_kg_m2: float, count: int) -> np.ndarray:
    """The first ``count`` natural frequencies (Hz) of the clamped-free strip with a point mass and a
    rotary inertia at ``position_m``: the state crosses the sensor with the jumps
    [EI w'''] = m omega² w and [EI w''] = -J omega² w' (the body's translation and rotation), and
    the free end's EI w'' = EI w''' = 0 from the clamp's w = w' = 0 is a 2 x 2 determinant in beta,
    whose sign changes on a fine grid are refined by Brent's method."""
    def determinant(beta: float) -> float:
        omega2 = EI * beta**4 / DENSITY
        jump = np.eye(4)
        jump[2, 1], jump[3, 0] = -inertia_kg_m2 * omega2, mass_kg * omega2
        end = transfer(beta, LENGTH - position_m) @ jump @ transfer(beta, position_m)
        block = end[2:, 2:]
        return float(np.linalg.det(block / np.abs(block).max()))

    grid = np.linspace(0.3 / LENGTH, (count + 2.5) * np.pi / LENGTH, 20_000)
    values = [determinant(b) for b in grid]
    roots = [brentq(determinant, a, b, xtol=1e-15, rtol=1e-15)
             for a, b, fa, fb in zip(grid[:-1], grid[1:], values[:-1], values[1:]) if np.sign(fa) != np.sign(fb)]
    return np.sqrt(EI / DENSITY) * np.array(roots[:count]) ** 2 / (2 * np.pi)


def strip(position_m: float) -> BeamGeometry:
    return BeamGeometry(LENGTH, DENSITY, None, None, position_m)


def test_the_reference_is_the_closed_form_of_the_bare_cantilever():
    """Without the sensor the determinant's roots are the clamped-free beam's beta_n L."""
    beta_l = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349, 14.1371683910])
    closed = np.sqrt(EI / DENSITY) * beta_l**2 / (2 * np.pi * LENGTH**2)
    np.testing.assert_allclose(exact_frequencies(0.44, 0.0, 0.0, 5), closed, rtol=1e-9)


@pytest.mark.parametrize("position_m", [0.44, 0.25, LENGTH])
@pytest.mark.parametrize("mass_kg, inertia_kg_m2", [(0.0, PHONE_J), (PHONE_KG, PHONE_J), (0.002, 1e-7)])
def test_the_frequencies_follow_the_exact_cantilever_with_a_mass_and_a_rotary_inertia(position_m, mass_kg,
                                                                                       inertia_kg_m2):
    """The first five frequencies of the default mesh within 2e-5 of the exact ones (a 20 s record
    resolves 0.05 Hz, 8e-3 of the strip's 6.6 Hz mode 1), the sensor 6 cm from the tip (the shared
    rig), mid-span and at the tip, for a phone (whose J takes mode 2 from 41 Hz to 30 Hz) and an
    accelerometer board (2 g, J ~ 1e-7 kg m²)."""
    model = BeamModel(strip(position_m), EFFECTS, input_kind=None)
    values = {"bending_stiffness_Nm2": EI, "sensor_mass_kg": mass_kg, "sensor_rotary_inertia_kg_m2": inertia_kg_m2}
    frequencies, _ = model.natural_modes(values, 5)
    exact = exact_frequencies(position_m, mass_kg, inertia_kg_m2, 5)
    np.testing.assert_allclose(frequencies, exact, rtol=2e-5)


def test_the_rotary_inertia_lowers_the_modes_whose_slope_at_the_sensor_is_large():
    """A phone's J (no mass) at 0.44 m: mode 1, nearly straight there, moves by < 4 %, mode 2 by
    > 25 % (the exact equation's numbers, the model's within 2e-5 of them)."""
    model = BeamModel(strip(0.44), ("sensor_rotary_inertia",), input_kind=None)
    bare, _ = BeamModel(strip(0.44), (), input_kind=None).natural_modes({"bending_stiffness_Nm2": EI}, 3)
    loaded, _ = model.natural_modes({"bending_stiffness_Nm2": EI, "sensor_rotary_inertia_kg_m2": PHONE_J}, 3)
    drop = 1 - loaded / bare
    assert drop[0] < 0.04 and drop[1] > 0.25


def test_a_vanishing_inertia_is_the_model_without_it():
    """J = 0 and J at its prior's low end (1e-12 kg m²): the frequencies and a free decay of the
    model with the effect are those of the model without it, and between the two J within 1e-7
    (nested). The two bases differ (the effect's has a double knot at the sensor, where the
    mass's shear jump also sits): its frequencies are within 2e-5 of the exact mass-only
    cantilever's, the model without it within 1e-4 (mode 5: 6e-5)."""
    geometry = strip(0.44)
    base = {"bending_stiffness_Nm2": EI, "sensor_mass_kg": PHONE_KG}
    without = BeamModel(geometry, ("sensor_mass",), input_kind=None)
    with_it = BeamModel(geometry, EFFECTS, input_kind=None)
    reference, _ = without.natural_modes(base, 5)
    zero, _ = with_it.natural_modes(dict(base, sensor_rotary_inertia_kg_m2=0.0), 5)
    low, _ = with_it.natural_modes(dict(base, sensor_rotary_inertia_kg_m2=1e-12), 5)
    exact = exact_frequencies(0.44, PHONE_KG, 0.0, 5)
    np.testing.assert_allclose(zero, exact, rtol=2e-5)
    np.testing.assert_allclose(reference, exact, rtol=1e-4)
    np.testing.assert_allclose(low, zero, rtol=1e-7)
    t = np.arange(0.0, 2.0, 1e-3)
    decay = dict(base, damping_ratio_mode_1=0.002)
    a = BeamModel(geometry, ("sensor_mass", "modal_damping"), input_kind=None)
    b = BeamModel(geometry, ("sensor_mass", "sensor_rotary_inertia", "modal_damping"), input_kind=None)
    eta = np.array([1e-3, 0.0, 0.0])
    ya = a.free_response(decay, t, eta, modes=3, output="acceleration")
    yb = b.free_response(dict(decay, sensor_rotary_inertia_kg_m2=0.0), t, eta, modes=3, output="acceleration")
    assert np.max(np.abs(ya - yb)) <= 1e-4 * np.max(np.abs(ya))


def test_it_is_offered_where_a_contact_sensor_is():
    assert effect_needs("sensor_rotary_inertia") == {"contact_sensor"}
    assert applicable("sensor_rotary_inertia", {"contact_sensor", "free"})
    assert not applicable("sensor_rotary_inertia", {"displacement", "free"})


def test_a_phones_rotary_inertia_is_recovered_from_its_free_decay():
    """A phone (0.17 kg, J = 3.2e-4 kg m²) at 0.44 m on the strip of a known material (EI to 2 %,
    what a material preset states), an accelerometer's free decay of three modes (1 kHz, 3 s, noise
    0.02 m/s² and an offset): calibrated with the sensor's mass and its rotary inertia, J and m
    within 1 % of the truth and the noise sd within 5 % of the record's; the model with the mass
    alone is beaten by more than 100 nats of Laplace evidence and fits the window worse. (With EI
    free, the three frequencies have a second exact solution, EI 12 % low: the design decisions.)"""
    geometry = strip(0.44)
    truth = {"bending_stiffness_Nm2": EI, "sensor_mass_kg": PHONE_KG, "sensor_rotary_inertia_kg_m2": PHONE_J,
             "damping_ratio_mode_1": 0.003, "damping_ratio_mode_2": 0.004, "damping_ratio_mode_3": 0.005}
    model = BeamModel(geometry, (*EFFECTS, "modal_damping"), input_kind=None)
    t = np.arange(0.0, 3.0, 1e-3)
    _, shapes = model.mode_shapes(truth, 3)
    eta = np.array([0.02, 0.002, 0.0005]) / (model.parts.tip_values @ shapes)
    rng = np.random.default_rng(4)
    y = model.free_response(truth, t, eta, modes=3, output="acceleration") + 0.3 + 0.02 * rng.standard_normal(t.size)
    record = Measurement("phone_on_strip", "simulated", geometry, t, acceleration_m_s2=y,
                         nominal={"bending_stiffness_Nm2": EI}, nominal_spread={"bending_stiffness_Nm2": 0.02})
    options = dict(window=(0.0, 2.0), modes=3)
    with_it = calibration_preview(record, effects="sensor_mass,sensor_rotary_inertia,modal_damping", **options)
    without = calibration_preview(record, effects="sensor_mass,modal_damping", **options)
    found = with_it.laplace.map.values
    assert found["sensor_rotary_inertia_kg_m2"] == pytest.approx(PHONE_J, rel=0.01)
    assert found["sensor_mass_kg"] == pytest.approx(PHONE_KG, rel=0.01)
    assert found["noise_sd"] == pytest.approx(0.02, rel=0.05)
    assert with_it.laplace.log_evidence - without.laplace.log_evidence > 100
    assert with_it.rmse_calibration_map < without.rmse_calibration_map
