"""The quadratic air drag (``quadratic_drag``): against an independent integration of the full
Galerkin system, against the closed-form decay of one mode, its linear limit and its inputs."""

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.signal import find_peaks

from beam.errors import BeamInputError
from beam.physics.basis import gauss_points
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel
from beam.physics.nonlinear import AIR_DENSITY_KG_M3

#: An aluminium strip 500 x 50 x 2 mm (E = 70 GPa): EI = 2.333 N m², rho = 0.27 kg/m.
LENGTH, DENSITY, STIFFNESS, WIDTH = 0.5, 0.27, 2.333, 0.05
STRIP = BeamGeometry(LENGTH, DENSITY, None, None, 0.44, width_m=WIDTH)


def _relative_l2(value, reference):
    return np.linalg.norm(value - reference) / np.linalg.norm(reference)


def _tip_state(model, parameters, tips_m):
    """Modal displacements eta (mass-normalised shapes) giving tip displacements ``tips_m`` mode by mode."""
    _, shapes = model.mode_shapes(parameters, len(tips_m))
    return np.asarray(tips_m) / (model.parts.tip_values @ shapes)


def test_the_drag_at_zero_coefficient_is_the_linear_free_and_driven_response():
    model = BeamModel(STRIP, ["modal_damping", "sensor_mass", "quadratic_drag"], input_kind=None)
    parameters = {"bending_stiffness_Nm2": STIFFNESS, "sensor_mass_kg": 0.004, "damping_ratio_mode_1": 0.004,
                  "damping_ratio_mode_2": 0.003, "damping_ratio_mode_3": 0.002, "damping_ratio_mode_4": 0.002}
    linear = BeamModel(STRIP, ["modal_damping", "sensor_mass"], input_kind=None)
    time = np.cumsum(np.r_[0.0, np.random.default_rng(1).uniform(2e-4, 4e-4, 3000)])  # irregular stamps
    eta = _tip_state(linear, parameters, [0.02, 0.002, 5e-4, 1e-4])
    for output in ("displacement", "velocity", "acceleration"):
        expected = linear.free_response(parameters, time, eta, modes=4, output=output)
        # C_d small but > 0 takes the integrator's path; its share is ~1e-9 of the response here
        got = model.free_response(dict(parameters, drag_coefficient=1e-9), time, eta, modes=4, output=output)
        assert _relative_l2(got, expected) < 1e-8, output
    # driven by a point force at the tip (held between samples), from rest
    driven = BeamGeometry(LENGTH, DENSITY, None, None, 0.44, force_position_m=LENGTH, width_m=WIDTH)
    pulse = np.where(np.arange(2000) < 40, 0.5, 0.0)
    base = {"bending_stiffness_Nm2": STIFFNESS, "air_damping_Ns_m2": 0.005, "kelvin_voigt_Nm2s": 1e-6}
    reference = BeamModel(driven, ["air_damping", "kelvin_voigt"], input_kind="force")
    model = BeamModel(driven, ["air_damping", "kelvin_voigt", "quadratic_drag"], input_kind="force")
    for output in ("displacement", "velocity", "acceleration"):
        expected = reference.response(base, pulse, 5e-4, modes=4, output=output)
        got = model.response(dict(base, drag_coefficient=1e-9), pulse, 5e-4, modes=4, output=output)
        assert _relative_l2(got, expected) < 1e-7, output


def test_the_drag_matches_an_independent_integration_of_the_full_galerkin_system():
    """The retained modes with the drag by quadrature at 16 Gauss points against Radau (rtol 1e-10)
    on all the Galerkin equations M q'' + C q' + K q = -∫ phi ½ rho_air C_d b |w_t| w_t dx, the
    drag integrated by 6 Gauss points on every element (a different quadrature, no modes). A
    free decay from 2 cm at the tip in modes 1 and 2, acceleration at the sensor (as an
    accelerometer reads it): relative L2 <= 1 % (measured 6e-5 here, 5e-7 on 12 elements over
    2 s), while the model without the drag is 7 % away (the drag matters here)."""
    model = BeamModel(STRIP, ["air_damping", "kelvin_voigt", "quadratic_drag"], intervals=8, input_kind=None)
    parameters = {"bending_stiffness_Nm2": STIFFNESS, "air_damping_Ns_m2": 1e-3, "kelvin_voigt_Nm2s": 1e-6,
                  "drag_coefficient": 8.0}
    eta = _tip_state(model, parameters, [0.02, 0.002])
    eta = np.r_[eta, 0.0, 0.0]
    time = np.arange(1001) * 5e-4
    got = model.free_response(parameters, time, eta, modes=4, output="acceleration")
    linear = model.free_response(dict(parameters, drag_coefficient=0.0), time, eta, modes=4, output="acceleration")

    matrices = model.system_matrices(parameters)
    mass, damping, stiffness = (matrices[k][0] for k in ("mass", "damping", "stiffness"))
    x, w = gauss_points(model.parts.basis.breakpoints_m, 6)
    values = model.parts.basis.evaluate(x, 0)
    coefficient = 0.5 * AIR_DENSITY_KG_M3 * WIDTH * parameters["drag_coefficient"] * w
    n = mass.shape[0]
    inverse = np.linalg.inv(mass)
    system = np.block([[np.zeros((n, n)), np.eye(n)], [-inverse @ stiffness, -inverse @ damping]])

    def rhs(_, z):
        v = values @ z[n:]
        out = system @ z
        out[n:] += inverse @ (values.T @ (-coefficient * np.abs(v) * v))
        return out

    def jacobian(_, z):
        v = values @ z[n:]
        out = system.copy()
        out[n:, n:] += inverse @ (values.T * (-2.0 * coefficient * np.abs(v))) @ values
        return out

    _, shapes = model.mode_shapes(parameters, 4)
    start = np.concatenate([shapes @ eta, np.zeros(n)])
    solution = solve_ivp(rhs, (0.0, time[-1]), start, method="Radau", rtol=1e-10, atol=1e-13, jac=jacobian, t_eval=time)
    assert solution.success
    reference = model.parts.sensor_values @ np.array([rhs(0.0, z)[n:] for z in solution.y.T]).T
    assert _relative_l2(linear, reference) > 0.05
    assert _relative_l2(got, reference) <= 0.01


def test_one_mode_decays_as_the_closed_form_of_quadratic_damping():
    """One mode, eta'' + 2 zeta omega eta' + omega² eta = -kappa |eta'| eta', with
    kappa = ½ rho_air C_d b ∫ |psi|³ dx (psi the mass-normalised shape). Averaging over a cycle
    (eta = A cos(omega t + phi), <|sin|³> = 4 / (3 pi)) the energy ½ omega² A² loses
    2 zeta omega <eta'²> + kappa <|eta'|³>, so

        dA/dt = -zeta omega A - (4 / (3 pi)) kappa omega A²,

    i.e. the equivalent viscous coefficient (8 / (3 pi)) kappa omega A, whose solution is
    A(t) = a A0 e^(-a t) / (a + b A0 (1 - e^(-a t))), a = zeta omega, b = (4 / 3 pi) kappa omega.
    kappa and omega come here from the closed-form clamped-free shape (no B-splines); the
    simulated envelope (tip, 30 s, falling to 5 % where the linear damping alone leaves 57 %)
    follows it within 0.1 % (measured 2e-6)."""
    tip = BeamGeometry(LENGTH, DENSITY, None, None, LENGTH, width_m=WIDTH)
    model = BeamModel(tip, ["air_damping", "quadratic_drag"], input_kind=None)
    drag, gamma = 10.0, 0.01
    parameters = {"bending_stiffness_Nm2": STIFFNESS, "air_damping_Ns_m2": gamma, "drag_coefficient": drag}
    beta = 1.8751040687119611
    sigma = (np.cosh(beta) + np.cos(beta)) / (np.sinh(beta) + np.sin(beta))

    def shape(x):
        s = beta * x / LENGTH
        return np.cosh(s) - np.cos(s) - sigma * (np.sinh(s) - np.sin(s))

    norm = np.sqrt(DENSITY * quad(lambda x: shape(x) ** 2, 0, LENGTH)[0])
    psi_tip = shape(LENGTH) / norm
    kappa = 0.5 * AIR_DENSITY_KG_M3 * drag * WIDTH * quad(lambda x: abs(shape(x) / norm) ** 3, 0, LENGTH, limit=200)[0]
    omega = beta**2 / LENGTH**2 * np.sqrt(STIFFNESS / DENSITY)
    a = gamma / (2 * DENSITY)  # gamma M is a mass-proportional damping: 2 zeta omega = gamma / rho
    b = 4.0 / (3.0 * np.pi) * kappa * omega / psi_tip  # for the tip's amplitude

    start = 0.03  # m at the tip
    dt = 1e-3
    time = np.arange(0.0, 30.0, dt)
    tip_motion = model.free_response(parameters, time, np.array([start / psi_tip]), modes=1)
    peaks, _ = find_peaks(np.abs(tip_motion))
    left, centre, right = tip_motion[peaks - 1], tip_motion[peaks], tip_motion[peaks + 1]
    shift = 0.5 * (left - right) / (left - 2 * centre + right)  # parabola through the three samples
    amplitude = np.abs(centre - 0.25 * (left - right) * shift)
    at = time[peaks] + shift * dt
    closed = a * start * np.exp(-a * at) / (a + b * start * (1.0 - np.exp(-a * at)))
    assert amplitude[-1] < 0.1 * start < 0.2 * start * np.exp(-a * at[-1])  # the drag dominates the decay
    np.testing.assert_allclose(amplitude, closed, rtol=1e-3)


def test_the_drag_needs_the_strip_s_width():
    geometry = BeamGeometry(LENGTH, DENSITY, None, None, 0.44)
    model = BeamModel(geometry, ["air_damping", "quadratic_drag"], input_kind=None)
    with pytest.raises(BeamInputError, match="width_m"):
        model.free_response({"bending_stiffness_Nm2": STIFFNESS, "air_damping_Ns_m2": 1e-3, "drag_coefficient": 5.0},
                            np.arange(10) * 1e-3, np.array([1e-3, 0, 0, 0]))
    with pytest.raises(BeamInputError, match="width_m"):
        BeamGeometry(LENGTH, DENSITY, None, None, 0.44, width_m=-0.01)


def test_a_batch_of_sets_gives_what_each_set_gives_alone():
    model = BeamModel(STRIP, ["modal_damping", "quadratic_drag"], input_kind=None)
    batch = {"bending_stiffness_Nm2": np.array([2.2, 2.4]), "damping_ratio_mode_1": np.array([0.003, 0.001]),
             "drag_coefficient": np.array([3.0, 12.0])}
    time = np.arange(2000) * 2.5e-4
    eta = np.array([0.05, 0.004])
    together = model.free_response(batch, time, eta, modes=2, output="acceleration")
    for i in range(2):
        alone = model.free_response({k: float(v[i]) for k, v in batch.items()}, time, eta, modes=2, output="acceleration")
        np.testing.assert_allclose(together[i], alone, rtol=0, atol=1e-12 * np.abs(alone).max())


def test_the_general_kernel_with_the_spring_reproduces_the_spring_s_own_kernel():
    """lab_run_4's beam, spring (k3 = 1.5e4 N/m³) and 40 V pulse: the drag's kernel (every channel,
    its own step rule) with a vanishing C_d against the spring's kernel, which tests/test_nonlinear.py
    checks against solve_ivp (2e-8 of the peak): the same response to 1e-5 of the peak."""
    geometry = BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.40, width_m=0.02)
    parameters = {"bending_stiffness_Nm2": 0.491, "patch_coupling_NmV": 1.746e-2, "air_damping_Ns_m2": 0.02,
                  "kelvin_voigt_Nm2s": 0.649e-5, "tip_cubic_stiffness_N_m3": 1.5e4}
    voltage = np.where(np.arange(1500) < 80, 40.0, 0.0)
    spring = BeamModel(geometry, ["air_damping", "kelvin_voigt", "tip_cubic_spring"])
    both = BeamModel(geometry, ["air_damping", "kelvin_voigt", "tip_cubic_spring", "quadratic_drag"])
    expected = spring.response(parameters, voltage, 1e-3, modes=4)
    got = both.response(dict(parameters, drag_coefficient=1e-9), voltage, 1e-3, modes=4)
    assert np.abs(got - expected).max() <= 1e-5 * np.abs(expected).max()


def test_the_sidecar_s_width_reaches_the_geometry(tmp_path):
    from beam.io.measurement import read_measurement

    time = np.arange(200) * 1e-3
    (tmp_path / "strip.csv").write_text("time_s,acceleration_m_s2\n" + "".join(
        f"{t:.3f},{0.4 + np.sin(40 * t):.6f}\n" for t in time))
    sidecar = "[beam]\nlength_m = 0.5\nlinear_density_kg_m = 0.27\n{}[sensor]\nposition_m = 0.44\n"
    (tmp_path / "strip.toml").write_text(sidecar.format("width_m = 0.05\nthickness_m = 0.002\n"))
    assert read_measurement(tmp_path / "strip.csv").geometry.width_m == 0.05
    (tmp_path / "strip.toml").write_text(sidecar.format(""))
    assert read_measurement(tmp_path / "strip.csv").geometry.width_m is None


def test_irregular_stamps_give_the_uniform_response_at_the_shared_times_and_linear_paths_refuse_the_drag():
    """A driven response at irregular stamps (every other sample of a uniform grid dropped here and
    there, the input held over each recorded interval) equals the uniform-grid response at the
    kept stamps when the input is constant over the dropped samples, to the scheme's step error
    (an interval twice as long may take one substep where the grid takes two: within 1e-5 of the
    peak); the linear-only paths refuse a positive C_d instead of ignoring it."""
    driven = BeamGeometry(LENGTH, DENSITY, None, None, 0.44, force_position_m=LENGTH, width_m=WIDTH)
    model = BeamModel(driven, ["air_damping", "quadratic_drag"], input_kind="force")
    values = {"bending_stiffness_Nm2": STIFFNESS, "air_damping_Ns_m2": 0.005, "drag_coefficient": 10.0}
    dt = 5e-4
    force = np.where(np.arange(3000) < 60, 0.8, 0.0)
    uniform = model.response(values, force, dt, modes=4, output="acceleration")
    keep = np.ones(force.size, bool)
    keep[np.arange(200, 2900, 7)] = False  # the input is 0 there: holding the previous sample changes nothing
    irregular = model.response_at(values, force[keep], np.arange(force.size)[keep] * dt, modes=4, output="acceleration")
    np.testing.assert_allclose(irregular, uniform[keep], rtol=0, atol=1e-5 * np.abs(uniform).max())
    with pytest.raises(BeamInputError, match="quadratic_drag"):
        model.response_full(values, force, dt)
    free = BeamModel(STRIP, ["air_damping", "quadratic_drag"], input_kind=None)
    with pytest.raises(BeamInputError, match="quadratic_drag"):
        free.free_response_basis(values, np.arange(10) * dt)
