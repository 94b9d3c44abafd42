"""Strain as an output: a gauge at ``[sensor] position_m`` reads epsilon = -(h/2) w''(x_obs).

References: the full Galerkin state space (all 2n states, :meth:`BeamModel.response_full` with
the strain row as its output), the static cantilever's closed forms (a tip force: M(x) = F (L - x),
so epsilon = -(h/2) F (L - x) / EI; a patch moment k_p V: the curvature k_p V / EI on the patch and
zero beyond it), and a record simulated with every mode and noise, calibrated back to its truth.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from beam.errors import BeamInputError
from beam.io.measurement import Measurement, read_measurement, write_measurement
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

#: A 300 x 15 x 1 mm aluminium strip (rho b h = 0.0405 kg/m, E b h³ / 12 = 0.08625 N m²), a
#: gauge 50 mm from the clamp, a small patch near the root and a point force at the tip.
LENGTH, THICKNESS, DENSITY, EI = 0.3, 1e-3, 0.0405, 69e9 * 0.015 * 1e-9 / 12
GAUGE = 0.05
GEOMETRY = BeamGeometry(LENGTH, DENSITY, 0.01, 0.04, GAUGE, force_position_m=LENGTH, width_m=0.015,
                        thickness_m=THICKNESS)
DAMPING = {"air_damping_Ns_m2": 2e-3, "kelvin_voigt_Nm2s": 2e-7}
RATE = 2000.0


def parameters_for(input_kind: str) -> dict:
    base = {"bending_stiffness_Nm2": EI, **DAMPING}
    if input_kind == "voltage":
        base["patch_coupling_NmV"] = 1e-3
    return base


def smooth_burst(duration_s: float = 1.0, frequency_Hz: float = 12.0) -> tuple[np.ndarray, np.ndarray]:
    """A sine under a sin² envelope rising over 0.1 s (smooth at the sampling rate)."""
    t = np.arange(round(duration_s * RATE)) / RATE
    envelope = np.sin(0.5 * np.pi * np.clip(t / 0.1, 0.0, 1.0)) ** 2
    return t, np.sin(2 * np.pi * frequency_Hz * t) * envelope


@pytest.mark.parametrize("input_kind", ["voltage", "force"])
def test_all_modes_equal_the_full_state_space(input_kind):
    model = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"], input_kind=input_kind)
    parameters = parameters_for(input_kind)
    _, u = smooth_burst(0.4)
    full = model.response_full(parameters, u, 1 / RATE, output="strain")
    modal = model.response(parameters, u, 1 / RATE, None, output="strain")
    assert np.abs(full).max() > 0
    assert np.abs(modal - full).max() <= 1e-7 * np.abs(full).max()


#: Relative max error of 4 modes + correction against the full model, and the least factor by
#: which the correction must cut the bare truncation error (measured: voltage 2.5e-3 against
#: 0.73 bare, force 8.5e-5 against 2.1e-2). The gauge at 50 mm sits just beyond the patch, whose
#: moment pair excites high modes strongly: there the discarded modes carry most of the strain,
#: and their quasi-static share is off by ~(f / f_5)² = (20 / 516)² of it.
TRUNCATION = {"voltage": (5e-3, 100.0), "force": (2e-4, 100.0)}


@pytest.mark.parametrize("input_kind", ["voltage", "force"])
def test_four_modes_with_the_curvature_of_the_static_residual_match_the_full_model(input_kind):
    """The discarded modes' static share at the gauge is the curvature row applied to
    K⁻¹ f - Phi_r Omega_r⁻² Phi_r^T f. Against the full model under the same held input at
    20 kHz (fine enough that the hold's steps do not ring the discarded modes)."""
    model = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"], input_kind=input_kind)
    parameters = parameters_for(input_kind)
    rate = 20_000.0
    t = np.arange(round(0.25 * rate)) / rate
    u = np.sin(2 * np.pi * 20.0 * t) * np.sin(0.5 * np.pi * np.clip(t / 0.1, 0.0, 1.0)) ** 2
    full = model.response_full(parameters, u, 1 / rate, output="strain")
    corrected = model.response(parameters, u, 1 / rate, 4, True, output="strain")
    bare = model.response(parameters, u, 1 / rate, 4, False, output="strain")
    tolerance, gain = TRUNCATION[input_kind]
    error = np.abs(corrected - full).max() / np.abs(full).max()
    assert error <= tolerance
    assert np.abs(bare - full).max() / np.abs(full).max() >= gain * error
    # the irregular-time path gives the same numbers on the same grid
    np.testing.assert_allclose(model.response_at(parameters, u, t, 4, output="strain"), corrected,
                               atol=1e-9 * np.abs(full).max())


def test_a_slowly_applied_tip_force_gives_the_closed_form_strain():
    """epsilon(x) = -(h/2) F (L - x) / EI under a tip force F (cubic splines hold it exactly)."""
    model = BeamModel(GEOMETRY, ["air_damping"], input_kind="force")
    force = np.ones(4000)  # 1 N held; heavy air damping settles it
    strain = model.response({"bending_stiffness_Nm2": EI, "air_damping_Ns_m2": 5.0}, force, 1 / RATE, 4, output="strain")
    expected = -0.5 * THICKNESS * 1.0 * (LENGTH - GAUGE) / EI
    assert strain[-1] == pytest.approx(expected, rel=1e-8)


def test_the_patch_moment_bends_its_own_span_uniformly():
    """A patch moment k_p V is a couple: curvature k_p V / EI on the patch, none beyond it."""
    on_patch = BeamGeometry(LENGTH, DENSITY, 0.02, 0.08, 0.05, thickness_m=THICKNESS)
    beyond = BeamGeometry(LENGTH, DENSITY, 0.02, 0.08, 0.15, thickness_m=THICKNESS)
    parameters = {"bending_stiffness_Nm2": EI, "patch_coupling_NmV": 1e-3, "air_damping_Ns_m2": 5.0}
    volts = np.full(4000, 10.0)
    for geometry, expected in ((on_patch, -0.5 * THICKNESS * 1e-3 * 10.0 / EI), (beyond, 0.0)):
        strain = BeamModel(geometry, ["air_damping"]).response(parameters, volts, 1 / RATE, 4, output="strain")
        assert strain[-1] == pytest.approx(expected, abs=1e-9 * 0.5 * THICKNESS * 1e-2 / EI)


def test_free_strain_with_all_modes_equals_the_full_state_space():
    model = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"], input_kind=None)
    parameters = {"bending_stiffness_Nm2": EI, **DAMPING}
    omega2, shapes = model.mode_shapes(parameters, None)
    q0 = shapes[:, 0] * 1e-3 + shapes[:, 1] * 2e-4  # modes 1 and 2 displaced
    eta, rate = model.modal_state(parameters, q0, None, None)
    t = np.arange(800) / RATE
    full = model.free_response_full(parameters, t, q0, output="strain")
    modal = model.free_response(parameters, t, eta, rate, None, output="strain")
    assert np.abs(modal - full).max() <= 1e-7 * np.abs(full).max()
    # the free basis spans the strain: the amplitudes give back the initial state
    basis = model.free_response_basis(parameters, t, 4)
    amplitudes, *_ = np.linalg.lstsq(basis, full, rcond=None)
    back, _ = model.free_state_from_amplitudes(parameters, amplitudes, 4, output="strain")
    np.testing.assert_allclose(back[:2], eta[:2], rtol=1e-6)


def test_a_strain_output_needs_the_thickness():
    model = BeamModel(BeamGeometry(LENGTH, DENSITY, None, None, GAUGE, force_position_m=LENGTH), input_kind="force")
    with pytest.raises(BeamInputError, match=r"\[beam\] thickness_m"):
        model.response({"bending_stiffness_Nm2": EI}, np.ones(10), 1e-3, output="strain")
    t = np.arange(100) / RATE
    with pytest.raises(BeamInputError, match="strain output needs the strip's thickness"):
        Measurement(name="gauge", title="gauge", geometry=model.geometry, time_s=t, force_N=np.ones(100),
                    strain=np.sin(t))


def test_a_strain_record_round_trips_through_its_files(tmp_path):
    t = np.arange(200) / RATE
    record = Measurement(name="gauge", title="gauge", geometry=GEOMETRY, time_s=t, force_N=np.sin(t), strain=1e-6 * np.cos(t))
    write_measurement(tmp_path / "gauge", record)
    assert (tmp_path / "gauge.csv").read_text().splitlines()[0] == "time_s,force_N,strain"
    back = read_measurement(tmp_path / "gauge.csv")
    assert back.output_kind == "strain" and back.output_unit == "1"
    assert back.geometry.thickness_m == THICKNESS and back.geometry.width_m == 0.015
    np.testing.assert_array_equal(back.output, record.output)


def test_a_strain_record_simulated_with_every_mode_is_calibrated_back_to_its_truth():
    """A point-force-driven gauge record (a 2-200 Hz sweep, 5 kHz) from the full state space
    (all modes) with 2 % noise, three fixed seeds, calibrated with 6 modes from a nominal EI
    15 % off: the true EI and both dampings inside their 95 % intervals (at least 8 of 9),
    prediction residuals at the noise floor. (A strain sees the discarded modes more than a
    displacement: 4 modes at 2 kHz leave a 0.18 % RMS discrepancy, which moved EI by 1-3 of its
    posterior sd; 6 modes at 5 kHz leave 0.016 %.)"""
    from beam.calibration import calibration_preview

    parameters = parameters_for("force")
    model = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"], input_kind="force")
    rate, duration = 5000.0, 1.5
    t = np.arange(round(duration * rate)) / rate
    force = 0.05 * scipy.signal.chirp(t, 2.0, duration, 200.0)  # a shaker's sweep over modes 1-3 (N)
    clean = model.response_full(parameters, force, 1 / rate, output="strain")
    noise = 0.02 * np.sqrt(np.mean(clean**2))
    inside = 0
    for seed in range(3):
        record = Measurement(name="gauge", title="gauge", geometry=GEOMETRY, time_s=t, force_N=force,
                             strain=clean + np.random.default_rng(seed).normal(0.0, noise, t.size),
                             nominal={"bending_stiffness_Nm2": EI * 1.15})
        result = calibration_preview(record, window=(0.0, 1.0), modes=6)
        summary = result.summary()
        inside += sum(summary[n]["q025"] <= truth <= summary[n]["q975"] for n, truth in parameters.items())
        assert abs(summary["bending_stiffness_Nm2"]["mean"] / EI - 1) < 1e-3
        assert abs(result.rmse_prediction / noise - 1) < 0.05
    assert inside >= 8


def test_a_free_strain_decay_profiles_the_bridges_zero_offset():
    """A plucked strip's gauge record (all modes, from a static tip deflection released at t_0)
    with a bridge offset of 40 microstrain and 1 % noise: the offset is profiled out like an
    accelerometer's (within 3 of its sd) and EI comes back inside its 95 % interval."""
    from beam.calibration import calibration_preview

    geometry = BeamGeometry(LENGTH, DENSITY, None, None, GAUGE, width_m=0.015, thickness_m=THICKNESS)
    model = BeamModel(geometry, ["air_damping", "kelvin_voigt"], input_kind=None)
    parameters = {"bending_stiffness_Nm2": EI, **DAMPING}
    stiffness = model.system_matrices(parameters)["stiffness"][0]
    q0 = np.linalg.solve(stiffness, 0.02 * model.parts.tip_values)  # the static shape under 20 mN at the tip
    t = np.arange(3000) / RATE
    clean = model.free_response_full(parameters, t, q0, output="strain")
    noise = 0.01 * np.abs(clean).max()
    offset = 40e-6
    record = Measurement(name="pluck", title="pluck", geometry=geometry, time_s=t,
                         strain=clean + offset + np.random.default_rng(5).normal(0.0, noise, t.size),
                         nominal={"bending_stiffness_Nm2": EI * 0.9})
    result = calibration_preview(record, window=(0.0, 1.0), modes=4)
    summary, fit = result.summary(), result.linear_fit()
    stiffness_summary = summary["bending_stiffness_Nm2"]
    assert stiffness_summary["q025"] <= EI <= stiffness_summary["q975"], stiffness_summary
    assert abs(fit["output_offset"] - offset) <= 3 * fit["output_offset_sd"], fit
    assert result.to_json()["output_unit"] == "1"
