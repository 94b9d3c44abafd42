"""Inputs (patch voltage, point force, none) x outputs (displacement, velocity, acceleration).

References: the full Galerkin state space with its own C and D matrices for each output,
stepped by :func:`scipy.signal.lsim` (all 2n states), and closed forms (a single damped mode,
the static cantilever under a point load). Irregular time stamps are checked against the full
model on a fine uniform grid of which they are a subset.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from beam.errors import BeamInputError
from beam.physics.effects import EFFECTS, MAX_DAMPED_MODES, model_parameter_names
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel, state_space

#: The real rig's strip (500 x 50 x 2 mm aluminium), with a small patch near the clamp and a
#: force applied at 0.3 m.
LENGTH, DENSITY, EI = 0.5, 0.27, 2.333
GEOMETRY = BeamGeometry(LENGTH, DENSITY, 0.01, 0.06, 0.44, force_position_m=0.3)
FREE_GEOMETRY = BeamGeometry(LENGTH, DENSITY, None, None, 0.44)
DAMPING = {"air_damping_Ns_m2": 2e-3, "kelvin_voigt_Nm2s": 2e-6}
OUTPUTS = ("displacement", "velocity", "acceleration")
INPUTS = ("voltage", "force")

#: Damping and mass cases: proportional (air + Kelvin-Voigt on a uniform beam), non-proportional
#: (a sensor mass with air + Kelvin-Voigt) and modal damping with a sensor mass.
CASES = {
    "proportional": (["air_damping", "kelvin_voigt"], DAMPING),
    "sensor mass (non-proportional)": (["air_damping", "kelvin_voigt", "sensor_mass"], dict(DAMPING, sensor_mass_kg=4e-3)),
    "modal damping": (["sensor_mass", "modal_damping"],
                      {"sensor_mass_kg": 4e-3, **{f"damping_ratio_mode_{j}": 0.002 * j for j in range(1, 11)}}),
}


def parameters_for(input_kind: str | None, extra: dict) -> dict:
    base = {"bending_stiffness_Nm2": EI}
    if input_kind == "voltage":
        base["patch_coupling_NmV"] = 0.02
    return dict(base, **extra)


def smooth_burst(rate_Hz: float, duration_s: float = 0.25, frequency_Hz: float = 20.0) -> tuple[np.ndarray, np.ndarray]:
    """A 20 Hz sine under a sin² envelope rising over 0.1 s: smooth at the sampling rate."""
    t = np.arange(round(duration_s * rate_Hz)) / rate_Hz
    envelope = np.sin(0.5 * np.pi * np.clip(t / 0.1, 0.0, 1.0)) ** 2
    return t, np.sin(2 * np.pi * frequency_Hz * t) * envelope


def relative_max(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def relative_l2(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


#: These checks compare two algorithms of the same discrete model (all modes against the full
#: state space, truncation with its correction against all modes, closed forms to 1e-10), not the
#: mesh's accuracy; their round-off grows with the stiffest mode of the mesh (omega ~ 3e6 rad/s at
#: the default 40 elements), so they run on 16 elements, as in tests/test_physics_response.py.
ALL_MODES_INTERVALS = 16


# ---------------------------------------------------------------------------------------------
# every input x output pair against the full state space
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("output", OUTPUTS)
@pytest.mark.parametrize("input_kind", INPUTS)
def test_all_modes_equal_the_full_state_space(input_kind, output, case):
    effects, extra = CASES[case]
    model = BeamModel(GEOMETRY, effects, intervals=ALL_MODES_INTERVALS, input_kind=input_kind)
    parameters = parameters_for(input_kind, extra)
    t, u = smooth_burst(4000.0)
    full = model.response_full(parameters, u, t[1], output=output)
    assert relative_l2(model.response(parameters, u, t[1], modes=None, output=output), full) <= 1e-8
    assert relative_l2(model.response_at(parameters, u, t, modes=None, output=output), full) <= 1e-8


#: Largest relative error (max over the record / peak) of 4 modes with the correction for the
#: discarded modes, and the smallest factor by which the correction must beat no correction.
#: Measured: force 6.0e-6 / 6.7e-6 / 7.7e-4, voltage 1.8e-5 / 1.1e-5 / 2.6e-4 (displacement /
#: velocity / acceleration); without the correction 1.2e-3 / 1.3e-3 / 1.6e-3 and 4.0e-3 / 4.3e-3 /
#: 4.3e-3. The acceleration's floor is the hold itself: against the interpolated input the held
#: one lags by dt/2, omega dt / 2 = 7.9e-4 at 20 Hz and 80 kHz.
TRUNCATION = {
    ("force", "displacement"): (2e-5, 20), ("force", "velocity"): (2e-5, 20), ("force", "acceleration"): (2e-3, 1.5),
    ("voltage", "displacement"): (6e-5, 20), ("voltage", "velocity"): (4e-5, 20),
    ("voltage", "acceleration"): (1e-3, 5),
}


@pytest.mark.parametrize("output", OUTPUTS)
@pytest.mark.parametrize("input_kind", INPUTS)
def test_four_modes_with_the_correction_match_the_full_model(input_kind, output):
    """Displacement and velocity against the full model under the same held input (20 kHz);
    acceleration against the full model under the continuous (linearly interpolated) input at
    80 kHz, because the held input's steps give the full model's acceleration a jump c M⁻¹ f Δu
    at every sample (an artefact of the hold that the truncated model rightly lacks)."""
    model = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"], intervals=ALL_MODES_INTERVALS, input_kind=input_kind)
    parameters = parameters_for(input_kind, DAMPING)
    if output == "acceleration":
        t, u = smooth_burst(80_000.0)
        matrices = model.system_matrices(parameters)
        system = state_space(matrices["mass"][0], matrices["damping"][0], matrices["stiffness"][0],
                             matrices["force"][0], model.parts.sensor_values, 2)
        _, full, _ = scipy.signal.lsim(system, u, t, interp=True)
    else:
        t, u = smooth_burst(20_000.0)
        full = model.response_full(parameters, u, t[1], output=output)
    corrected = model.response(parameters, u, t[1], modes=4, output=output)
    bare = model.response(parameters, u, t[1], modes=4, output=output, static_correction=False)
    tolerance, gain = TRUNCATION[(input_kind, output)]
    assert relative_max(corrected, full) <= tolerance
    assert relative_max(bare, full) >= gain * relative_max(corrected, full)
    # irregular-time path: the same numbers on the same grid
    np.testing.assert_allclose(model.response_at(parameters, u, t, modes=4, output=output), corrected,
                               atol=1e-9 * np.abs(full).max())


def test_the_full_models_feed_through_is_not_a_correction_for_the_acceleration():
    """c M⁻¹ f minus the retained modes' share, added as a direct term, is wrong by ~23 %: the
    discarded modes' quasi-static stiffness force cancels it (see beam.physics.model's notes)."""
    model = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"], intervals=ALL_MODES_INTERVALS, input_kind="force")
    parameters = parameters_for("force", DAMPING)
    matrices = model.system_matrices(parameters)
    c = model.parts.sensor_values
    full_feed_through = c @ np.linalg.solve(matrices["mass"][0], matrices["force"][0])
    reduced, _, _ = model.reduced_system(parameters, 4)
    discarded = full_feed_through - reduced["sensor"][0] @ reduced["force"][0]
    t, u = smooth_burst(20_000.0)
    full = model.response_full(parameters, u, t[1], output="acceleration")
    ours = model.response(parameters, u, t[1], modes=4, output="acceleration")
    assert relative_max(ours, full) < 3e-3
    assert relative_max(ours + discarded * u, full) > 0.1


# ---------------------------------------------------------------------------------------------
# irregular time stamps: the full model on a fine grid
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("output", OUTPUTS)
@pytest.mark.parametrize("input_kind", INPUTS)
def test_irregular_stamps_equal_the_full_model_on_a_fine_grid(input_kind, output):
    """Stamps picked irregularly (steps of 1-40 fine steps) from a 20 kHz grid, the input held
    between them: the full model on the fine grid, read at the stamps, is the exact answer."""
    rng = np.random.default_rng(16)
    fine_rate = 20_000.0
    picks = np.concatenate([[0], np.cumsum(rng.integers(1, 41, size=400))])
    picks = picks[picks < int(0.25 * fine_rate)]
    t_fine = np.arange(picks[-1] + 1) / fine_rate
    t, u_smooth = t_fine[picks], smooth_burst(fine_rate)[1][picks]
    held = u_smooth[np.searchsorted(picks, np.arange(t_fine.size), side="right") - 1]  # the staircase
    effects, extra = CASES["sensor mass (non-proportional)"]
    model = BeamModel(GEOMETRY, effects, intervals=ALL_MODES_INTERVALS, input_kind=input_kind)
    parameters = parameters_for(input_kind, extra)
    full = model.response_full(parameters, held, 1 / fine_rate, output=output)[picks]
    exact = model.response_at(parameters, u_smooth, t, modes=None, output=output)
    assert relative_l2(exact, full) <= 1e-8


# ---------------------------------------------------------------------------------------------
# free responses
# ---------------------------------------------------------------------------------------------


def _initial_modal_state(model, parameters, modes):
    omega2, _ = model.mode_shapes(parameters, modes)
    rng = np.random.default_rng(3)
    scale = 1e-3 / np.arange(1, omega2.size + 1) ** 2
    return rng.normal(size=omega2.size) * scale, rng.normal(size=omega2.size) * scale * np.sqrt(omega2)


@pytest.mark.parametrize("output", OUTPUTS)
@pytest.mark.parametrize("case", CASES)
def test_free_response_with_all_modes_equals_the_full_state_space(case, output):
    effects, extra = CASES[case]
    model = BeamModel(FREE_GEOMETRY, effects, intervals=ALL_MODES_INTERVALS, input_kind=None)
    parameters = parameters_for(None, extra)
    eta, rate = _initial_modal_state(model, parameters, None)
    _, shapes = model.mode_shapes(parameters, None)
    t = np.arange(4000) / 4000.0
    full = model.free_response_full(parameters, t, shapes @ eta, shapes @ rate, output=output)
    # every mode is excited here, up to omega_17 dt ~ 25: lsim's matrix exponential carries ~1e-8
    assert relative_l2(model.free_response(parameters, t, eta, rate, modes=None, output=output), full) <= 5e-8


@pytest.mark.parametrize("output", OUTPUTS)
def test_free_response_of_retained_modes_under_modal_damping_is_exact_when_truncated(output):
    """Modal damping keeps the modes uncoupled: a state in the first four modes stays there."""
    effects, extra = CASES["modal damping"]
    model = BeamModel(FREE_GEOMETRY, effects, intervals=ALL_MODES_INTERVALS, input_kind=None)
    parameters = parameters_for(None, extra)
    eta, rate = _initial_modal_state(model, parameters, 4)
    _, shapes = model.mode_shapes(parameters, 4)
    t = np.arange(4000) / 4000.0
    full = model.free_response_full(parameters, t, shapes @ eta, shapes @ rate, output=output)
    assert relative_l2(model.free_response(parameters, t, eta, rate, modes=4, output=output), full) <= 1e-8


def test_release_from_a_static_tip_deflection_four_modes_against_the_full_model():
    """Released from rest under a tip load (every mode excited); 4 modes carry the displacement to
    0.1 % (3.5e-4 measured); velocity and acceleration agree once Kelvin-Voigt has damped the
    discarded modes (t > 0.2 s: 1.3e-8 measured; before, the discarded modes' ringing is 2 % of
    the velocity and as large as the acceleration)."""
    effects, extra = CASES["sensor mass (non-proportional)"]
    model = BeamModel(FREE_GEOMETRY, effects, intervals=ALL_MODES_INTERVALS, input_kind=None)
    parameters = parameters_for(None, dict(extra, kelvin_voigt_Nm2s=2e-4))
    stiffness = model.system_matrices(parameters)["stiffness"][0]
    q0 = np.linalg.solve(stiffness, model.parts.tip_values) * 0.1  # 0.1 N at the tip
    eta, rate = model.modal_state(parameters, q0, None, modes=4)
    t = np.arange(8000) / 8000.0
    late = t > 0.2
    for output, tolerance in (("displacement", 1e-3), ("velocity", 1e-6), ("acceleration", 1e-6)):
        full = model.free_response_full(parameters, t, q0, output=output)
        ours = model.free_response(parameters, t, eta, rate, modes=4, output=output)
        window = slice(None) if output == "displacement" else late
        assert relative_max(ours[window], full[window]) <= tolerance, output


@pytest.mark.parametrize("output", OUTPUTS)
def test_the_free_basis_spans_every_output_and_gives_back_the_initial_state(output):
    """At irregular stamps like the real logger's (median 0.25 ms, stalls of up to 10 ms)."""
    rng = np.random.default_rng(5)
    steps = np.where(rng.random(3000) < 0.002, rng.uniform(2e-3, 1e-2, 3000), rng.normal(0.25e-3, 0.02e-3, 3000))
    t = 7.0 + np.concatenate([[0.0], np.cumsum(steps)])
    effects, extra = CASES["sensor mass (non-proportional)"]
    model = BeamModel(FREE_GEOMETRY, effects, intervals=ALL_MODES_INTERVALS, input_kind=None)
    parameters = parameters_for(None, extra)
    eta, rate = _initial_modal_state(model, parameters, 4)
    y = model.free_response(parameters, t, eta, rate, modes=4, output=output)
    basis = model.free_response_basis(parameters, t, modes=4)
    assert basis.shape == (t.size, 8) and np.abs(basis).max() <= 1.0
    amplitudes, *_ = np.linalg.lstsq(basis, y, rcond=None)
    assert relative_max(basis @ amplitudes, y) <= 1e-10
    got_eta, got_rate = model.free_state_from_amplitudes(parameters, amplitudes, modes=4, output=output)
    np.testing.assert_allclose(got_eta, eta, rtol=1e-8, atol=1e-10 * np.abs(eta).max())
    np.testing.assert_allclose(got_rate, rate, rtol=1e-8, atol=1e-10 * np.abs(rate).max())
    # batched parameters give one basis per set
    batch = model.free_response_basis({k: np.full(3, v) for k, v in parameters.items()}, t, modes=4)
    assert batch.shape == (3, t.size, 8)
    np.testing.assert_allclose(batch[1], basis, atol=1e-12)


def test_single_mode_free_decay_matches_its_closed_form():
    """One retained mode with modal damping zeta: poles -zeta omega ± i omega sqrt(1 - zeta²) and
    y = phi(x_s) e^(-zeta omega t) (eta0 cos omega_d t + (eta0' + zeta omega eta0) / omega_d sin omega_d t)."""
    zeta = 0.03
    model = BeamModel(FREE_GEOMETRY, ["modal_damping"], intervals=ALL_MODES_INTERVALS, input_kind=None)
    parameters = {"bending_stiffness_Nm2": EI, "damping_ratio_mode_1": zeta}
    omega2, shapes = model.mode_shapes(parameters, 1)
    omega, phi = np.sqrt(omega2[0]), model.parts.sensor_values @ shapes[:, 0]
    omega_d = omega * np.sqrt(1 - zeta**2)
    eta0, rate0 = 2e-3, -0.05
    t = np.sort(np.random.default_rng(1).uniform(0.0, 1.0, 500))
    envelope = np.exp(-zeta * omega * (t - t[0]))
    tau = t - t[0]
    a, b = eta0, (rate0 + zeta * omega * eta0) / omega_d
    displacement = phi * envelope * (a * np.cos(omega_d * tau) + b * np.sin(omega_d * tau))
    pole = complex(-zeta * omega, omega_d)
    amplitude = complex(a, -b)  # y = phi Re(amplitude e^(pole tau))
    expected = {
        "displacement": displacement,
        "velocity": phi * (amplitude * pole * np.exp(pole * tau)).real,
        "acceleration": phi * (amplitude * pole**2 * np.exp(pole * tau)).real,
    }
    for output, values in expected.items():
        got = model.free_response(parameters, t, [eta0], [rate0], modes=1, output=output)
        np.testing.assert_allclose(got, values, rtol=0, atol=1e-9 * np.abs(values).max())
    # the pole in the full model: natural_modes gives |lambda| = omega and the ratio zeta
    frequencies, ratios = model.natural_modes(parameters, 2)
    assert frequencies[0] == pytest.approx(omega / (2 * np.pi), rel=1e-10)
    assert ratios[0] == pytest.approx(zeta, rel=1e-10) and ratios[1] == pytest.approx(0.0, abs=1e-12)


# ---------------------------------------------------------------------------------------------
# static load: closed forms of the cantilever
# ---------------------------------------------------------------------------------------------


def static_deflection(x: float, a: float, force: float) -> float:
    """Cantilever under a point force F at x = a: F x²(3a - x)/(6EI) for x <= a, F a²(3x - a)/(6EI) beyond."""
    if x <= a:
        return force * x**2 * (3 * a - x) / (6 * EI)
    return force * a**2 * (3 * x - a) / (6 * EI)


@pytest.mark.parametrize("force_at, sensor_at", [(0.5, 0.5), (0.5, 0.44), (0.25, 0.44), (0.25, 0.125)])
def test_a_slowly_applied_force_gives_the_static_deflection(force_at, sensor_at):
    """A raised-cosine ramp to 0.2 N over 2 s, then held 4 s (mode 1 at ~6.6 Hz, 5 % damped): the
    sensor reads the static deflection (tip: F L³/(3EI)), velocity and acceleration fall to zero.
    The force sits on a knot of the 16-interval mesh, where the cubic-spline basis holds the
    piecewise-cubic static shape exactly."""
    geometry = BeamGeometry(LENGTH, DENSITY, None, None, sensor_at, force_position_m=force_at)
    model = BeamModel(geometry, ["modal_damping"], intervals=ALL_MODES_INTERVALS, input_kind="force")
    parameters = {"bending_stiffness_Nm2": EI, **{f"damping_ratio_mode_{j}": 0.05 for j in range(1, 5)}}
    rate, force = 1000.0, 0.2
    t = np.arange(int(6.0 * rate)) / rate
    u = force * 0.5 * (1 - np.cos(np.pi * np.clip(t / 2.0, 0.0, 1.0)))
    expected = static_deflection(sensor_at, force_at, force)
    displacement = model.response(parameters, u, 1 / rate, modes=4)
    assert displacement[-1] == pytest.approx(expected, rel=1e-7)  # 4-5e-9 measured
    if force_at == sensor_at == LENGTH:
        assert displacement[-1] == pytest.approx(force * LENGTH**3 / (3 * EI), rel=1e-7)
    velocity = model.response(parameters, u, 1 / rate, modes=4, output="velocity")
    acceleration = model.response(parameters, u, 1 / rate, modes=4, output="acceleration")
    omega1 = np.sqrt(model.mode_shapes(parameters, 1)[0][0])
    assert abs(velocity[-1]) <= 1e-6 * omega1 * expected
    assert abs(acceleration[-1]) <= 1e-6 * omega1**2 * expected
    # the static correction alone is c K⁻¹ f less the retained modes' share: exact at any mode count
    for modes in (1, 2, 8):
        assert model.response(parameters, u, 1 / rate, modes=modes)[-1] == pytest.approx(expected, rel=1e-6)


# ---------------------------------------------------------------------------------------------
# the new effects
# ---------------------------------------------------------------------------------------------


def test_a_sensor_mass_at_the_tip_is_a_tip_mass():
    geometry = BeamGeometry(LENGTH, DENSITY, None, None, LENGTH)
    sensor = BeamModel(geometry, ["sensor_mass"], intervals=ALL_MODES_INTERVALS, input_kind=None).natural_modes(
        {"bending_stiffness_Nm2": EI, "sensor_mass_kg": 0.02}, 4)[0]
    tip = BeamModel(geometry, ["tip_mass"], intervals=ALL_MODES_INTERVALS, input_kind=None).natural_modes(
        {"bending_stiffness_Nm2": EI, "tip_mass_kg": 0.02}, 4)[0]
    np.testing.assert_allclose(sensor, tip, rtol=1e-12)


def test_a_small_sensor_mass_shifts_each_mode_by_rayleighs_first_order_estimate():
    """delta omega / omega = -m_s phi_j(x_s)² / 2 for mass-normalised shapes, to first order in m_s."""
    model = BeamModel(FREE_GEOMETRY, ["sensor_mass"], intervals=ALL_MODES_INTERVALS, input_kind=None)
    bare = {"bending_stiffness_Nm2": EI, "sensor_mass_kg": 0.0}
    omega2, shapes = model.mode_shapes(bare, 4)
    phi = model.parts.sensor_values @ shapes
    mass = 1e-5
    loaded = np.sqrt(model.mode_shapes(dict(bare, sensor_mass_kg=mass), 4)[0])
    np.testing.assert_allclose(loaded / np.sqrt(omega2) - 1, -mass * phi**2 / 2, rtol=2e-3)


def test_modal_damping_sets_each_modes_ratio_and_leaves_the_others_undamped():
    model = BeamModel(FREE_GEOMETRY, ["modal_damping"], intervals=ALL_MODES_INTERVALS, input_kind=None)
    parameters = {"bending_stiffness_Nm2": EI, "damping_ratio_mode_1": 0.004, "damping_ratio_mode_2": 0.0015}
    frequencies, ratios = model.natural_modes(parameters, 4)
    bare, _ = BeamModel(FREE_GEOMETRY, [], intervals=ALL_MODES_INTERVALS, input_kind=None).natural_modes({"bending_stiffness_Nm2": EI}, 4)
    np.testing.assert_allclose(frequencies, bare, rtol=1e-10)  # |lambda| = omega
    np.testing.assert_allclose(ratios, [0.004, 0.0015, 0.0, 0.0], atol=1e-12)
    # the reduced system carries 2 zeta omega on its diagonal
    reduced, _, _ = model.reduced_system(parameters, 3)
    np.testing.assert_allclose(np.diag(reduced["damping"][0]), 2 * np.array([0.004, 0.0015, 0.0]) * np.sqrt(reduced["omega2"][0]),
                               rtol=1e-12, atol=1e-12)


def test_per_mode_parameters_follow_the_number_of_retained_modes():
    model = BeamModel(FREE_GEOMETRY, ["sensor_mass", "modal_damping"], intervals=ALL_MODES_INTERVALS, input_kind=None)
    assert model.parameter_names_for(3) == ("bending_stiffness_Nm2", "sensor_mass_kg", "damping_ratio_mode_1",
                                            "damping_ratio_mode_2", "damping_ratio_mode_3")
    assert model_parameter_names(["modal_damping"], modes=2, input_kind=None) == (
        "bending_stiffness_Nm2", "damping_ratio_mode_1", "damping_ratio_mode_2")
    assert model_parameter_names(["air_damping"]) == ("bending_stiffness_Nm2", "patch_coupling_NmV", "air_damping_Ns_m2")
    with pytest.raises(BeamInputError, match="one parameter per retained mode"):
        model.parameter_names  # noqa: B018 - the property raises
    with pytest.raises(BeamInputError, match=f"at most {MAX_DAMPED_MODES} modes"):
        model.parameter_names_for(MAX_DAMPED_MODES + 1)
    spec = EFFECTS["modal_damping"].parameters[0]
    assert spec.absent_at == "low" and EFFECTS["sensor_mass"].parameters[0].absent_at == "low"
    with pytest.raises(BeamInputError, match="missing value for parameter 'damping_ratio_mode_1'"):
        model.free_response({"bending_stiffness_Nm2": EI, "sensor_mass_kg": 1e-3}, np.arange(3.0), np.zeros(3), modes=3)


# ---------------------------------------------------------------------------------------------
# clear errors
# ---------------------------------------------------------------------------------------------


def test_inputs_need_their_geometry_and_parameters():
    with pytest.raises(BeamInputError, match="voltage input needs the piezo patch"):
        BeamModel(FREE_GEOMETRY)
    with pytest.raises(BeamInputError, match="point-force input needs its position"):
        BeamModel(FREE_GEOMETRY, intervals=ALL_MODES_INTERVALS, input_kind="force")
    with pytest.raises(BeamInputError, match="patch_stiffening acts on the piezo patch"):
        BeamModel(FREE_GEOMETRY, ["patch_stiffening"], intervals=ALL_MODES_INTERVALS, input_kind=None)
    with pytest.raises(BeamInputError, match="input kind must be"):
        BeamModel(GEOMETRY, intervals=ALL_MODES_INTERVALS, input_kind="pressure")
    force_model = BeamModel(GEOMETRY, intervals=ALL_MODES_INTERVALS, input_kind="force")
    assert force_model.parameter_names == ("bending_stiffness_Nm2",)
    with pytest.raises(BeamInputError, match="'patch_coupling_NmV' is not part of this model"):
        force_model.response({"bending_stiffness_Nm2": EI, "patch_coupling_NmV": 0.02}, np.zeros(5), 1e-3)
    free_model = BeamModel(FREE_GEOMETRY, intervals=ALL_MODES_INTERVALS, input_kind=None)
    with pytest.raises(BeamInputError, match="no input .* use free_response"):
        free_model.response({"bending_stiffness_Nm2": EI}, np.zeros(5), 1e-3)
    with pytest.raises(BeamInputError, match="output must be one of displacement, velocity, acceleration"):
        force_model.response({"bending_stiffness_Nm2": EI}, np.zeros(5), 1e-3, output="jerk")
    with pytest.raises(BeamInputError, match="strictly increasing"):
        force_model.response_at({"bending_stiffness_Nm2": EI}, np.zeros(3), np.array([0.0, 0.1, 0.1]))
    with pytest.raises(BeamInputError, match="force_N must be finite with one value per time stamp"):
        force_model.response_at({"bending_stiffness_Nm2": EI}, np.zeros(4), np.arange(3.0))
