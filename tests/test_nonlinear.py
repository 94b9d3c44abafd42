"""The tip cubic spring integrator: linear limit, an independent ODE solver, hardening."""

import numpy as np
from scipy.integrate import solve_ivp

from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel
from beam.physics.nonlinear import _triple_quartic_sum, choose_substeps, integrate_tip_cubic

GEOMETRY = BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.27438)
PARAMETERS = {"bending_stiffness_Nm2": 0.491, "patch_coupling_NmV": 1.746e-2, "air_damping_Ns_m2": 0.013,
              "kelvin_voigt_Nm2s": 0.649e-5}
EFFECTS = ["air_damping", "kelvin_voigt", "tip_cubic_spring"]
DT = 1e-3


def chirp(n=600):
    t = np.arange(n) * DT
    return np.where(t < 0.5, 10 * np.sin(2 * np.pi * (2 * t + 150 * t**2)), 0.0)


def test_zero_cubic_stiffness_reproduces_the_linear_response():
    model = BeamModel(GEOMETRY, EFFECTS)
    parameters = dict(PARAMETERS, tip_cubic_stiffness_N_m3=0.0)
    linear = model.response(parameters, chirp(), DT, modes=4)
    system = model.modal_system(parameters, modes=4)
    reduced, _, _ = model.reduced_system(parameters, modes=4)
    nonlinear_path = integrate_tip_cubic(system, np.zeros(1), chirp(), DT, substeps=3, static_gains=reduced["static"])[0]
    np.testing.assert_allclose(nonlinear_path, linear, atol=1e-11 * np.abs(linear).max())
    # and without the static correction on both sides
    bare = integrate_tip_cubic(system, np.zeros(1), chirp(), DT, substeps=3)[0]
    np.testing.assert_allclose(bare, model.response(parameters, chirp(), DT, modes=4, static_correction=False),
                               atol=1e-11 * np.abs(linear).max())


def _reference(model, parameters, voltage, modes):
    """solve_ivp (DOP853, rtol 1e-12) on the real modal equations, one sample interval at a time."""
    reduced, _, _ = model.reduced_system(parameters, modes)
    omega2, damping, force = reduced["omega2"][0], reduced["damping"][0], reduced["force"][0]
    sensor, tip = reduced["sensor"][0], reduced["tip"][0]
    k3 = parameters["tip_cubic_stiffness_N_m3"]

    def rhs(_, x, volts):
        eta, velocity = x[:modes], x[modes:]
        w_tip = tip @ eta
        return np.concatenate([velocity, -omega2 * eta - damping @ velocity + force * volts - k3 * w_tip**3 * tip])

    state, out = np.zeros(2 * modes), np.zeros(voltage.size)
    for k, volts in enumerate(voltage):
        out[k] = sensor @ state[:modes]
        state = solve_ivp(rhs, (0, DT), state, args=(volts,), method="DOP853", rtol=1e-12, atol=1e-16).y[:, -1]
    return out


def test_strongly_nonlinear_response_matches_an_independent_ode_solver_at_fourth_order():
    model = BeamModel(GEOMETRY, EFFECTS)
    parameters = dict(PARAMETERS, tip_cubic_stiffness_N_m3=3e8)
    voltage = chirp(500)
    reference = _reference(model, parameters, voltage, modes=3)
    # the reference integrates the retained modes only: compare without the static correction
    linear = BeamModel(GEOMETRY, EFFECTS[:2]).response(PARAMETERS, voltage, DT, modes=3, static_correction=False)
    assert np.abs(linear - reference).max() > 0.3 * np.abs(reference).max()  # the spring matters here
    automatic = model.response(parameters, voltage, DT, modes=3, static_correction=False)
    assert np.abs(automatic - reference).max() <= 2e-4 * np.abs(reference).max()
    system = model.modal_system(parameters, modes=3)
    errors = [np.abs(integrate_tip_cubic(system, np.array([3e8]), voltage, DT, substeps=s)[0] - reference).max()
              for s in (4, 8, 16)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 3.5), orders


def _zero_crossing_frequency(signal, start, stop):
    segment = signal[start:stop]
    crossings = np.flatnonzero(np.diff(np.sign(segment)) > 0)
    return (crossings.size - 1) / ((crossings[-1] - crossings[0]) * DT)


def test_hardening_raises_the_frequency_at_large_amplitude_and_it_relaxes_as_motion_decays():
    voltage = np.where(np.arange(8000) < 90, 40.0, 0.0)  # a pulse, then free decay of mode 1
    damped = dict(PARAMETERS, air_damping_Ns_m2=0.15)
    linear = BeamModel(GEOMETRY, EFFECTS[:2]).response(damped, voltage, DT, modes=2)
    stiff = BeamModel(GEOMETRY, EFFECTS).response(dict(damped, tip_cubic_stiffness_N_m3=2e7), voltage, DT, modes=2)
    early, late = (200, 1500), (6000, 8000)
    f_linear = _zero_crossing_frequency(linear, *early)
    f_early = _zero_crossing_frequency(stiff, *early)
    f_late = _zero_crossing_frequency(stiff, *late)
    assert f_early > 1.05 * f_linear  # hardening: higher frequency at large amplitude
    assert abs(f_late / _zero_crossing_frequency(linear, *late) - 1) < 0.5 * (f_early / f_linear - 1)


def test_substeps_grow_with_cubic_stiffness():
    model = BeamModel(GEOMETRY, EFFECTS)
    soft = choose_substeps(model.modal_system(dict(PARAMETERS, tip_cubic_stiffness_N_m3=1.0), 4), np.array([1.0]), chirp(), DT)
    hard = choose_substeps(model.modal_system(dict(PARAMETERS, tip_cubic_stiffness_N_m3=1e12), 4), np.array([1e12]), chirp(), DT)
    assert hard[0] > soft[0] >= 1


def test_automatic_step_on_a_weakly_hardening_pulse_response_is_far_below_the_noise():
    """lab_run_4's beam and spring (k3 = 1.5e4 N/m³, 40 V pulse of 80 ms, record noise 7e-4 of the
    peak): the step sized by the spring force's content (3 substeps, not the 27 of 3x the highest
    kept mode) stays within 1e-6 of the peak of the solve_ivp reference (measured 2e-8)."""
    geometry = BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.40)
    model = BeamModel(geometry, EFFECTS)
    parameters = dict(PARAMETERS, air_damping_Ns_m2=0.02, tip_cubic_stiffness_N_m3=1.5e4)
    voltage = np.where(np.arange(1000) < 80, 40.0, 0.0)
    system = model.modal_system(parameters, modes=4)
    substeps = choose_substeps(system, np.array([1.5e4]), voltage, DT)[0]
    assert substeps < 27  # coarser than 3x the highest kept mode would make it
    reference = _reference(model, parameters, voltage, modes=4)
    linear = BeamModel(geometry, EFFECTS[:2]).response(dict(PARAMETERS, air_damping_Ns_m2=0.02), voltage, DT, modes=4,
                                                       static_correction=False)
    assert np.abs(linear - reference).max() > 0.3 * np.abs(reference).max()  # the spring matters here
    automatic = model.response(parameters, voltage, DT, modes=4, static_correction=False)
    assert np.abs(automatic - reference).max() <= 1e-6 * np.abs(reference).max()


def test_the_discarded_modes_answer_the_spring_quasi_statically():
    """lab_run_4 at its true parameters: 6 retained modes with the static correction of the spring's
    force against the model with every Galerkin mode (no mode discarded, no correction): the
    held-out difference is a small fraction of the record's noise (2e-5 m); without the spring's
    share (the voltage's alone, as before) it was 2.6 x the noise."""
    from pathlib import Path

    from beam.io.measurement import read_measurement
    from beam.io.simulation import read_truth

    root = Path(__file__).resolve().parents[1]
    record = read_measurement(root / "assets" / "measurements" / "lab_run_4.csv")
    truth = read_truth(root / "assets" / "answers" / "lab_run_4.truth.toml")
    model = BeamModel(record.geometry, truth.effects, truth.intervals, truth.knots)
    every = model.response(truth.parameters, record.input, record.sample_interval_s, None)
    kept = model.response(truth.parameters, record.input, record.sample_interval_s, 6)
    held_out = record.time_s > 1.2
    assert np.sqrt(np.mean((kept - every)[held_out] ** 2)) < 0.1 * truth.noise_m
    # the voltage's correction alone leaves the spring's share out: well above the noise
    reduced, _, _ = model.reduced_system(truth.parameters, modes=6)
    voltage_only = integrate_tip_cubic(model.modal_system(truth.parameters, modes=6),
                                       np.array([truth.parameters["tip_cubic_stiffness_N_m3"]]), record.input,
                                       record.sample_interval_s, static_gains=reduced["static"][:, :2])[0]
    assert np.sqrt(np.mean((voltage_only - every)[held_out] ** 2)) > truth.noise_m


def test_rows_stepped_together_match_the_one_row_kernel_checked_against_solve_ivp():
    """A batch of parameter sets with different substeps (grouped and stepped together) gives what
    each set gives alone through the one-row kernel, which the tests above check against an
    independent ODE solver."""
    model = BeamModel(GEOMETRY, EFFECTS)
    rng = np.random.default_rng(4)
    count = 12
    batch = {name: value * np.exp(rng.uniform(-0.3, 0.3, count)) for name, value in PARAMETERS.items()}
    batch["tip_cubic_stiffness_N_m3"] = np.exp(rng.uniform(np.log(1e3), np.log(3e8), count))
    voltage = chirp(400)
    system = model.modal_system(batch, modes=3)
    substeps = choose_substeps(system, batch["tip_cubic_stiffness_N_m3"], voltage, DT)
    assert np.unique(substeps).size > 3  # several groups, some of more than one row
    together = integrate_tip_cubic(system, batch["tip_cubic_stiffness_N_m3"], voltage, DT)
    for i in range(count):
        one = model.modal_system({k: v[i:i + 1] for k, v in batch.items()}, modes=3)
        alone = integrate_tip_cubic(one, batch["tip_cubic_stiffness_N_m3"][i:i + 1], voltage, DT, substeps=substeps[i:i + 1])
        assert np.abs(together[i] - alone[0]).max() <= 1e-10 * np.abs(alone).max()


def test_the_substep_rule_s_quartic_sum_by_moments_equals_the_triple_sum():
    """The force-content sum of :func:`choose_substeps`, sum_ijk c_i c_j c_k (w_i + w_j + w_k)^4,
    formed from five moments (multinomial theorem), against the explicit triple sum over every
    (i, j, k): weights spanning decades, unused slots at zero, frequencies of 1 to 1e4 rad/s."""
    rng = np.random.default_rng(17)
    weights = 10.0 ** rng.uniform(-6, -2, (40, 9))
    weights[:, -2:] = 0.0  # padded slots of rows with fewer pairs
    frequencies = 10.0 ** rng.uniform(0, 4, (40, 9))
    c, w = weights, frequencies
    explicit = np.einsum(
        "bi,bj,bk,bijk->b", c, c, c,
        (w[:, :, None, None] + w[:, None, :, None] + w[:, None, None, :]) ** 4,
    )
    np.testing.assert_allclose(_triple_quartic_sum(weights, frequencies), explicit, rtol=1e-13)


def _residue_matrices(system):
    """Poles (B, 2m) sorted and each pole's residue matrix output x input (B, 2m, n_out, n_in)."""
    order = np.lexsort((system.poles.imag, system.poles.real), axis=-1)
    poles = np.take_along_axis(system.poles, order, axis=1)
    outputs = np.take_along_axis(system.output_gains, order[:, None, :], axis=2)
    inputs = np.take_along_axis(system.input_gains, order[:, None, :], axis=2)
    return poles, np.einsum("boj,bij->bjoi", outputs, inputs)


def test_the_compiled_complex_modes_of_the_spring_path_equal_lapack_s():
    """The spring's modal system by the compiled Rayleigh-functional iteration
    (``modal.quadratic_complex_modes``) against dgeev on the first-order matrix (``complex_modes``):
    the same poles and residue matrices (voltage and tip force in, sensor and tip out) to 1e-10,
    with a non-proportional damping added, one overdamped set (left to dgeev), and the spring's
    response the same to 1e-10 of its peak."""
    from beam.physics import modal

    model = BeamModel(GEOMETRY, EFFECTS)
    rng = np.random.default_rng(11)
    count = 6
    batch = {name: value * np.exp(rng.uniform(-0.3, 0.3, count)) for name, value in PARAMETERS.items()}
    batch["tip_cubic_stiffness_N_m3"] = np.full(count, 3e7)
    reduced, _, _ = model.reduced_system(batch, modes=4)
    extra = rng.normal(size=(count, 4, 4))
    damping = reduced["damping"] + 2.0 * (extra @ np.swapaxes(extra, 1, 2))  # symmetric, non-proportional (1/s)
    damping[-1] += np.diag([2.0 * np.sqrt(reduced["omega2"][-1, 0]) * 3.0, 0, 0, 0])  # first mode overdamped
    inputs = np.stack([reduced["force"], reduced["tip"]], axis=1)
    outputs = np.stack([reduced["sensor"], reduced["tip"]], axis=1)
    lapack = modal.complex_modes(reduced["omega2"], damping, inputs, outputs)
    compiled = modal.quadratic_complex_modes(reduced["omega2"], damping, inputs, outputs)
    assert np.all(compiled.poles[:-1, 0::2].imag > 0)  # pairs adjacent, Im > 0 first, as from dgeev
    np.testing.assert_array_equal(compiled.poles[:-1, 1::2], np.conj(compiled.poles[:-1, 0::2]))
    poles_a, residues_a = _residue_matrices(lapack)
    poles_b, residues_b = _residue_matrices(compiled)
    np.testing.assert_allclose(poles_b, poles_a, rtol=1e-10)
    scale = np.abs(residues_a).max(axis=(1, 2, 3), keepdims=True)
    assert np.all(np.abs(residues_b - residues_a) <= 1e-10 * scale)
    k3 = batch["tip_cubic_stiffness_N_m3"]
    voltage = chirp(400)
    by_lapack = integrate_tip_cubic(lapack, k3, voltage, DT, static_gains=reduced["static"])
    by_compiled = integrate_tip_cubic(compiled, k3, voltage, DT, static_gains=reduced["static"])
    assert np.abs(by_compiled - by_lapack).max() <= 1e-10 * np.abs(by_lapack).max()
