"""Nested fits are monotone: a model that contains a smaller one already fitted by the engine
starts from (and keeps) the smaller model's optimum with its new parameters at their null values,
so its MAP log posterior is never below the smaller one's embedded in it, and its
calibration-window error never above the smaller one's by more than 0.1 %."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from beam.calibration import CalibrationSpec, Engine, calibration_preview
from beam.calibration.run import prepare
from beam.calibration.starts import null_value
from beam.io.measurement import read_measurement
from tests.simulated_data import TRUE_BASE, simulated_measurement

REAL = Path(__file__).resolve().parents[1] / "assets" / "real"
BASE = ("air_damping", "kelvin_voigt")


def embedded_log_posterior(measurement, small, large_effects, spec: CalibrationSpec) -> tuple[float, float]:
    """The larger model's log posterior at the smaller model's MAP with the new parameters at their
    null values, and the new parameters' prior log density there (internal coordinates)."""
    _, problem = prepare(measurement, spec, effects=large_effects, engine=Engine())
    values = dict(small.laplace.map.values)
    prior_density = 0.0
    for name in problem.names:
        if name not in values:
            values[name] = null_value(problem, name)
            prior = problem.parameter(name).prior
            prior_density += float(prior.log_density_internal(prior.to_internal(values[name])))
    z = problem.to_internal({k: np.atleast_1d(v) for k, v in values.items()})
    return float(problem.log_posterior(z)[0]), prior_density


def assert_monotone(measurement, spec: CalibrationSpec, added: str, engine: Engine):
    small = calibration_preview(measurement, spec, engine=engine)
    large_effects = (*spec.effects, added)
    large = calibration_preview(measurement, spec, effects=large_effects, engine=engine)
    nested, prior_density = embedded_log_posterior(measurement, small, large_effects, small.spec)
    lp_small, lp_large = small.laplace.map.log_posterior, large.laplace.map.log_posterior
    # the larger model nests the smaller: its optimum is at least the smaller one's embedded in it
    # (the new parameters at their null values, the bounds of their supports; the embedded point's
    # log posterior is the smaller MAP's plus the new parameters' prior density there, less what
    # the effect still does at its bound)
    assert lp_large >= nested - 1e-6 * abs(nested), (lp_small, prior_density, nested, lp_large)
    assert large.rmse_calibration_map <= 1.001 * small.rmse_calibration_map, (
        small.rmse_calibration_map, large.rmse_calibration_map)
    return small, large


@pytest.mark.slow
@pytest.mark.parametrize("base, added", [(("modal_damping",), "sensor_mass"),
                                         (("sensor_mass", "modal_damping"), "clamp_compliance")])
def test_a_nested_fit_on_a_real_free_decay_is_monotone(base, added):
    record = read_measurement(REAL / "adxl_50cm_114655.csv")
    assert_monotone(record, CalibrationSpec(window=(0.0, 2.0), effects=base, modes=4), added, Engine())


@pytest.mark.slow
@pytest.mark.parametrize("added", ["patch_damping", "tip_mass", "clamp_compliance"])
def test_a_nested_fit_on_a_simulated_record_is_monotone(added):
    """A record of the base model: the added effect has nothing to explain, so the larger model's
    optimum is the smaller one's with the effect switched off."""
    record = simulated_measurement(TRUE_BASE, seed=5)
    assert_monotone(record, CalibrationSpec(window=(0.0, 1.0), effects=BASE, modes=4), added, Engine())


def test_a_search_that_ends_below_the_sub_model_keeps_the_sub_models_optimum():
    """An engine whose only start strategy is the spectral match (no nested, null or design
    starts) ends far below the sub-model it contains when it remembers nothing; remembering the
    sub-model's optimum, it ends no lower than that optimum embedded (the guard searches again
    from it)."""
    from beam.calibration.fit import fast_map
    from beam.calibration.starts import SpectralStarts

    record = simulated_measurement({**TRUE_BASE, "tip_mass_kg": 0.004}, seed=6)
    spec = CalibrationSpec(window=(0.0, 1.0), effects=(*BASE, "tip_mass"), modes=4)
    larger = (*spec.effects, "clamp_compliance")
    small = calibration_preview(record, spec, engine=Engine())  # the full engine's optimum ...
    nested, _ = embedded_log_posterior(record, small, larger, small.spec)
    _, problem = prepare(record, spec, effects=larger, engine=Engine(strategies=(SpectralStarts(),)))
    alone = fast_map(problem, problem.initial_guesses(problem))
    assert alone.log_posterior < nested - 100.0  # the weak search alone: another basin
    weak = Engine(strategies=(SpectralStarts(),))
    weak.merge([weak.memory_of(small)])  # ... handed to the weak engine
    large = calibration_preview(record, spec, effects=larger, engine=weak)
    assert large.laplace.map.log_posterior >= nested - 1e-6 * abs(nested)
    assert large.rmse_calibration_map <= 1.001 * small.rmse_calibration_map


def test_the_engine_exports_and_merges_its_memory():
    record = simulated_measurement(TRUE_BASE, seed=7)
    spec = CalibrationSpec(window=(0.0, 1.0), effects=BASE, modes=4)
    one = Engine()
    fit = calibration_preview(record, spec, engine=one)
    assert len(one) == 1 and one.recall(fit.setup) is fit.laplace.map
    other = Engine()
    other.merge(one.export())
    again = calibration_preview(record, spec, engine=other)
    assert again.laplace.map is fit.laplace.map  # recalled, not searched again
    assert one.submodels(calibration_preview(record, spec, effects=(*BASE, "tip_mass"), engine=one).setup) == [
        (BASE, fit.laplace.map)]


#: Stand-ins for other labs' records (tests/record_families.py: strips of 0.25-0.58 m, an
#: accelerometer at 4 and 2 kHz, a phone at 263 Hz on jittered stamps, a strain gauge near the root).
OTHER_STRIPS = [("accelerometer", 1), ("accelerometer", 0), ("phone", 1), ("strain", 0)]


@pytest.mark.slow
@pytest.mark.parametrize("family, seed", OTHER_STRIPS)
def test_nested_fits_are_monotone_on_strips_of_other_lengths_and_sensors(family, seed):
    """#38 item 2: on every length and sensor, from every remembered sub-model (the base, then the
    base with the sensor's mass), a larger model never fits the window worse than the model it
    contains (the record holds a sensor mass the base lacks)."""
    from tests.record_families import make_record

    record = make_record(family, "sensor_mass", seed).measurement
    engine = Engine()
    spec = CalibrationSpec(window=(0.0, 2.0), effects=("modal_damping",), modes=3)
    assert_monotone(record, spec, "sensor_mass", engine)
    assert_monotone(record, CalibrationSpec(window=(0.0, 2.0), effects=("modal_damping", "sensor_mass"), modes=3),
                    "clamp_compliance", engine)
