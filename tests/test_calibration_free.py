"""Calibration of free responses: variable projection, the analytic marginalisation of the initial
state and offset, simulated decays of known truth, and the bundled real records."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.special import logsumexp

from beam.calibration import calibration_preview, make_setup
from beam.calibration.free import ProjectedFreeModel, free_basis_at, free_prediction_at, free_rows_at
from beam.inference import NOISE_SD
from beam.io.measurement import Measurement, read_measurement
from beam.physics import modal
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

REAL = Path(__file__).resolve().parent.parent / "assets" / "real"
GEOMETRY = BeamGeometry(length_m=0.5, linear_density_kg_m=0.27, patch_start_m=None, patch_end_m=None, sensor_position_m=0.44)


def _free_model(effects=("modal_damping",)) -> BeamModel:
    return BeamModel(GEOMETRY, effects, 16, input_kind=None)


def test_basis_matches_the_physics_basis():
    """free_basis_at spans the columns of BeamModel.free_response_basis (same order, any reference)."""
    model = _free_model()
    values = {"bending_stiffness_Nm2": 2.1, "damping_ratio_mode_1": 0.01, "damping_ratio_mode_2": 0.02}
    t = np.linspace(0.3, 1.3, 400)
    reference = model.free_response_basis(values, t, modes=2)
    reduced, _, _ = model.reduced_system(values, 2)
    poles, _ = modal.modal_decomposition(reduced["omega2"], reduced["damping"])
    ours = free_basis_at(poles, t, t[0])[0]
    np.testing.assert_allclose(ours, reference, atol=1e-12)


def test_marginal_correction_matches_brute_force_sampling_of_the_amplitudes():
    """log ∫ p(y | theta, a) N(a; 0, A² I) da by Monte Carlo over the amplitudes (importance sampling
    from a wide Gaussian around the least-squares fit) equals profile log-likelihood + correction."""
    model = _free_model()
    values = {"bending_stiffness_Nm2": 2.1, "damping_ratio_mode_1": 0.05}
    rng = np.random.default_rng(1)
    t = np.sort(rng.uniform(0.0, 0.4, 60))
    truth = model.free_response(values, t, [0.02], [0.5], modes=1, output="acceleration") + 0.4
    sd = 0.3
    y = truth + sd * rng.standard_normal(t.size)
    forward = ProjectedFreeModel(model, 1, "acceleration", t, y)
    batch = {k: np.array([v]) for k, v in values.items()} | {NOISE_SD: np.array([sd])}
    fitted = forward(batch, t)[0]
    profile = -0.5 * np.sum((y - fitted) ** 2) / sd**2 - t.size * np.log(sd) - 0.5 * t.size * np.log(2 * np.pi)
    analytic = profile + forward.log_likelihood_correction(batch)[0]

    fit = forward.fit(batch)
    x = forward.design(fit["poles"], t)[0]  # (n, 3)
    a_hat = fit["amplitudes"][0]
    covariance = 4.0 * sd**2 * np.linalg.inv(x.T @ x)  # a proposal twice as wide as the posterior
    draws = rng.multivariate_normal(a_hat, covariance, 200_000)
    residual = y[None, :] - draws @ x.T
    log_like = -0.5 * np.sum(residual**2, axis=1) / sd**2 - t.size * np.log(sd) - 0.5 * t.size * np.log(2 * np.pi)
    a = forward.prior_sd
    log_prior = -0.5 * np.sum(draws**2, axis=1) / a**2 - 3 * np.log(a) - 1.5 * np.log(2 * np.pi)
    chol = np.linalg.cholesky(covariance)
    z = np.linalg.solve(chol, (draws - a_hat).T)
    log_proposal = -0.5 * np.sum(z**2, axis=0) - np.sum(np.log(np.diag(chol))) - 1.5 * np.log(2 * np.pi)
    brute = logsumexp(log_like + log_prior - log_proposal) - np.log(draws.shape[0])
    assert brute == pytest.approx(analytic, abs=0.02)
    # and it depends on the noise sd: a k-column fit costs k log(sd)
    other = dict(batch, **{NOISE_SD: np.array([2 * sd])})
    shift = forward.log_likelihood_correction(other)[0] - forward.log_likelihood_correction(batch)[0]
    assert shift == pytest.approx(3 * np.log(2.0), abs=1e-3)


def _simulated_decay(sensor_mass_kg=0.005, offset=0.43, sd=0.05, seed=3) -> Measurement:
    """An accelerometer's free decay of the strip with a sensor mass, irregular stamps, an offset."""
    rng = np.random.default_rng(seed)
    model = BeamModel(GEOMETRY, ("sensor_mass", "modal_damping"), 16, input_kind=None)
    truth = {"bending_stiffness_Nm2": 2.14, "sensor_mass_kg": sensor_mass_kg, "damping_ratio_mode_1": 0.005,
             "damping_ratio_mode_2": 0.006, "damping_ratio_mode_3": 0.01}
    t = np.cumsum(rng.uniform(0.6e-3, 1.4e-3, 6000))
    t -= t[0]
    acceleration = model.free_response(truth, t, [0.02, -0.002, 0.0003], [0.0, 0.0, 0.0], modes=3,
                                       output="acceleration")
    y = acceleration + offset + sd * rng.standard_normal(t.size)
    geometry = BeamGeometry(length_m=0.5, linear_density_kg_m=0.27, patch_start_m=None, patch_end_m=None, sensor_position_m=0.44)
    return Measurement("simulated_adxl", "simulated", geometry, t, acceleration_m_s2=y,
                       nominal={"bending_stiffness_Nm2": 2.333})


def test_simulated_free_decay_recovers_known_truth():
    """Irregular stamps, acceleration, offset, sensor mass: the calibration recovers them."""
    record = _simulated_decay()
    result = calibration_preview(record, window=(0.0, 2.0), effects="sensor_mass,modal_damping", modes=3)
    values = result.laplace.map.values
    assert float(values["sensor_mass_kg"]) == pytest.approx(0.005, rel=0.05)
    assert float(values["bending_stiffness_Nm2"]) == pytest.approx(2.14, rel=0.02)
    assert float(values["damping_ratio_mode_1"]) == pytest.approx(0.005, rel=0.1)
    linear = result.linear_fit()
    assert linear["output_offset"] == pytest.approx(0.43, abs=0.01)
    assert float(values[NOISE_SD]) == pytest.approx(0.05, rel=0.1)
    assert result.rmse_prediction_map < 0.08  # the held-out decay predicted to about the noise


def test_clipped_samples_are_left_out():
    record = _simulated_decay(sd=0.02)
    peak = float(np.max(record.output[:2000])) * 0.8
    clipped = Measurement(record.name, record.title, record.geometry, record.time_s,
                          acceleration_m_s2=np.minimum(record.output, peak), sensor_range=peak,
                          nominal=record.nominal)
    assert clipped.clipped_count > 0
    setup = make_setup(clipped, window=(0.0, 2.0), effects="sensor_mass,modal_damping", modes=3)
    assert setup.fit_mask.sum() == setup.window_mask.sum() - np.count_nonzero(clipped.clipped & setup.window_mask)
    result = calibration_preview(clipped, window=(0.0, 2.0), effects="sensor_mass,modal_damping", modes=3)
    assert float(result.laplace.map.values["sensor_mass_kg"]) == pytest.approx(0.005, rel=0.1)


# 114759 begins at rest and is released at 0.33 s; its window starts after the release transient
@pytest.mark.parametrize(("run", "window"), [("adxl_50cm_114655", (0.0, 2.0)), ("adxl_50cm_114759", (0.5, 2.5))])
def test_real_record_sensor_mass_repair(run, window):
    """The bundled strip records: with a sensor mass the model's two frequencies are within 0.2 % of
    the record's spectral peaks, the mass is a few grams, the offset ~0.43 m/s², and the
    calibration-window RMSE falls at least 2x against modal damping alone."""
    record = read_measurement(REAL / f"{run}.csv")
    base = calibration_preview(record, window=window, effects="modal_damping", modes=4)
    repaired = calibration_preview(record, window=window, effects="sensor_mass,modal_damping", modes=4)
    values = {k: float(v) for k, v in repaired.laplace.map.values.items() if k in repaired.setup.physical_names}
    frequencies = repaired.setup.model.natural_modes(values, 2)[0]
    # the record's spectral peaks (the window, offset removed), interpolated to a uniform grid
    inside = (record.time_s >= window[0]) & (record.time_s <= window[1])
    t, y = record.time_s[inside], record.output[inside]
    step = 1e-4
    grid = np.arange(t[0], t[-1], step)
    signal = np.interp(grid, t, y) - np.mean(y)
    n_fft = 2**22
    spectrum = np.abs(np.fft.rfft(signal * np.hanning(grid.size), n_fft))
    f = np.fft.rfftfreq(n_fft, step)
    peaks = [f[(f > lo) & (f < hi)][np.argmax(spectrum[(f > lo) & (f < hi)])] for lo, hi in ((4, 8), (30, 50))]
    np.testing.assert_allclose(frequencies, peaks, rtol=0.002)
    assert 0.002 < values["sensor_mass_kg"] < 0.008
    # the offset measured in phase 1 is 0.434 m/s²; a 2 s window of a decay with amplitude-dependent
    # damping biases it by up to a few hundredths of a m/s² (0.3 % of the signal's peak)
    assert repaired.linear_fit()["output_offset"] == pytest.approx(0.434, abs=0.03)
    assert base.rmse_calibration >= 2.0 * repaired.rmse_calibration


def test_release_after_a_quiet_lead_in():
    """114759 is held at rest for 0.33 s: the free response (and the fit) starts at the release."""
    from beam.calibration.free import release_index

    record = read_measurement(REAL / "adxl_50cm_114759.csv")
    start = record.time_s[release_index(record.output)]
    assert 0.30 < start < 0.34
    before = record.output[record.time_s < start]
    after = record.output[(record.time_s >= start) & (record.time_s < start + 1.0)]
    assert np.std(before) < 0.02 * np.std(after)  # at rest before, moving after
    moving = read_measurement(REAL / "adxl_50cm_114655.csv")
    assert release_index(moving.output) == 0


def test_driven_records_of_every_output_on_irregular_stamps():
    """A point force (known), irregular stamps, velocity and acceleration outputs: the forward model
    steps the recorded stamps and the calibration recovers EI and the damping."""
    rng = np.random.default_rng(7)
    geometry = BeamGeometry(length_m=0.5, linear_density_kg_m=0.27, patch_start_m=None, patch_end_m=None,
                            sensor_position_m=0.44, force_position_m=0.3)
    model = BeamModel(geometry, ("modal_damping",), input_kind="force")  # the calibration's default mesh
    truth = {"bending_stiffness_Nm2": 2.2, "damping_ratio_mode_1": 0.01, "damping_ratio_mode_2": 0.02}
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 3000))
    t -= t[0]
    force = np.where(t < 0.005, 1.0, 0.0)  # a short hammer pulse
    for output, column in (("velocity", "velocity_m_s"), ("acceleration", "acceleration_m_s2")):
        clean = model.response_at(truth, force, t, modes=2, output=output)
        y = clean + 0.01 * np.std(clean) * rng.standard_normal(t.size)
        record = Measurement("hammer", "hammer", geometry, t, force_N=force, **{column: y},
                             nominal={"bending_stiffness_Nm2": 2.333})
        setup = make_setup(record, window=(0.0, 1.0), effects="modal_damping", modes=2)
        prediction = setup.forward({k: np.array([v]) for k, v in truth.items()}, record.time_s[setup.fit_mask])[0]
        np.testing.assert_allclose(prediction, clean[setup.fit_mask], rtol=1e-9, atol=1e-12 * np.abs(clean).max())
        result = calibration_preview(record, window=(0.0, 1.0), effects="modal_damping", modes=2)
        values = result.laplace.map.values
        assert float(values["bending_stiffness_Nm2"]) == pytest.approx(2.2, rel=0.005)
        assert float(values["damping_ratio_mode_1"]) == pytest.approx(0.01, rel=0.05)
        assert result.rmse_prediction_map < 0.03 * np.std(clean)


def test_candidates_fit_the_record():
    """sensor_mass is offered for an accelerometer's record; patch effects need a patch; the cubic
    tip spring needs a driven, uniform displacement record."""
    from beam.discovery.ranking import candidate_effects

    record = read_measurement(REAL / "adxl_50cm_114655.csv")
    offered = candidate_effects(("modal_damping",), record)
    assert "sensor_mass" in offered and "tip_mass" in offered
    assert "patch_stiffening" not in offered and "tip_cubic_spring" not in offered
    assert "sensor_mass" not in candidate_effects(("modal_damping",))  # without a record: the catalogue's


def test_verdict_names_repairs_the_data_cannot_tell_apart():
    from beam.discovery.report import verdict_sentence

    both = verdict_sentence("sensor_mass", 3838.0, 1.12, 0.14, None, unit="m/s²", alternatives=["tip_mass"],
                            error_label="calibration-window RMSE")
    assert "cannot tell it from tip_mass" in both and "m/s²" in both and "calibration-window RMSE" in both
    partly = verdict_sentence("sensor_mass", 3838.0, 1.12, 0.14, None, unit="m/s²", partly=[("tip_mass", 2)])
    assert "tip_mass places modes 1-2 as well, only mode 3 tells them apart" in partly


def test_damped_away_starts_one_per_mode_inside_the_prior():
    """One start per mode's damping ratio, that ratio 2 % of its log prior range below the top,
    every other value the start's."""
    from beam.calibration.free_starts import DAMPED_AWAY, damped_away_starts

    record = read_measurement(REAL / "adxl_50cm_114655.csv")
    result = calibration_preview(record, window=(0.0, 2.0), effects="modal_damping", modes=3)
    problem = result.problem
    start = {name: float(result.laplace.map.values[name]) for name in result.setup.physical_names}
    starts = damped_away_starts(problem, start)
    names = [f"damping_ratio_mode_{j}" for j in (1, 2, 3)]
    assert len(starts) == 3
    for name, s in zip(names, starts):
        prior = problem.parameter(name).prior
        expected = np.exp(np.log(prior.upper) - DAMPED_AWAY * np.log(prior.upper / prior.lower))
        assert s[name] == pytest.approx(expected, rel=1e-12) and prior.lower < s[name] < prior.upper
        assert {k: v for k, v in s.items() if k != name} == {k: v for k, v in start.items() if k != name}


def test_damped_away_starts_take_the_frequencies_of_the_best_screened_start():
    """With a point mass the damped-away starts carry EI and the mass of the screened start with
    the lowest residual RMS (scored here one by one) and the centre's damping ratios; the MAP is
    the one the old starts (damped away from the prior centre, mass barely on) reach, to the
    search's tolerance (a second search)."""
    from beam.calibration import prepare
    from beam.calibration.fit import fast_map
    from beam.calibration.free_starts import damped_away_starts

    record = read_measurement(REAL / "adxl_50cm_114655.csv")
    from beam.calibration import Engine

    # a fresh engine: no sub-model remembered, so no null starts (beam.calibration.starts.null)
    setup, problem = prepare(record, window=(0.0, 2.0), effects="modal_damping,sensor_mass", search=False,
                             engine=Engine())
    starts = problem.initial_guesses(problem)
    damped = [s for s in starts if max(s[n] for n in s if n.startswith("damping_ratio")) > 0.2]
    screened = [s for s in starts if s not in damped]
    assert len(damped) == 4 and len(screened) == 4
    rms = [float(np.sqrt(np.mean((problem.data - problem.predict({k: np.array([v]) for k, v in s.items()})) ** 2)))
           for s in screened]
    best, centre = screened[int(np.argmin(rms))], screened[0]
    assert best["sensor_mass_kg"] > 10 * centre["sensor_mass_kg"]  # the centre's mass is barely on
    for s in damped:
        assert s["sensor_mass_kg"] == best["sensor_mass_kg"] and s["bending_stiffness_Nm2"] == best["bending_stiffness_Nm2"]
        kept = [n for n in s if n.startswith("damping_ratio") and s[n] < 0.2]
        assert len(kept) == 3 and all(s[n] == centre[n] for n in kept)
    new = fast_map(problem, starts)
    old = fast_map(problem, screened + damped_away_starts(problem, centre))
    assert new.log_posterior == pytest.approx(old.log_posterior, abs=1e-3)
    for name in ("bending_stiffness_Nm2", "sensor_mass_kg", "damping_ratio_mode_1", "damping_ratio_mode_2"):
        assert new.values[name] == pytest.approx(old.values[name], rel=1e-4)


def test_a_mode_the_model_cannot_place_is_damped_away_at_the_map():
    """114759, window 0-2 s, modal damping alone: the base model cannot place the third mode.
    Fitted from the release (0.329 s) its posterior piled against the top of the mode's damping
    ratio, 190 nats above the small-damping optimum the spectral starts alone reached; fitted from
    the end of the release's transient (0.397 s) the damped-away basin is no longer the best
    (ζ3 ~0.05 at the MAP). Either way the preview's MAP must be at least as high as a search
    started inside the damped-away basin (a second method), to the search's tolerance."""
    from beam.calibration.fit import fast_map

    record = read_measurement(REAL / "adxl_50cm_114759.csv")
    result = calibration_preview(record, window=(0.0, 2.0), effects="modal_damping", modes=4)
    problem = result.problem
    found = result.laplace.map
    # the independent reference: a search from inside the damped-away basin (the mean of a long
    # sampler run, which climbed there from the old MAP), not from the starts of the preview
    reference = fast_map(problem, [{"bending_stiffness_Nm2": 1.972, "damping_ratio_mode_1": 0.0051,
                                    "damping_ratio_mode_2": 0.0276, "damping_ratio_mode_3": 0.29,
                                    "damping_ratio_mode_4": 0.074}])
    # at that optimum or above it (the reference's search stops within its tolerance, ~0.02 nats)
    assert found.log_posterior >= reference.log_posterior - 0.01


def test_tabulated_basis_and_prediction_match_the_closed_form_on_a_long_irregular_record():
    """On logger stamps (1 µs quantum, 20 s, irregular steps) the tabulated columns and
    predictions (power tables re-anchored every few hundred entries, a term left out where its
    envelope is below 1e-13 of its value at the reference) equal exp(lambda tau) evaluated directly, for a light,
    a moderate and a heavy damping and an overdamped (real) pole pair."""
    rng = np.random.default_rng(11)
    t = np.round(np.cumsum(rng.uniform(0.9e-3, 1.1e-3, 19_000)), 6) + 0.25
    poles = np.array([[-0.19 + 38.0j, -0.19 - 38.0j, -1.2 + 245.0j, -1.2 - 245.0j, -12.0 + 694.0j, -12.0 - 694.0j,
                       -370.0 + 1360.0j, -370.0 - 1360.0j, -50.0 + 0.0j, -900.0 + 0.0j]])
    reference = t[0]
    tau = t - reference
    _check_tabulated(poles, t, reference, tau, rng)
    # a reference after the first samples (a record that starts at rest: the fit starts at the
    # release): before it the decaying terms grow backwards and must not set what is negligible
    _check_tabulated(poles, t, t[400], t - t[400], rng)


def _check_tabulated(poles, t, reference, tau, rng):
    from beam.calibration.free import free_prediction_at, free_rows_at

    columns = []
    for j in (0, 2, 4, 6):
        z = np.exp(poles[0, j] * tau)
        columns += [z.real, z.imag]
    columns += [np.exp(poles[0, 8].real * tau), np.exp(poles[0, 9].real * tau)]
    exact = np.array(columns)
    # the error allowed: 1e-12 of each column's envelope, at least 1e-12 (a term left out after
    # the reference is below 1e-13)
    envelope = np.maximum(np.exp(np.repeat(poles[0, [0, 2, 4, 6, 8, 9]].real, [2, 2, 2, 2, 1, 1])[:, None] * tau), 1.0)
    rows = free_rows_at(poles, t, reference, 1)[0]
    assert np.all(np.abs(rows[:-1] - exact) <= 1e-12 * envelope)
    assert np.all(rows[-1] == 1.0)
    amplitudes = rng.normal(size=(1, 11))
    predicted = free_prediction_at(poles, amplitudes, t, reference, offset=True)[0]
    expected = amplitudes[0, :10] @ exact + amplitudes[0, 10]
    assert np.all(np.abs(predicted - expected) <= 1e-12 * (np.abs(amplitudes[0, :10]) @ envelope + abs(amplitudes[0, 10])))


def test_spectral_scales_maximise_the_interpolated_log_power():
    """Each row's EI scale is the grid point maximising the summed log of the record's power at
    sqrt(scale) x its modes (np.interp of the power; modes beyond 0.8 x Nyquist or scaled beyond
    0.95 x Nyquist score the floor), by a direct numpy evaluation."""
    from beam.calibration.free_starts import record_spectrum, spectral_scales
    from beam.calibration.starts import SCALE_GRID

    record = read_measurement(REAL / "adxl_50cm_114655.csv")
    inside = record.time_s < 2.0
    frequencies, power = record_spectrum(record.time_s[inside], record.output[inside])
    rng = np.random.default_rng(4)
    model = np.sort(rng.uniform(3.0, 300.0, (40, 4)), axis=1)
    model[:, 3] *= 3.0  # some modes beyond Nyquist (499 Hz)
    nyquist = frequencies[-1]
    floor = power.max() * 1e-12 + 1e-300
    expected = []
    for row in model:
        scaled = np.sqrt(SCALE_GRID)[:, None] * row[None, :]
        ok = (row > 0) & (row < 0.8 * nyquist) & (scaled < 0.95 * nyquist)
        score = np.where(ok, np.log(np.interp(scaled, frequencies, power) + floor), np.log(floor)).sum(axis=1)
        expected.append(SCALE_GRID[np.argmax(score)])
    np.testing.assert_allclose(spectral_scales(model, (frequencies, power)), expected, rtol=1e-12)


def _released_decay(seed=5) -> tuple[Measurement, float]:
    """A free decay of modes 1-3 after 0.3 s at rest, its release ringing modes 4-6 strongly for a
    few hundredths of a second (as a hand's snap does), irregular stamps, an offset; and the release time."""
    rng = np.random.default_rng(seed)
    model = BeamModel(GEOMETRY, ("sensor_mass", "modal_damping"), 16, input_kind=None)
    ratios = [0.005, 0.006, 0.01, 0.035, 0.021, 0.014]
    truth = {"bending_stiffness_Nm2": 2.14, "sensor_mass_kg": 0.005,
             **{f"damping_ratio_mode_{k + 1}": r for k, r in enumerate(ratios)}}
    t = np.cumsum(rng.uniform(0.6e-3, 1.4e-3, 6000))
    t -= t[0]
    release_s = 0.3
    moving = t >= release_s
    y = np.zeros(t.size)
    # modes 4-6 start at accelerations several times those of modes 1-3 (a snap), then die out
    y[moving] = model.free_response(truth, t[moving], [0.02, -0.002, 0.0003, 0.0002, -0.0001, 0.00005], np.zeros(6),
                                    modes=6, output="acceleration")
    y += 0.43 + 0.05 * rng.standard_normal(t.size)
    return Measurement("released_adxl", "simulated", GEOMETRY, t, acceleration_m_s2=y,
                       nominal={"bending_stiffness_Nm2": 2.333}), release_s


def test_the_free_response_starts_after_the_release_transient():
    """The fit starts where the content above the retained modes' band has died out to 5 % of
    the motion in it, not at the release; the known truth is then recovered with 3 modes."""

    from beam.calibration.free import TRANSIENT_FRACTION, free_start_indices, retained_band

    record, release_s = _released_decay()
    release, start = free_start_indices(record, 3)
    t = record.time_s
    assert t[release] == pytest.approx(release_s, abs=0.003)
    # the truth: the noise-free ringing of modes 4-6 against modes 1-3, on a fine uniform grid
    model = BeamModel(GEOMETRY, ("sensor_mass", "modal_damping"), 16, input_kind=None)
    truth = {"bending_stiffness_Nm2": 2.14, "sensor_mass_kg": 0.005,
             **{f"damping_ratio_mode_{k + 1}": r for k, r in enumerate([0.005, 0.006, 0.01, 0.035, 0.021, 0.014])}}
    fine = release_s + np.arange(0.0, 0.5, 1e-4)
    eta = np.array([0.02, -0.002, 0.0003, 0.0002, -0.0001, 0.00005])
    high = model.free_response(truth, fine, eta * [0, 0, 0, 1, 1, 1], np.zeros(6), modes=6, output="acceleration")
    low = model.free_response(truth, fine, eta * [1, 1, 1, 0, 0, 0], np.zeros(6), modes=6, output="acceleration")
    edge, _ = retained_band(record, 3)
    assert 115 < edge < 226  # between the bare beam's modes 3 and 4
    # the ringing's RMS (over a few of its periods) against the RMS of modes 1-3, from the separate,
    # noise-free parts: where it falls below the fraction for good
    rms = np.sqrt(np.convolve(high * high, np.ones(50) / 50, mode="same"))
    done = fine[np.flatnonzero(rms > TRANSIENT_FRACTION * np.std(low))[-1]]
    assert 0.03 < done - release_s < 0.2
    assert done - 0.02 < t[start] < done + 0.03  # within the detector's sliding windows
    result = calibration_preview(record, window=(0.0, 2.3), effects="sensor_mass,modal_damping", modes=3)
    assert result.setup.free_start_s == pytest.approx(t[start])
    assert result.setup.free_start_indices == (release, start)
    values = result.laplace.map.values
    assert float(values["sensor_mass_kg"]) == pytest.approx(0.005, rel=0.05)
    assert float(values["bending_stiffness_Nm2"]) == pytest.approx(2.14, rel=0.02)
    assert float(values["damping_ratio_mode_1"]) == pytest.approx(0.005, rel=0.1)
    # the bands describe the beam from the free response's start on (no prediction before it:
    # extrapolated backwards the decaying terms grow without bound), and contain the data there
    bands = result.bands
    assert bands.time_s.size == t.size
    assert np.all(np.isnan(bands.mean[:start])) and np.all(np.isnan(bands.prediction_upper[:start]))
    assert np.all(np.isfinite(bands.mean[start:])) and np.all(np.isfinite(bands.prediction_lower[start:]))
    fit = result.setup.fit_mask
    inside = (record.output >= bands.prediction_lower) & (record.output <= bands.prediction_upper)
    assert inside[fit].mean() > 0.9
    # a decay without a release transient is fitted from its first sample
    assert free_start_indices(_simulated_decay(), 3) == (0, 0)


def test_retained_poles_match_the_dense_eigen_solve():
    """The closed-form poles of a diagonal reduced damping equal the dense solve's, in its order
    (underdamped and overdamped modes; not exactly critical damping, a defective matrix whose dense
    eigenvalues split by round-off)."""
    from beam.calibration.free import retained_poles

    rng = np.random.default_rng(1)
    omega2 = np.sort(rng.uniform(10.0, 1e6, (60, 4)), axis=1)
    zeta = rng.choice([0.001, 0.01, 0.3, 0.99, 1.01, 1.5, 3.0], (60, 4))
    damping = np.zeros((60, 4, 4))
    damping[:, np.arange(4), np.arange(4)] = 2.0 * zeta * np.sqrt(omega2)
    expected, _ = modal.modal_decomposition(omega2, damping)
    np.testing.assert_allclose(retained_poles(omega2, damping), expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())
    coupled = damping.copy()
    coupled[:, 0, 1] = coupled[:, 1, 0] = 1.0
    np.testing.assert_allclose(retained_poles(omega2, coupled), modal.modal_decomposition(omega2, coupled)[0])


def _eigen_reference(gram, c, lam, sd2):
    """The eigen-decomposition forms (the previous method): pseudo-inverse amplitudes dropping
    eigenvalues below 1e-13 of the largest, and the correction's two sums over the kept ones."""
    g, vectors = np.linalg.eigh(gram)
    d = np.einsum("bij,bi->bj", vectors, c)
    usable = g > 1e-13 * np.max(np.abs(g), axis=1, keepdims=True)
    coefficients = np.where(usable, d / np.where(usable, g, 1.0), 0.0)
    amplitudes = np.einsum("bij,bj->bi", vectors, coefficients)
    g = np.where(usable, g, 0.0)
    d2g = coefficients**2 * g
    correction = -0.5 * np.sum(np.log1p(g / lam), axis=1) - 0.5 * np.sum(d2g * lam / (g + lam), axis=1) / sd2
    return amplitudes, correction


def test_gram_solve_matches_the_eigen_pseudo_inverse_on_random_cases():
    """Cholesky amplitudes equal the eigen-decomposition's pseudo-inverse, including a rank-deficient
    Gram matrix (a repeated column) that the Cholesky bound must send to the eigen path."""
    from beam.calibration.free import gram_solve

    rng = np.random.default_rng(5)
    rows = rng.normal(size=(40, 7, 300)) * np.logspace(-1, 1, 7)[None, :, None]
    rows[3, 6] = rows[3, 5]  # singular: the pseudo-inverse splits the amplitude between the twins
    gram = rows @ np.swapaxes(rows, 1, 2)
    c = np.einsum("bkn,n->bk", rows, rng.normal(size=300))
    for part in (np.arange(40) != 3, np.arange(40) < 10):  # definite; then one singular in the batch
        amplitudes, certified = gram_solve(gram[part], c[part])
        reference, _ = _eigen_reference(gram[part], c[part], 1.0, 1.0)
        assert certified.all() if part[3] == 0 else not certified[3]
        fitted, fitted_ref = (np.einsum("bkn,bk->bn", rows[part], a) for a in (amplitudes, reference))
        np.testing.assert_allclose(fitted, fitted_ref, rtol=0, atol=1e-9 * np.max(np.abs(fitted_ref)))
        if part[3] == 0:  # a definite G: the same amplitudes, each to its own scale
            np.testing.assert_allclose(amplitudes, reference, rtol=1e-5)


def test_correction_by_cholesky_matches_the_eigen_form():
    """log_likelihood_correction (Cholesky of G + lam I) equals the eigen-decomposition's sums on a
    batch of random parameter sets of a real record's window."""
    record = read_measurement(REAL / "adxl_50cm_114655.csv")
    keep = (record.time_s >= 0.5) & (record.time_s < 1.0)
    model = _free_model(("modal_damping", "sensor_mass"))
    forward = ProjectedFreeModel(model, 3, "acceleration", record.time_s[keep], record.output[keep])
    rng = np.random.default_rng(2)
    batch = {"bending_stiffness_Nm2": rng.uniform(1.9, 2.3, 50), "sensor_mass_kg": rng.uniform(1e-3, 8e-3, 50),
             NOISE_SD: rng.uniform(0.05, 0.5, 50)}
    batch |= {f"damping_ratio_mode_{i}": rng.uniform(0.002, 0.05, 50) for i in (1, 2, 3)}
    correction = forward.log_likelihood_correction(batch)
    fit = forward.fit(batch)
    sd2 = batch[NOISE_SD] ** 2
    amplitudes, reference = _eigen_reference(fit["gram"], fit["c"], (sd2 / forward.prior_sd**2)[:, None], sd2)
    assert fit["certified"].all()
    np.testing.assert_allclose(correction, reference, rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(fit["amplitudes"], amplitudes, rtol=1e-7, atol=1e-9 * np.max(np.abs(amplitudes)))


def test_repeated_sets_fit_as_each_alone():
    """A batch whose sets repeat (only the noise sd differs, as in the Newton polish's stencil)
    gives every set the fit, prediction and marginal correction it gets alone."""
    record = read_measurement(REAL / "adxl_50cm_114655.csv")
    keep = (record.time_s >= 0.5) & (record.time_s < 1.0)
    model = _free_model(("modal_damping", "sensor_mass"))
    forward = ProjectedFreeModel(model, 3, "acceleration", record.time_s[keep], record.output[keep])
    rng = np.random.default_rng(4)
    distinct = {"bending_stiffness_Nm2": rng.uniform(1.9, 2.3, 5), "sensor_mass_kg": rng.uniform(1e-3, 8e-3, 5)}
    distinct |= {f"damping_ratio_mode_{i}": rng.uniform(0.002, 0.05, 5) for i in (1, 2, 3)}
    pick = np.array([3, 0, 3, 1, 4, 0, 2, 3])
    batch = {name: v[pick] for name, v in distinct.items()} | {NOISE_SD: rng.uniform(0.05, 0.5, pick.size)}
    correction = forward.log_likelihood_correction(batch)
    later = record.time_s[(record.time_s >= 1.0) & (record.time_s < 1.2)]
    prediction = forward(batch, later)
    for row, i in enumerate(pick):
        one = {name: v[i : i + 1] for name, v in distinct.items()} | {NOISE_SD: batch[NOISE_SD][row : row + 1]}
        alone = ProjectedFreeModel(model, 3, "acceleration", record.time_s[keep], record.output[keep])
        fit = alone.fit(one)
        np.testing.assert_allclose(forward.fit(batch)["amplitudes"][row], fit["amplitudes"][0], rtol=1e-12)
        np.testing.assert_allclose(forward.fit(batch)["fitted"][row], fit["fitted"][0], rtol=1e-12,
                                   atol=1e-12 * np.max(np.abs(fit["fitted"])))
        np.testing.assert_allclose(correction[row], alone.log_likelihood_correction(one)[0], rtol=1e-12)
        np.testing.assert_allclose(prediction[row], alone(one, later)[0], rtol=1e-12,
                                   atol=1e-12 * np.max(np.abs(prediction[row])))


def test_chained_and_tabulated_paths_match_the_closed_form_with_gaps():
    """Stamps in increasing order take the chain over their distinct steps (an exact anchor every
    128 samples), the same stamps in another order the two-level power tables: both equal
    exp(lambda tau) evaluated directly on a record with gaps up to 100 median steps (distinct
    steps from 0.8 to 100 ms), a reference inside the record, and sets of different damping in
    one call (terms left out at different samples)."""
    from beam.calibration.free import ChainLayout, _layout

    rng = np.random.default_rng(12)
    steps = rng.uniform(0.8e-3, 1.2e-3, 6_000)
    steps[rng.choice(steps.size, 40, replace=False)] = rng.uniform(5e-3, 0.1, 40)  # gaps
    t = np.round(np.cumsum(steps), 6) + 0.5
    reference = t[50]
    base = np.array([-0.3 + 38.0j, -0.3 - 38.0j, -2.0 + 245.0j, -2.0 - 245.0j, -40.0 + 694.0j, -40.0 - 694.0j,
                     -30.0 + 0.0j, -700.0 + 0.0j])
    poles = np.array([base * scale for scale in (1.0, 1.3, 0.7, 2.0, 0.2)])  # five sets: one group of four and one
    assert isinstance(_layout(t - reference), ChainLayout)
    order = rng.permutation(t.size)
    assert not isinstance(_layout(t[order] - reference), ChainLayout)
    tau = t - reference
    amplitudes = rng.normal(size=(poles.shape[0], 9))
    for stamps, index in ((t, np.arange(t.size)), (t[order], order)):
        rows = free_rows_at(poles, stamps, reference, 1)
        predicted = free_prediction_at(poles, amplitudes, stamps, reference, offset=True)
        for b in range(poles.shape[0]):
            columns = []
            for j in (0, 2, 4):
                z = np.exp(poles[b, j] * tau)
                columns += [z.real, z.imag]
            columns += [np.exp(poles[b, 6].real * tau), np.exp(poles[b, 7].real * tau)]
            exact = np.array(columns)[:, index]
            envelope = np.maximum(np.exp(np.repeat(poles[b, [0, 2, 4, 6, 7]].real, [2, 2, 2, 1, 1])[:, None] * tau[index]),
                                  1.0)
            assert np.all(np.abs(rows[b, :-1] - exact) <= 1e-12 * envelope)
            assert np.all(rows[b, -1] == 1.0)
            expected = amplitudes[b, :8] @ exact + amplitudes[b, 8]
            bound = 1e-12 * (np.abs(amplitudes[b, :8]) @ envelope + abs(amplitudes[b, 8]))
            assert np.all(np.abs(predicted[b] - expected) <= bound)


def test_remembered_free_start_is_the_records_own():
    """free_start_indices remembers its last records: asked again (another object with the same
    samples) it answers as computed afresh, and a record whose output differs is not confused
    with one remembered."""
    from dataclasses import replace

    from beam.calibration.free import free_response_start, free_start_indices, retained_band

    record, _ = _released_decay()
    fresh = free_response_start(record.time_s, record.output, *retained_band(record, 3))
    assert free_start_indices(record, 3) == fresh
    assert free_start_indices(replace(record, acceleration_m_s2=record.output.copy()), 3) == fresh
    moved = np.concatenate([np.zeros(200), record.output[:-200]])  # released 200 samples later
    other = replace(record, acceleration_m_s2=moved)
    expected = free_response_start(other.time_s, other.output, *retained_band(other, 3))
    assert expected != fresh
    assert free_start_indices(other, 3) == expected
    assert free_start_indices(record, 3) == fresh


def test_spectral_scales_by_products_and_by_log_sums_agree():
    """The product kernel (up to 16 modes) picks the scale the sum of logarithms picks, for 1 to
    16 modes, some beyond Nyquist; 20 modes take the sums themselves."""
    from beam.calibration.free_starts import _best_scales, record_spectrum, spectral_scales
    from beam.calibration.starts import SCALE_GRID

    record = read_measurement(REAL / "adxl_50cm_114759.csv")
    inside = (record.time_s > 0.5) & (record.time_s < 3.0)
    frequencies, power = record_spectrum(record.time_s[inside], record.output[inside])
    floor = power.max() * 1e-12 + 1e-300
    roots = np.sqrt(np.asarray(SCALE_GRID, dtype=float))
    rng = np.random.default_rng(8)
    for modes in (1, 2, 4, 7, 16, 20):
        model = np.sort(rng.uniform(2.0, 700.0, (30, modes)), axis=1)
        by_logs = _best_scales(model, roots, power, float(frequencies[1]), float(frequencies[-1]), floor, False)
        if modes <= 16:
            by_products = _best_scales(model, roots, power / power.max(), float(frequencies[1]),
                                       float(frequencies[-1]), floor / power.max(), True)
            np.testing.assert_array_equal(by_products, by_logs)
        np.testing.assert_array_equal(spectral_scales(model, (frequencies, power)), np.asarray(SCALE_GRID)[by_logs])
