"""The ``effective_length`` effect: the strip vibrates as if its free length were L_eff.

References: the model without the effect (nested identity at L_eff = L), the Euler–Bernoulli
cantilever's closed-form frequencies (beta_1 L = 1.8751041), a model assembled directly for the
shorter geometry, and a record simulated with a shorter true free length, calibrated back.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from beam.calibration import calibration_preview, make_setup
from beam.calibration.setup import build_problem
from beam.errors import BeamInputError
from beam.io.measurement import Measurement
from beam.physics.effects import CANDIDATE_EFFECTS, EFFECTS, applicable
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel
from beam.residuals.fingerprints import effect_scores

STATED, DENSITY = 0.419, 0.27
EI = 69e9 * 0.05 * 0.002**3 / 12  # a 50 x 2 mm aluminium strip
PATCHED = BeamGeometry(STATED, DENSITY, 0.01, 0.06, 0.409, force_position_m=0.3, width_m=0.05, thickness_m=0.002)
DAMPING = {"air_damping_Ns_m2": 5e-3, "kelvin_voigt_Nm2s": 2e-6}
BETA_1 = 1.8751040687119611  # first root of 1 + cos(bL) cosh(bL) = 0


def test_at_the_stated_length_the_model_is_the_model_without_the_effect():
    t = np.arange(600) / 2000.0
    u = scipy.signal.chirp(t, 2.0, t[-1], 200.0)
    for input_kind, extra in (("voltage", {"patch_coupling_NmV": 0.02}), ("force", {})):
        base = BeamModel(PATCHED, ["air_damping", "kelvin_voigt"], input_kind=input_kind)
        free = BeamModel(PATCHED, ["air_damping", "kelvin_voigt", "effective_length"], input_kind=input_kind)
        parameters = {"bending_stiffness_Nm2": EI, **DAMPING, **extra}
        with_length = dict(parameters, effective_length_m=STATED)
        for output in ("displacement", "acceleration", "strain"):
            np.testing.assert_array_equal(free.response(with_length, u, t[1], 4, output=output),
                                          base.response(parameters, u, t[1], 4, output=output))
        np.testing.assert_array_equal(free.natural_modes(with_length, 4)[0], base.natural_modes(parameters, 4)[0])
        np.testing.assert_array_equal(free.response_at(with_length, u, t, 4), base.response_at(parameters, u, t, 4))
    with pytest.raises(BeamInputError, match="effective_length_m"):
        free.response(parameters, u, t[1], 4)


def test_frequencies_follow_the_closed_form_of_the_free_length():
    """Uniform strip: f_1 = (beta_1² / 2 pi) sqrt(EI / (rho L_eff⁴)), and every mode scales as 1 / L_eff²."""
    geometry = BeamGeometry(STATED, DENSITY, None, None, STATED)
    model = BeamModel(geometry, ["effective_length"], input_kind=None)
    stated = model.natural_modes({"bending_stiffness_Nm2": EI, "effective_length_m": STATED}, 4)[0]
    for length in (0.365, 0.40, 0.45):
        frequencies = model.natural_modes({"bending_stiffness_Nm2": EI, "effective_length_m": length}, 4)[0]
        closed = BETA_1**2 / (2 * np.pi) * np.sqrt(EI / (DENSITY * length**4))
        assert frequencies[0] == pytest.approx(closed, rel=1e-6)
        # to the first-order eigensolver's round-off (dgeev: ~2e-9 on mode 1)
        np.testing.assert_allclose(frequencies, stated * (STATED / length) ** 2, rtol=1e-8)


def test_positions_keep_their_distance_from_the_tip():
    """Points in the outer half (and the patch) keep their distance from the tip."""
    shorter = PATCHED.with_free_length(0.365)
    shift = 0.365 - STATED
    assert shorter.length_m == 0.365
    assert shorter.sensor_position_m == pytest.approx(PATCHED.sensor_position_m + shift)
    assert shorter.force_position_m == pytest.approx(PATCHED.force_position_m + shift)
    assert shorter.patch_start_m == 0.0  # the patch reaches into the clamp: cut at its edge
    assert shorter.patch_end_m == pytest.approx(PATCHED.patch_end_m + shift)
    assert PATCHED.with_free_length(STATED) is PATCHED
    with pytest.raises(BeamInputError, match="sensor .* inside the clamp"):
        BeamGeometry(STATED, DENSITY, None, None, 0.3).with_free_length(0.1)
    # a sensor in the root half keeps its distance from the clamp instead (test_a_root_strain_gauge_...)
    assert BeamGeometry(STATED, DENSITY, None, None, 0.05).with_free_length(0.3).sensor_position_m == 0.05
    with pytest.raises(BeamInputError, match="sensor .* beyond the tip"):
        BeamGeometry(STATED, DENSITY, None, None, 0.05).with_free_length(0.04)
    # the model of a free length is the model assembled for that geometry
    parameters = {"bending_stiffness_Nm2": EI, "patch_coupling_NmV": 0.02, **DAMPING}
    direct = BeamModel(shorter, ["air_damping", "kelvin_voigt"])
    via = BeamModel(PATCHED, ["air_damping", "kelvin_voigt", "effective_length"])
    u = np.sin(np.arange(400) / 40.0)
    np.testing.assert_array_equal(via.response(dict(parameters, effective_length_m=0.365), u, 5e-4, 4),
                                  direct.response(parameters, u, 5e-4, 4))


def _clamped_curvature_over_tip(length: float, x: float, k: int) -> float:
    """phi_k''(x) / phi_k(L) of the exact Euler-Bernoulli clamped-free beam (1/m²)."""
    from scipy.optimize import brentq

    guess = (k - 0.5) * np.pi
    beta_l = brentq(lambda b: 1 + np.cos(b) * np.cosh(b), guess - 0.5, guess + 0.5)
    beta = beta_l / length
    sigma = (np.cosh(beta_l) + np.cos(beta_l)) / (np.sinh(beta_l) + np.sin(beta_l))
    curvature = beta**2 * (np.cosh(beta * x) + np.cos(beta * x) - sigma * (np.sinh(beta * x) + np.sin(beta * x)))
    tip = np.cosh(beta_l) - np.cos(beta_l) - sigma * (np.sinh(beta_l) - np.sin(beta_l))
    return float(curvature / tip)


def test_a_root_strain_gauge_keeps_its_distance_from_the_clamp_and_reads_the_exact_strain():
    """#38: a gauge 30 mm from the clamp of a stated 419 mm bar that vibrates as if 365 mm long reads
    the strain 30 mm from the clamp of a 365 mm cantilever: mode by mode, the model's strain at the
    gauge per unit tip displacement is the exact clamped-beam -(h/2) phi''(x) / phi(L_eff)."""
    h, gauge = 0.0048, 0.03
    geometry = BeamGeometry(STATED, 7850 * 0.025 * h, None, None, gauge, width_m=0.025, thickness_m=h)
    model = BeamModel(geometry, ["effective_length"], input_kind=None)
    stiffness = 200e9 * 0.025 * h**3 / 12
    for length in (0.365, 0.40, 0.45):
        assert geometry.with_free_length(length).sensor_position_m == gauge
        shorter = model.free_length_model(length)
        _, shapes = shorter.mode_shapes({"bending_stiffness_Nm2": stiffness}, 3)
        per_tip = -0.5 * h * (shorter.parts.sensor_curvatures @ shapes) / (shorter.parts.tip_values @ shapes)
        exact = [-0.5 * h * _clamped_curvature_over_tip(length, gauge, k) for k in (1, 2, 3)]
        # the Galerkin mesh's error grows with the mode: 1e-6, 1e-4, 1e-3 on modes 1-3
        assert np.all(np.abs(per_tip / np.array(exact) - 1) <= [1e-5, 3e-4, 3e-3]), (length, per_tip, exact)
    # the strain output of the model of that length is the gauge's
    free = {"bending_stiffness_Nm2": stiffness, "effective_length_m": 0.365}
    t = np.arange(200) / 4000.0
    direct = BeamModel(BeamGeometry(0.365, geometry.linear_density_kg_m, None, None, gauge, width_m=0.025, thickness_m=h),
                       [], input_kind=None)
    state = np.array([1e-3, 2e-4, 0, 0])
    np.testing.assert_array_equal(model.free_response(free, t, state, output="strain"),
                                  direct.free_response({"bending_stiffness_Nm2": stiffness}, t, state, output="strain"))


def test_a_batch_of_lengths_equals_one_call_per_length():
    model = BeamModel(PATCHED, ["air_damping", "kelvin_voigt", "effective_length"], input_kind="force")
    lengths = np.array([0.40, 0.365, 0.40, STATED])
    batch = {"bending_stiffness_Nm2": EI * np.array([1.0, 1.1, 0.9, 1.0]), **DAMPING, "effective_length_m": lengths}
    u = np.sin(np.arange(300) / 30.0)
    together = model.response(batch, u, 5e-4, 4, output="strain")
    reduced, values, batched = model.reduced_system(batch, 4)
    assert batched and np.array_equal(values["effective_length_m"], lengths)
    for b in range(lengths.size):
        one = {name: float(np.broadcast_to(value, lengths.shape)[b]) for name, value in batch.items()}
        np.testing.assert_allclose(together[b], model.response(one, u, 5e-4, 4, output="strain"), rtol=1e-12, atol=0)
        np.testing.assert_allclose(reduced["omega2"][b], model.reduced_system(one, 4)[0]["omega2"][0], rtol=1e-12)
    # free responses split their initial states with the batch
    free = BeamModel(PATCHED, ["air_damping", "effective_length"], input_kind=None)
    states = np.array([[1e-3, 0, 0, 0], [0, 1e-4, 0, 0]])
    two = {"bending_stiffness_Nm2": np.array([EI, EI]), "air_damping_Ns_m2": 5e-3, "effective_length_m": np.array([0.40, 0.365])}
    t = np.arange(100) / 2000.0
    out = free.free_response(two, t, states)
    for b in range(2):
        one = {"bending_stiffness_Nm2": EI, "air_damping_Ns_m2": 5e-3, "effective_length_m": float(two["effective_length_m"][b])}
        np.testing.assert_allclose(out[b], free.free_response(one, t, states[b]), rtol=1e-12)


def test_the_effect_is_a_candidate_without_a_patch_and_a_uniform_raising_points_to_it():
    assert "effective_length" in CANDIDATE_EFFECTS and EFFECTS["effective_length"].parameter_names == ("effective_length_m",)
    assert applicable("effective_length", frozenset({"no_patch"}))  # any clamped strip without a patch
    assert not applicable("effective_length", frozenset({"patch", "input"}))  # the patch would move into the clamp
    raised = effect_scores({"frequency_error_mean": 0.04, "mode1_deficit": 0.0})
    lowered = effect_scores({"frequency_error_mean": -0.04, "mode1_deficit": 0.0})
    assert raised["effective_length"] == pytest.approx(2.0) and raised["clamp_compliance"] == 0.0
    assert lowered["clamp_compliance"] == pytest.approx(2.0) and lowered["effective_length"] == 0.0


def simulated_short_record(true_length: float, seed: int = 0) -> tuple[Measurement, dict]:
    """A tip-sensor displacement record of a force-driven strip whose free length is ``true_length``
    (stated 0.419 m), every mode kept, 1 % noise; nominal EI 10 % off."""
    geometry = BeamGeometry(STATED, DENSITY, None, None, 0.409, force_position_m=0.409, width_m=0.05, thickness_m=0.002)
    truth = {"bending_stiffness_Nm2": EI, **DAMPING, "effective_length_m": true_length}
    model = BeamModel(geometry, ["air_damping", "kelvin_voigt", "effective_length"], input_kind="force")
    rate = 2000.0
    t = np.arange(3000) / rate
    force = 0.5 * scipy.signal.chirp(t, 2.0, t[-1], 150.0)
    clean = model.response(truth, force, 1 / rate, None)
    noise = 0.01 * np.sqrt(np.mean(clean**2))
    record = Measurement(name="short", title="short", geometry=geometry, time_s=t, force_N=force,
                         displacement_m=clean + np.random.default_rng(seed).normal(0.0, noise, t.size),
                         nominal={"bending_stiffness_Nm2": EI * 1.1})
    return record, dict(truth, noise=noise)


def test_the_prior_is_centred_on_the_stated_length():
    record, _ = simulated_short_record(0.365)
    setup = make_setup(record, effects="air_damping,kelvin_voigt,effective_length", window=(0.0, 1.0))
    prior = build_problem(setup).parameter("effective_length_m").prior
    assert prior.kind == "log-normal" and prior.median == STATED and prior.sigma == pytest.approx(0.1)
    assert 0 < prior.lower < 0.365 < STATED < prior.upper
    # the effect vanishes at the prior's centre: a nested fit's null start and a candidate's
    # "barely on" start put it exactly at the stated length
    from beam.calibration.starts.base import barely_on
    from beam.calibration.starts.null import null_value

    problem = build_problem(setup)
    assert null_value(problem, "effective_length_m") == pytest.approx(STATED, rel=1e-12)
    assert barely_on(problem, "effective_length_m") == pytest.approx(STATED, rel=1e-12)


def test_a_shorter_free_length_is_calibrated_back_with_its_frequencies():
    """Stated 0.419 m, vibrating as 0.365 m (13 % short, 1.4 prior sd): the length and EI come
    back inside their 95 % intervals, the calibrated model's first three frequencies within 0.3 %
    of the truth's (whose mode 1 is 30 % above the stated length's at the nominal EI)."""
    record, truth = simulated_short_record(0.365)
    result = calibration_preview(record, window=(0.0, 1.0), modes=4, effects="air_damping,kelvin_voigt,effective_length")
    summary = result.summary()
    for name in ("effective_length_m", "bending_stiffness_Nm2"):
        assert summary[name]["q025"] <= truth[name] <= summary[name]["q975"], (name, summary[name], truth[name])
    assert summary["effective_length_m"]["mean"] == pytest.approx(0.365, rel=5e-3)
    model = BeamModel(record.geometry, ["air_damping", "kelvin_voigt", "effective_length"], input_kind="force")
    fitted = {name: summary[name]["mean"] for name in model.parameter_names}
    reference = {name: truth[name] for name in model.parameter_names}
    np.testing.assert_allclose(model.natural_modes(fitted, 3)[0], model.natural_modes(reference, 3)[0], rtol=3e-3)
    assert abs(result.rmse_prediction / truth["noise"] - 1) < 0.05
