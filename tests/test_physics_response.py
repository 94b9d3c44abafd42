"""The fast modal ZOH response against the full state space (lsim) and closed forms."""

import numpy as np
import pytest

from beam.errors import BeamInputError
from beam.physics import modal
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

GEOMETRY = BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.27438)
BASE = {"bending_stiffness_Nm2": 0.491, "patch_coupling_NmV": 1.746e-2}
DAMPING = {"air_damping_Ns_m2": 0.013, "kelvin_voigt_Nm2s": 0.649e-5}
DT = 1e-3


def chirp(n: int = 1500, amplitude: float = 10.0, start: float = 2.0, stop: float = 250.0, duration: float = 1.0):
    t = np.arange(n) * DT
    phase = 2 * np.pi * (start * t + (stop - start) * t**2 / (2 * duration))
    return np.where(t < duration, amplitude * np.sin(phase), 0.0)


CASES = {
    "proportional": (["air_damping", "kelvin_voigt"], DAMPING),
    "patch (non-proportional)": (
        ["air_damping", "kelvin_voigt", "patch_stiffening", "patch_damping"],
        dict(DAMPING, patch_added_density_kg_m=0.433, patch_added_stiffness_Nm2=0.793, patch_added_kelvin_voigt_Nm2s=1.255e-5),
    ),
    "tip mass": (["air_damping", "kelvin_voigt", "tip_mass"], dict(DAMPING, tip_mass_kg=0.01)),
    "compliant clamp": (["air_damping", "kelvin_voigt", "clamp_compliance"], dict(DAMPING, clamp_stiffness_Nm_rad=20.0)),
}


def relative_l2(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


@pytest.mark.parametrize("case", CASES)
def test_fast_path_with_all_modes_equals_full_state_space(case):
    """An algorithm check, on 16 elements: the round-off of both paths grows with the stiffest
    mode (as N⁴); at the default 40 elements the two agree to ~2e-8 and each is within 6e-9 of a
    40-digit reference over the first 600 samples (measured once, mpmath)."""
    effects, extra = CASES[case]
    model = BeamModel(GEOMETRY, effects, 16)
    parameters = dict(BASE, **extra)
    voltage = chirp()
    full = model.response_full(parameters, voltage, DT)
    fast = model.response(parameters, voltage, DT, modes=None)
    assert relative_l2(fast, full) <= 1e-8
    # four modes already carry the chirp's band: a percent-level truncation error, not more
    assert relative_l2(model.response(parameters, voltage, DT, modes=4), full) < 0.1


def test_single_mode_pulse_response_matches_its_closed_form():
    model = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"])
    parameters = dict(BASE, **DAMPING)
    n, width_samples, amplitude = 3000, 40, 5.0
    voltage = np.where(np.arange(n) < width_samples, amplitude, 0.0)
    reduced, _, _ = model.reduced_system(parameters, modes=1)
    omega = np.sqrt(reduced["omega2"][0, 0])
    zeta = reduced["damping"][0, 0, 0] / (2 * omega)
    gain = reduced["sensor"][0, 0] * reduced["force"][0, 0]
    omega_d = omega * np.sqrt(1 - zeta**2)

    def step(t):
        t = np.maximum(t, 0.0)
        decay = np.exp(-zeta * omega * t) * (np.cos(omega_d * t) + zeta * omega / omega_d * np.sin(omega_d * t))
        return gain * amplitude / omega**2 * (1 - decay)

    t = np.arange(n) * DT
    expected = step(t) - np.where(t >= width_samples * DT, step(t - width_samples * DT), 0.0)
    got = model.response(parameters, voltage, DT, modes=1, static_correction=False)
    np.testing.assert_allclose(got, expected, atol=1e-10 * np.abs(expected).max())
    # the static correction adds the discarded modes' quasi-static response D V[k], exactly
    corrected = model.response(parameters, voltage, DT, modes=1)
    np.testing.assert_allclose(corrected - got, reduced["static"][0, 0] * voltage, atol=1e-15)


def test_static_correction_reduces_the_truncation_error_and_vanishes_with_all_modes():
    effects, extra = CASES["patch (non-proportional)"]
    model = BeamModel(GEOMETRY, effects)
    parameters = dict(BASE, **extra)
    voltage = chirp(1500, stop=150.0)
    full = model.response_full(parameters, voltage, DT)
    for modes in (3, 4):
        plain = relative_l2(model.response(parameters, voltage, DT, modes, static_correction=False), full)
        corrected = relative_l2(model.response(parameters, voltage, DT, modes), full)
        assert corrected < 0.7 * plain
    reduced, _, _ = model.reduced_system(parameters, modes=None)
    np.testing.assert_allclose(reduced["static"], 0.0, atol=1e-20)


def test_batch_equals_one_call_per_parameter_set():
    effects, extra = CASES["patch (non-proportional)"]
    model = BeamModel(GEOMETRY, effects)
    rng = np.random.default_rng(3)
    base = dict(BASE, **extra)
    batch = {k: v * rng.uniform(0.8, 1.2, 6) for k, v in base.items()}
    voltage = chirp(800)
    together = model.response(batch, voltage, DT, modes=4)
    one_by_one = np.array([model.response({k: float(v[i]) for k, v in batch.items()}, voltage, DT, 4) for i in range(6)])
    np.testing.assert_allclose(together, one_by_one, rtol=0, atol=1e-12 * np.abs(one_by_one).max())


def test_mixed_batch_shared_shapes_and_an_overdamped_set_equal_the_full_state_space():
    """Sets sharing cached shapes, sets with their own, and one LAPACK fall-back, in one call
    (16 elements: an algorithm check, see the test above)."""
    effects, extra = CASES["patch (non-proportional)"]
    model = BeamModel(GEOMETRY, effects, 16)
    base = dict(BASE, **extra)
    scale = np.array([1.0, 1.1, 1.0, 0.9, 1.0])  # sets 0, 2 and 4 share their mode shapes
    batch = {k: v * scale if k == "patch_added_stiffness_Nm2" else np.full(5, v) for k, v in base.items()}
    batch["air_damping_Ns_m2"] = np.array([0.013, 0.02, 40.0, 0.013, 0.05])  # set 2: mode 1 overdamped
    batch["bending_stiffness_Nm2"] = np.array([0.491, 0.491, 0.491, 0.5, 0.45])
    voltage = chirp(700)
    together = model.response(batch, voltage, DT, modes=None)
    for i in range(5):
        one = {k: float(v[i]) for k, v in batch.items()}
        assert relative_l2(together[i], model.response_full(one, voltage, DT)) <= 1e-8
        assert relative_l2(together[i], model.response(one, voltage, DT, modes=None)) <= 1e-12


def test_non_finite_voltage_is_named_after_a_warm_call():
    model = BeamModel(GEOMETRY)
    voltage = chirp(200)
    model.response(BASE, voltage, DT)  # names and shapes cached: the fast path
    voltage[50] = np.nan
    with pytest.raises(BeamInputError, match="voltage_V holds NaN"):
        model.response(BASE, voltage, DT)
    with pytest.raises(BeamInputError, match="must be finite"):
        model.response(dict(BASE, bending_stiffness_Nm2=float("inf")), chirp(200), DT)


def test_rayleigh_iteration_poles_match_lapack():
    effects, extra = CASES["patch (non-proportional)"]
    model = BeamModel(GEOMETRY, effects)
    rng = np.random.default_rng(5)
    batch = {k: v * rng.uniform(0.5, 2.0, 20) for k, v in dict(BASE, **extra).items()}
    reduced, _, _ = model.reduced_system(batch, modes=5)
    poles, residues, ok = modal._quadratic_modes(reduced["omega2"], reduced["damping"], reduced["force"], reduced["sensor"])
    assert ok.all()
    lapack = modal.complex_modes(reduced["omega2"], reduced["damping"], reduced["force"][:, None], reduced["sensor"][:, None])
    upper = lapack.poles[:, 0::2]
    lapack_residues = (lapack.output_gains[:, 0] * lapack.input_gains[:, 0])[:, 0::2]
    mine, theirs = np.argsort(np.abs(poles), axis=1), np.argsort(np.abs(upper), axis=1)
    np.testing.assert_allclose(np.take_along_axis(poles, mine, 1), np.take_along_axis(upper, theirs, 1), rtol=1e-11)
    np.testing.assert_allclose(np.take_along_axis(residues, mine, 1), np.take_along_axis(lapack_residues, theirs, 1),
                               rtol=1e-8, atol=1e-12 * np.abs(lapack_residues).max())


def test_overdamped_modes_fall_back_to_lapack_and_stay_exact():
    model = BeamModel(GEOMETRY, ["air_damping"])
    parameters = dict(BASE, air_damping_Ns_m2=20.0)  # mode 1 overdamped
    voltage = chirp(600)
    full = model.response_full(parameters, voltage, DT)
    assert relative_l2(model.response(parameters, voltage, DT, modes=None), full) <= 1e-8


def test_mode_shapes_are_reused_when_only_scale_parameters_change():
    model = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"])
    voltage = chirp(500)
    model.response(dict(BASE, **DAMPING), voltage, DT)
    cached = len(model._shape_cache)
    stiffer = {**BASE, **DAMPING, "bending_stiffness_Nm2": 0.6, "patch_coupling_NmV": 0.03, "air_damping_Ns_m2": 0.05}
    got = model.response(stiffer, voltage, DT)
    assert len(model._shape_cache) == cached  # no new eigen-solve
    fresh = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"]).response(stiffer, voltage, DT)
    np.testing.assert_allclose(got, fresh, rtol=1e-10, atol=1e-16)


@pytest.mark.parametrize(
    "parameters, message",
    [
        ({"patch_coupling_NmV": 0.01}, "missing value for parameter 'bending_stiffness_Nm2'"),
        (dict(BASE, tip_mass_kg=0.1), "not part of this model"),
        (dict(BASE, bending_stiffness_Nm2=-1.0), "must be positive"),
        (dict(BASE, bending_stiffness_Nm2=float("nan")), "must be finite"),
        (dict(BASE, patch_coupling_NmV=np.ones(3), bending_stiffness_Nm2=np.ones(2)), "same length"),
    ],
)
def test_bad_parameters_give_clear_errors(parameters, message):
    with pytest.raises(BeamInputError, match=message):
        BeamModel(GEOMETRY).response(parameters, chirp(100), DT)


def test_more_modes_than_the_mesh_holds_is_a_clear_error():
    model = BeamModel(GEOMETRY, intervals=4)  # 4 elements, double knots at the patch ends: 7 functions
    with pytest.raises(BeamInputError, match="holds 7 modes"):
        model.response(BASE, chirp(100), DT, modes=8)
    with pytest.raises(BeamInputError, match="sample_interval_s"):
        model.response(BASE, chirp(100), 0.0)


def test_response_moves_smoothly_with_a_parameter_that_changes_the_mode_shapes():
    """Third differences of the response over steps of 1e-5 in log tip mass: a smooth function
    gives ~h³ (1e-15 of the signal here), round-off of the eigen-solve shows directly. On 40
    elements, eigen-solving K's M-whitened eigenproblem left 2e-10 m, 1.7e-8 of the signal (it
    spoiled the Newton steps and Hessians of tip-mass calibrations); inverted
    (beam.physics.modal.undamped_modes), 6e-14 m."""
    model = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt", "tip_mass"])
    parameters = dict(BASE, **DAMPING)
    voltage = chirp(1000)
    steps = np.exp(1e-5 * np.arange(-2, 2)) * 0.003
    responses = np.array([model.response(dict(parameters, tip_mass_kg=m), voltage, DT) for m in steps])
    assert np.abs(np.diff(responses, 3, axis=0)).max() < 1e-10 * np.abs(responses).max()
