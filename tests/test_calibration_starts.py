"""The start strategy against a brute-force reference (a seeded subset of tests/benchmarks/bench_starts.py)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from beam.calibration import (
    calibration_preview,  # noqa: E402
    prepare,  # noqa: E402
)
from beam.calibration.fit import fast_map  # noqa: E402
from beam.calibration.engine import default_engine  # noqa: E402
from beam.calibration.starts import design_points, starting_points  # noqa: E402
from tests.benchmarks.bench_starts import reference_log_posterior  # noqa: E402
from tests.simulated_data import HIDDEN_EFFECTS, TRUE_BASE, random_beam_case, simulated_measurement  # noqa: E402

ASSETS = Path(__file__).resolve().parents[1] / "assets" / "measurements"


@pytest.fixture(scope="module")
def patch_record():
    """Base + damping + a stiff, heavy patch (as lab_run_1), 15 µm noise, seed 7."""
    truth = dict(TRUE_BASE, patch_added_density_kg_m=0.433, patch_added_stiffness_Nm2=0.793)
    return simulated_measurement(truth, noise_m=1.5e-5, seed=7, name="patch")


@pytest.mark.slow
@pytest.mark.parametrize("effects", [
    ("air_damping", "kelvin_voigt", "patch_stiffening"),            # the true set
    ("air_damping", "kelvin_voigt", "patch_stiffening", "tip_mass"),  # a superset
    ("patch_stiffening",),                                            # damping left out
])
def test_engine_map_is_within_one_nat_of_a_256_start_reference(patch_record, effects):
    window = (0.0, 1.0)
    engine = float(calibration_preview(patch_record, window=window, effects=effects, modes=4).laplace.map.log_posterior)
    reference = reference_log_posterior(patch_record, window, effects, 4, starts=256)
    assert engine >= reference - 1.0


def test_design_covers_each_effect_barely_on_and_the_ranges(patch_record):
    setup, problem = prepare(patch_record, window=(0.0, 1.0), effects=("tip_mass", "clamp_compliance"))
    design = design_points(problem, setup)
    mass, clamp = design["tip_mass_kg"], design["clamp_stiffness_Nm_rad"]
    lo_m, hi_m = problem.parameter("tip_mass_kg").prior.lower, problem.parameter("tip_mass_kg").prior.upper
    lo_c, hi_c = (problem.parameter("clamp_stiffness_Nm_rad").prior.lower,
                  problem.parameter("clamp_stiffness_Nm_rad").prior.upper)
    barely_mass = np.isclose(np.log(mass / lo_m) / np.log(hi_m / lo_m), 0.02)
    barely_clamp = np.isclose(np.log(clamp / lo_c) / np.log(hi_c / lo_c), 0.98)  # a clamp vanishes when stiff
    assert barely_mass.sum() >= 8 and barely_clamp.sum() >= 8
    # the Sobol part spans each log range (every tenth of it holds a point)
    sobol = ~(barely_mass | barely_clamp)
    tenths = np.floor(10 * np.log(mass[sobol] / lo_m) / np.log(hi_m / lo_m))
    assert set(tenths.astype(int)) == set(range(10))
    starts = starting_points(problem, setup, engine=default_engine())
    assert len(starts) >= 3 and all(set(s) == set(setup.physical_names) for s in starts)


def sobol_reference_log_posterior(measurement, window, effects, starts: int = 256, seed: int = 1) -> float:
    """Log posterior of :func:`sobol_reference_map`."""
    return float(sobol_reference_map(measurement, window, effects, starts, seed).log_posterior)


def sobol_reference_map(measurement, window, effects, starts: int = 256, seed: int = 1):
    """The best optimum of the lock-step search from ``starts`` points of a
    scrambled Sobol design over every physical parameter's log prior range (k_p by least
    squares for a linear model), none of the engine's own starts among them: an independent
    brute-force reference."""
    from scipy.stats import qmc

    setup, problem = prepare(measurement, window=window, effects=effects, modes=4)
    names = list(setup.physical_names)
    logs = np.array([[np.log(problem.parameter(n).prior.lower), np.log(problem.parameter(n).prior.upper)]
                     for n in names])
    unit = qmc.Sobol(len(names), scramble=True, seed=seed).random(starts)
    values = np.exp(logs[:, 0] + unit * (logs[:, 1] - logs[:, 0]))
    batch = {n: values[:, i] for i, n in enumerate(names)}
    if not setup.model.is_nonlinear:  # k_p by least squares; a nonlinear model's k_p spans its range
        batch["patch_coupling_NmV"] = np.ones(starts)
        with np.errstate(all="ignore"):
            response = problem.predict(batch)
        denominator = np.einsum("ij,ij->i", response, response)
        prior = problem.parameter("patch_coupling_NmV").prior
        batch["patch_coupling_NmV"] = np.clip(
            np.abs(response @ problem.data) / np.where(denominator > 0, denominator, np.inf),
            prior.lower * 1.000001, prior.upper * 0.999999)
    guesses = [{n: float(batch[n][i]) for n in names} for i in range(starts)]
    return fast_map(problem, guesses)


@pytest.mark.parametrize("effects", [
    ("tip_mass",),                                  # the patch missing: a tip mass stands in for it
    ("clamp_compliance",),                          # ... or a compliant clamp
    ("air_damping", "kelvin_voigt", "tip_mass"),
])
def test_hard_cases_without_the_patch_reach_the_brute_force_optimum(effects):
    """lab_run_1 (a stiff, heavy patch) at the 20 % window with a model lacking the patch: a
    gross misfit whose best basin (heavy tip mass / soft clamp with a higher EI) the screened
    design used to miss by 17-34 nats (its points ranked 37th-124th by residual RMS)."""
    from beam.io.measurement import read_measurement

    record = read_measurement(ASSETS / "lab_run_1.csv")
    t = record.time_s
    window = (float(t[0]), float(t[0] + 0.2 * (t[-1] - t[0])))
    engine = float(calibration_preview(record, window=window, effects=effects, modes=4).laplace.map.log_posterior)
    reference = sobol_reference_log_posterior(record, window, effects)
    assert engine >= reference - 1.0


@pytest.mark.slow
def test_basins_side_by_side_on_the_ridge_are_each_searched():
    """A random record with a hidden soft clamp (the global-mode sample's "random1"), 45 % window,
    tip mass + sensor mass: along the ridge of equal frequencies the optima lie a few tenths of
    the mass's log range apart. With eight ridge bins the engine ended 33 nats below a 256-start
    Sobol search (66 below its own optimum now); with RIDGE_BINS it is at or above it."""
    rng = np.random.default_rng(2024)  # the records of tests/benchmarks/bench_starts.py
    random_beam_case(rng, HIDDEN_EFFECTS[0])
    record, _, _ = random_beam_case(rng, HIDDEN_EFFECTS[1])
    assert HIDDEN_EFFECTS[1] == "clamp_compliance"
    window = _window(record, 0.45)
    effects = ("tip_mass", "sensor_mass")
    engine = float(calibration_preview(record, window=window, effects=effects, modes=4).laplace.map.log_posterior)
    assert engine >= sobol_reference_log_posterior(record, window, effects) - 1.0


def _window(record, fraction: float) -> tuple[float, float]:
    t = record.time_s
    return float(t[0]), float(t[0] + fraction * (t[-1] - t[0]))


@pytest.fixture(scope="module")
def lab_run_1_at_30_percent():
    from beam.io.measurement import read_measurement

    record = read_measurement(ASSETS / "lab_run_1.csv")
    return record, _window(record, 0.3)


@pytest.fixture(scope="module")
def clamp_and_spring_reference(lab_run_1_at_30_percent):
    """The brute-force MAP of clamp compliance + tip cubic spring on lab_run_1 at the 30 % window."""
    record, window = lab_run_1_at_30_percent
    return sobol_reference_map(record, window, ("clamp_compliance", "tip_cubic_spring"))


@pytest.mark.slow
def test_nonlinear_spring_with_a_compliant_clamp_reaches_the_brute_force_optimum(lab_run_1_at_30_percent,
                                                                                 clamp_and_spring_reference):
    """lab_run_1 at the 30 % window with the hardening spring and a compliant clamp: the best basin
    (EI 0.3-0.35 N m², clamp 10-30 N m/rad, spring ~2e5 N/m³) is narrow along the effective
    frequency, which the spring's hardening makes depend on the amplitude, i.e. on k_p. The
    stratified design simulated each point at the prior centre's k_p (5x the record's
    amplitude) and ended 269 nats below the reference."""
    record, window = lab_run_1_at_30_percent
    effects = ("clamp_compliance", "tip_cubic_spring")
    _, problem = prepare(record, window=window, effects=effects, modes=4)
    engine = fast_map(problem, problem.initial_guesses(problem))
    assert engine.log_posterior >= clamp_and_spring_reference.log_posterior - 1.0


@pytest.mark.slow
def test_a_superset_of_spring_and_clamp_fits_at_least_as_well_as_their_brute_force_optimum(
        lab_run_1_at_30_percent, clamp_and_spring_reference):
    """Tip mass + clamp + spring nests clamp + spring (tip mass -> 0): its MAP's residual RMS (the
    profiled noise sd) cannot exceed the brute-force clamp + spring optimum's, beyond the tip
    mass's prior pull. It was 1.03 mm against 0.85 mm (194 nats below the bench's reference),
    because the nested start came from a clamp + spring MAP that had missed that basin."""
    record, window = lab_run_1_at_30_percent
    _, problem = prepare(record, window=window, effects=("tip_mass", "clamp_compliance", "tip_cubic_spring"), modes=4)
    engine = fast_map(problem, problem.initial_guesses(problem))
    assert engine.values["noise_sd"] <= 1.01 * clamp_and_spring_reference.values["noise_sd"]


@pytest.mark.slow
def test_patch_with_sensor_mass_on_lab_run_4_reaches_the_brute_force_optimum():
    """lab_run_4 at the 20 % window, patch stiffening + sensor mass: 2.8-3.0 nats short of the
    reference in the 80-case sample (before the default damping stopped being dropped for
    nested starts)."""
    from beam.io.measurement import read_measurement

    record = read_measurement(ASSETS / "lab_run_4.csv")
    window = _window(record, 0.2)
    effects = ("patch_stiffening", "sensor_mass")
    engine = float(calibration_preview(record, window=window, effects=effects, modes=4).laplace.map.log_posterior)
    reference = sobol_reference_log_posterior(record, window, effects)
    assert engine >= reference - 1.0


@pytest.mark.parametrize("effects, fraction", [
    (("air_damping", "kelvin_voigt", "clamp_compliance", "patch_damping"), 0.3),
    (("air_damping", "kelvin_voigt", "tip_mass", "patch_damping"), 0.2),
])
def test_a_pure_damping_effect_on_a_mode_changing_model_needs_no_searched_design(effects, fraction):
    """A model that adds a pure damping effect to one that changes the modes skips its own searched
    design (its quick stage starts from the sub-model's two-stage MAP): on lab_run_1 it still reaches
    an independent 256-start Sobol search (clamp + patch damping once ended 9 nats short of the
    clamp-only optimum)."""
    from beam.calibration.starts import adds_damping_to_a_searched_submodel
    from beam.io.measurement import read_measurement

    record = read_measurement(ASSETS / "lab_run_1.csv")
    window = _window(record, fraction)
    result = calibration_preview(record, window=window, effects=effects, modes=4)
    assert adds_damping_to_a_searched_submodel(result.setup)
    reference = sobol_reference_log_posterior(record, window, effects)
    assert float(result.laplace.map.log_posterior) >= reference - 1.0


@pytest.mark.slow
@pytest.mark.parametrize("name, fraction, effects", [
    ("lab_run_2", 0.45, ("air_damping", "clamp_compliance")),  # 3.1 nats short before the ridge copies
    ("lab_run_3", 0.2, ("air_damping", "patch_stiffening", "sensor_mass")),  # 158 nats lower before
])
def test_long_windows_reach_the_brute_force_optimum_from_the_ridge_of_equal_frequencies(name, fraction, effects):
    """Narrow basins along the ridge of equal frequencies: the stratified design's copies with
    EI from their own spectral match reach them (see ``stratified_design``)."""
    from beam.io.measurement import read_measurement

    record = read_measurement(ASSETS / f"{name}.csv")
    window = _window(record, fraction)
    engine = float(calibration_preview(record, window=window, effects=effects, modes=4).laplace.map.log_posterior)
    reference = sobol_reference_log_posterior(record, window, effects)
    assert engine >= reference - 1.0


def _random_clamp_record():
    """The global-mode sample's "random1": a random record with a hidden soft clamp."""
    rng = np.random.default_rng(2024)  # the records of tests/benchmarks/bench_starts.py
    random_beam_case(rng, HIDDEN_EFFECTS[0])
    record, _, _ = random_beam_case(rng, HIDDEN_EFFECTS[1])
    assert HIDDEN_EFFECTS[1] == "clamp_compliance"
    return record


@pytest.mark.slow
@pytest.mark.parametrize("name, fraction, effects", [
    ("random1", 0.45, ("air_damping", "sensor_mass")),  # 4.5 nats short before the walk
    ("lab_run_4", 0.3, ("air_damping", "patch_stiffening")),  # 1.4 short before
])
def test_a_washboard_of_basins_along_the_ridge_is_walked(name, fraction, effects):
    """Optima a few percent of a mass or stiffness apart along the ridge of equal frequencies
    (random1, 45 %: sensor masses of 105, 101, 97, 93 and 88 g, each a few nats above the last):
    the walk from the best MAP (``ridge_walk``) reaches an independent 256-start Sobol search.
    (lab_run_3, 20 %, clamp + spring + sensor mass: the walk gains 2.6 nats, to above the
    global-mode benchmark's reference, but this seed-1 search finds 11.5 nats more: not held.)"""
    from beam.io.measurement import read_measurement

    record = _random_clamp_record() if name == "random1" else read_measurement(ASSETS / f"{name}.csv")
    window = _window(record, fraction)
    engine = float(calibration_preview(record, window=window, effects=effects, modes=4).laplace.map.log_posterior)
    reference = sobol_reference_log_posterior(record, window, effects)
    assert engine >= reference - 1.0


def test_ridge_neighbours_step_one_parameter_with_ei_and_the_coupling_refitted():
    """Each neighbour moves one mode-changing parameter by a step of its log prior range each way
    and keeps the others but EI (moved along the ridge of equal frequencies) and k_p, which is the
    least-squares coupling of the neighbour (computed apart, one model call per point)."""
    from beam.calibration.starts import WALK_STEPS, least_squares_coupling, ridge_neighbours

    truth = dict(TRUE_BASE, tip_mass_kg=2e-3)
    record = simulated_measurement(truth, noise_m=1.5e-5, seed=7, name="tip")
    setup, problem = prepare(record, window=(0.0, 1.0), effects=("air_damping", "kelvin_voigt", "tip_mass"), modes=4)
    centre = dict(truth)
    neighbours = ridge_neighbours(problem, setup, centre)
    assert len(neighbours) == 2 * len(WALK_STEPS)
    coupling = problem.parameter("patch_coupling_NmV").prior
    prior = problem.parameter("tip_mass_kg").prior
    span = np.log(prior.upper / prior.lower)
    steps = sorted(abs(np.log(g["tip_mass_kg"] / centre["tip_mass_kg"])) / span for g in neighbours)
    np.testing.assert_allclose(steps, np.repeat(sorted(WALK_STEPS), 2), rtol=1e-9)
    for guess in neighbours:
        assert all(guess[n] == centre[n] for n in centre
                   if n not in ("tip_mass_kg", "bending_stiffness_Nm2", "patch_coupling_NmV"))
        assert coupling.lower < guess["patch_coupling_NmV"] < coupling.upper
        assert guess["patch_coupling_NmV"] == pytest.approx(least_squares_coupling(setup, guess, problem), rel=1e-6)


@pytest.mark.slow
def test_modal_damping_can_damp_the_upper_modes_away():
    """random1, 20 % window, tip mass + patch stiffening + modal damping: the best optimum damps
    modes 3-4 away (their damping ratios at the prior's top) and fits modes 1-2 with a heavy tip
    mass and a stiff patch. Without the damped-away starts the engine followed all four modes and
    ended 91 nats below it; an independent 256-start Sobol search finds it."""
    record = _random_clamp_record()
    window = _window(record, 0.2)
    effects = ("tip_mass", "patch_stiffening", "modal_damping")
    engine = calibration_preview(record, window=window, effects=effects, modes=4).laplace.map
    reference = sobol_reference_map(record, window, effects)
    assert float(engine.log_posterior) >= float(reference.log_posterior) - 1.0
    assert engine.values["damping_ratio_mode_3"] > 0.2 and engine.values["damping_ratio_mode_4"] > 0.2


def test_damped_away_starts_keep_each_count_of_lower_modes():
    """One start per count k of kept modes below the retained M: modes above k damped at the
    prior's top, the others barely on, the rest the MAP of the model without modal damping on k
    modes (inside the prior; on the true tip mass once two modes are kept); none for a model
    without modal damping."""
    from beam.calibration.starts import DAMPED_AWAY, damped_away_starts

    truth = dict(TRUE_BASE, tip_mass_kg=2e-3)
    record = simulated_measurement(truth, noise_m=1.5e-5, seed=7, name="tip")
    setup, problem = prepare(record, window=(0.0, 0.6), effects=("tip_mass", "modal_damping"), modes=3)
    starts = damped_away_starts(problem, setup)
    assert len(starts) == 2
    prior = problem.parameter("damping_ratio_mode_1").prior
    top = np.exp(np.log(prior.upper) - DAMPED_AWAY * np.log(prior.upper / prior.lower))
    for kept, start in enumerate(starts, start=1):
        assert set(start) == set(setup.physical_names)
        for j in range(1, 4):
            ratio = start[f"damping_ratio_mode_{j}"]
            assert ratio == pytest.approx(top, rel=1e-9) if j > kept else ratio < 2e-5
        if kept == 2:  # two modes tell the tip mass from EI (one cannot): the true ones, 2 g and 0.491 N m²
            assert start["tip_mass_kg"] == pytest.approx(2e-3, rel=0.1)
            assert start["bending_stiffness_Nm2"] == pytest.approx(TRUE_BASE["bending_stiffness_Nm2"], rel=0.03)
        for name, value in start.items():
            assert problem.parameter(name).prior.lower < value < problem.parameter(name).prior.upper
    setup, problem = prepare(record, window=(0.0, 0.6), effects=("tip_mass",), modes=3)
    assert damped_away_starts(problem, setup) == []


def test_the_spring_linearised_at_the_records_amplitude_puts_the_first_mode_on_its_peak():
    """lab_run_4 was simulated with a 15,000 N/m³ hardening tip spring (its truth in
    assets/answers): its window's spectrum peaks where the spring, linearised at the window's
    amplitude (harmonic balance, ``equivalent_linear_omega2``), puts the first mode, not at the
    linear frequency; the upper modes, nearly linear, stay on their own peaks. The peak comes
    from the nonlinear simulation (an independent method)."""
    from beam.calibration.starts import equivalent_linear_omega2, window_spectrum
    from beam.io.measurement import read_measurement
    from beam.io.simulation import read_truth

    record = read_measurement(ASSETS / "lab_run_4.csv")
    truth = read_truth(ASSETS.parent / "answers" / "lab_run_4.truth.toml")
    window = _window(record, 0.45)
    setup, _ = prepare(record, window=window, effects=tuple(truth.effects), modes=4, search=False)
    values = {name: np.atleast_1d(truth.parameters[name]) for name in setup.physical_names}
    reduced, _, _ = setup.model.reduced_system(values, 4)
    linear = np.sqrt(reduced["omega2"][0]) / (2 * np.pi)
    linearised = np.sqrt(equivalent_linear_omega2(setup, reduced, values)[0]) / (2 * np.pi)
    frequencies, power = window_spectrum(setup)

    def peak(low, high):
        band = (frequencies > low) & (frequencies < high)
        return frequencies[band][np.argmax(power[band])]

    first = peak(3.0, 15.0)
    assert abs(linearised[0] / first - 1) < 0.02 < 0.1 < abs(linear[0] / first - 1)
    second = peak(30.0, 50.0)
    assert abs(linearised[1] / second - 1) < 0.02


@pytest.mark.slow
def test_a_hardening_spring_on_a_large_pulse_reaches_the_brute_force_optimum():
    """lab_run_4 (a large pulse, a hidden hardening tip spring), 45 % window, tip mass + spring:
    the design's spring points are scaled to the record's amplitude and put on the ridge of the
    frequencies the spring has at that amplitude. With the linear frequencies and a
    least-squares k_p (which a point off the record's frequencies drives to the prior's bottom)
    the engine ended 225 nats below an independent 256-start Sobol search."""
    from beam.io.measurement import read_measurement

    record = read_measurement(ASSETS / "lab_run_4.csv")
    window = _window(record, 0.45)
    effects = ("tip_mass", "tip_cubic_spring")
    engine = float(calibration_preview(record, window=window, effects=effects, modes=4).laplace.map.log_posterior)
    assert engine >= sobol_reference_log_posterior(record, window, effects) - 1.0
