"""The fast calibration preview against the reference path, and its warm start.

The preview (:func:`beam.calibration.calibration_preview`) finds the MAP with the lock-step
search of :mod:`beam.calibration.fit` and computes the bands with the compiled kernel of
:mod:`beam.calibration.bands`; the reference is :func:`beam.inference.find_map` and
:func:`beam.inference.predictive_bands` on the same problem, the same starts and the same draws.
"""

from pathlib import Path

import numpy as np
import pytest
from scipy import special
from simulated_data import TRUE_BASE, simulated_measurement

from beam.calibration import calibrate, calibration_preview, calibration_stream, prepare
from beam.calibration.bands import fast_predictive_bands, mixture_bands
from beam.calibration.fit import fast_map
from beam.calibration.setup import BeamForwardModel
from beam.errors import BeamInputError
from beam.inference import find_map, laplace, predictive_bands
from beam.inference.predictive import BAND_RTOL

BASE_NAMES = tuple(TRUE_BASE)


def _mixture_cdf(q, f, sd):
    """Exact CDF of the equal-weight mixture of N(f_s, sd_s²) at each column's q."""
    return special.ndtr((q[None, :] - f) / np.broadcast_to(sd, (f.shape[0],))[:, None]).mean(axis=0)


def _check_bands(f, sd, level=0.95):
    rows = mixture_bands(f, sd, level)
    alpha = 0.5 * (1 - level)
    np.testing.assert_allclose(rows.mean, f.mean(axis=0), rtol=1e-12, atol=1e-15 * np.abs(f).max())
    np.testing.assert_allclose([rows.credible_lower, rows.credible_upper], np.quantile(f, [alpha, 1 - alpha], axis=0),
                               rtol=1e-12, atol=1e-15 * np.abs(f).max())
    tol = BAND_RTOL * alpha
    assert np.abs(_mixture_cdf(rows.prediction_lower, f, sd) - alpha).max() < 1.05 * tol
    assert np.abs(_mixture_cdf(rows.prediction_upper, f, sd) - (1 - alpha)).max() < 1.05 * tol


@pytest.mark.parametrize("level", [0.95, 0.5, 0.99])
def test_band_kernel_is_exact_on_hard_mixtures(level):
    """Bimodal, skewed, wide and narrow mixtures, few and many draws: the credible band equals
    numpy's quantiles and the prediction band's CDF is within the tolerance everywhere."""
    rng = np.random.default_rng(3)
    times = 300
    spread = np.linspace(0.01, 30.0, times)  # parameter spread from 1 % to 30 x the noise sd
    for draws in (1, 2, 7, 400, 1000):
        sd = 1.0 + 0.05 * rng.standard_normal(draws) ** 2
        unimodal = rng.standard_normal((draws, 1)) * spread
        bimodal = np.where(rng.random((draws, 1)) < 0.3, -1.0, 1.0) * spread + 0.1 * rng.standard_normal((draws, times))
        skewed = rng.exponential(1.0, (draws, 1)) * spread
        for f in (unimodal, bimodal, skewed, np.zeros((draws, times))):
            _check_bands(f + 5.0, sd, level)


def test_smallest_sorted_keeps_the_k_smallest_in_order():
    """_smallest_sorted leaves the k smallest of the first n values sorted in front (ties,
    k >= n and k = 0 included), as numpy's sort gives them."""
    from beam.calibration.bands import _smallest_sorted

    rng = np.random.default_rng(9)
    for n, k in ((30, 11), (30, 30), (12, 20), (1, 1), (5, 0), (400, 37)):
        for values in (rng.standard_normal(n), np.round(rng.standard_normal(n), 1)):
            a = np.concatenate([values, [99.0, -99.0]])  # beyond n: untouched and ignored
            _smallest_sorted(a, n, k)
            np.testing.assert_array_equal(a[: min(k, n)], np.sort(values)[: min(k, n)])
            np.testing.assert_array_equal(a[n:], [99.0, -99.0])


def test_band_kernel_marks_times_with_a_draw_not_finite():
    """A time at which a draw is inf or NaN gets NaN bands and is counted (fast_predictive_bands
    raises on it); the other times keep the bands they have without it."""
    from beam.calibration.bands import _mixture_bands

    rng = np.random.default_rng(5)
    f = rng.standard_normal((400, 50)) * 0.1 + 1.0
    sd = 0.5 + 0.01 * rng.random(400)
    clean, count = _mixture_bands(f, sd, 0.95, BAND_RTOL)
    assert count == 0 and all(np.all(np.isfinite(row)) for row in clean)
    bad = f.copy()
    bad[7, 3], bad[0, 10], bad[399, 20], bad[5, 21] = np.inf, np.nan, -np.inf, np.inf
    rows, count = _mixture_bands(bad, sd, 0.95, BAND_RTOL)
    assert count == 4
    marked = np.zeros(50, dtype=bool)
    marked[[3, 10, 20, 21]] = True
    for got, expected in zip(rows, clean):
        assert np.all(np.isnan(got[marked]))
        np.testing.assert_array_equal(got[~marked], expected[~marked])


def test_fast_bands_match_the_reference_on_a_calibration():
    record = simulated_measurement(TRUE_BASE, seed=31)
    setup, problem = prepare(record, window=(0.0, 1.0))
    fit = laplace(problem, fast_map(problem, problem.initial_guesses(problem)))
    draws = fit.draws(400, seed=2)
    time_s = setup.measurement.time_s
    fast = fast_predictive_bands(problem, draws, time_s)
    reference = predictive_bands(problem, draws, time_s)
    scale = np.abs(record.displacement_m).max()
    for name in ("mean", "credible_lower", "credible_upper"):
        np.testing.assert_allclose(getattr(fast, name), getattr(reference, name), rtol=1e-10, atol=1e-14 * scale)
    # both edges solve the same equation to the same probability tolerance
    noise = draws["noise_sd"].mean()
    for name in ("prediction_lower", "prediction_upper"):
        assert np.abs(getattr(fast, name) - getattr(reference, name)).max() < 1e-3 * noise
    assert fast.n_draws == reference.n_draws == 400 and fast.level == reference.level


@pytest.mark.parametrize(
    "effects, likelihood, seed",
    [("air_damping,kelvin_voigt", "iid", 32), ("air_damping,kelvin_voigt,tip_mass", "iid", 33),
     ("air_damping,kelvin_voigt", "ar1", 34)],
)
def test_fast_map_and_laplace_match_find_map(effects, likelihood, seed):
    """Same problem, same starts: the same MAP, Hessian and Laplace evidence as the reference."""
    parameters = dict(TRUE_BASE, tip_mass_kg=0.003) if "tip_mass" in effects else TRUE_BASE
    record = simulated_measurement(parameters, seed=seed)
    _, problem = prepare(record, window=(0.0, 1.0), effects=effects, likelihood=likelihood)
    guesses = problem.initial_guesses(problem)
    reference = laplace(problem, find_map(problem, guesses))
    fast = laplace(problem, fast_map(problem, guesses))
    assert fast.map.converged and fast.ok
    assert fast.map.log_posterior == pytest.approx(reference.map.log_posterior, abs=2e-3)
    sd = np.sqrt(np.diag(reference.cov))
    assert np.all(np.abs(fast.mean - reference.mean) < 0.05 * sd)
    np.testing.assert_allclose(np.sqrt(np.diag(fast.cov)), sd, rtol=0.02)
    assert fast.log_evidence == pytest.approx(reference.log_evidence, abs=0.05)


def _counting_model_calls(monkeypatch) -> list[int]:
    """Record the parameter sets of every beam model call (one entry per call)."""
    calls: list[int] = []
    original = BeamForwardModel.__call__

    def counted(self, values, time_s):
        out = original(self, values, time_s)
        calls.append(out.shape[0])
        return out

    monkeypatch.setattr(BeamForwardModel, "__call__", counted)
    return calls


def test_warm_start_reaches_the_cold_map_and_covers_the_truth(monkeypatch):
    """A slider move: the window end moves from 1.0 s to 1.1 s; the preview warm-started from
    the previous MAP lands on the cold preview's MAP with fewer model calls, and covers the truth."""
    record = simulated_measurement(TRUE_BASE, seed=35)
    previous = calibration_preview(record, window=(0.0, 1.0), modes=4)
    calls = _counting_model_calls(monkeypatch)
    cold = calibration_preview(record, window=(0.0, 1.1), modes=4)
    cold_calls = len(calls)
    warm = calibration_preview(record, window=(0.0, 1.1), start=previous.laplace.map.values, modes=4)
    warm_calls = len(calls) - cold_calls
    assert warm_calls < 0.8 * cold_calls  # measured: 22 against 32
    assert warm.laplace.map.log_posterior == pytest.approx(cold.laplace.map.log_posterior, abs=2e-3)
    sd = np.sqrt(np.diag(cold.laplace.cov))
    assert np.all(np.abs(warm.laplace.mean - cold.laplace.mean) < 0.05 * sd)
    assert warm.laplace.log_evidence == pytest.approx(cold.laplace.log_evidence, abs=0.05)
    summary = warm.summary()
    inside = sum(summary[n]["q025"] <= TRUE_BASE[n] <= summary[n]["q975"] for n in BASE_NAMES)
    assert inside >= 3
    assert abs(warm.rmse_prediction / 1e-5 - 1) < 0.1
    # its first candidate is the warm start, clipped to the priors
    first = warm.problem.initial_guesses(warm.problem)[0]
    assert first == pytest.approx({n: previous.laplace.map.values[n] for n in BASE_NAMES})


def test_warm_start_from_another_model_and_bad_warm_starts():
    record = simulated_measurement(dict(TRUE_BASE, tip_mass_kg=0.004), seed=36)
    base = calibration_preview(record, window=(0.0, 1.0), modes=4)
    # the base model's MAP starts the model with a tip mass (its tip mass at the prior centre)
    cold = calibration_preview(record, window=(0.0, 1.0), effects="air_damping,kelvin_voigt,tip_mass", modes=4)
    warm = calibration_preview(record, window=(0.0, 1.0), effects="air_damping,kelvin_voigt,tip_mass",
                               start=base.laplace.map.values, modes=4)
    assert warm.laplace.map.log_posterior >= cold.laplace.map.log_posterior - 2e-3
    tip = warm.summary()["tip_mass_kg"]
    assert tip["q025"] <= 0.004 <= tip["q975"]
    for bad in ({"bending_stiffness_Nm2": -1.0}, {"patch_coupling_NmV": float("nan")}, {"bending_stiffness_Nm2": "x"}):
        with pytest.raises(BeamInputError, match="warm start"):
            calibration_preview(record, window=(0.0, 1.0), start=bad, modes=4)


@pytest.mark.parametrize("warm", [False, True])
def test_stream_preview_is_the_preview(warm):
    record = simulated_measurement(TRUE_BASE, duration_s=2.0, seed=37)
    start = calibration_preview(record, window=(0.0, 0.7), modes=4).laplace.map.values if warm else None
    preview = calibration_preview(record, window=(0.0, 0.8), seed=4, start=start, modes=4)
    first = next(calibration_stream(record, window=(0.0, 0.8), seed=4, start=start, modes=4))
    assert first.is_preview
    np.testing.assert_array_equal(first.laplace.mean, preview.laplace.mean)
    np.testing.assert_array_equal(first.laplace.cov, preview.laplace.cov)
    for name in ("mean", "credible_lower", "credible_upper", "prediction_lower", "prediction_upper"):
        np.testing.assert_array_equal(getattr(first.bands, name), getattr(preview.bands, name))


def test_final_bands_are_the_posterior_predictive_bands():
    """The MCMC result's bands (fast kernel) are those of PosteriorResult.predict, same draws."""
    record = simulated_measurement(TRUE_BASE, duration_s=2.0, seed=38)
    result = calibrate(record, window=(0.0, 0.8), steps=200, seed=5, modes=4)
    reference = result.posterior.predict(record.time_s, n_draws=400, seed=5)
    scale = np.abs(record.displacement_m).max()
    for name in ("mean", "credible_lower", "credible_upper"):
        np.testing.assert_allclose(getattr(result.bands, name), getattr(reference, name), rtol=1e-10, atol=1e-14 * scale)
    noise = result.summary()["noise_sd"]["mean"]
    for name in ("prediction_lower", "prediction_upper"):
        assert np.abs(getattr(result.bands, name) - getattr(reference, name)).max() < 1e-3 * noise


def test_a_preview_with_many_parameters_on_their_bounds_still_draws_its_bands():
    """lab_run_1 with clamp compliance, patch damping and a damping ratio per mode (a set a user
    can tick): the MAP has six parameters on their bounds, rejection from the Laplace Gaussian
    accepted too few draws ("lies almost entirely outside the prior support"); the rest now
    come from the truncated Gaussian by Gibbs sampling, inside the support."""
    from beam.io.measurement import read_measurement

    record = read_measurement(Path(__file__).resolve().parents[1] / "assets" / "measurements" / "lab_run_1.csv")
    result = calibration_preview(record, effects=("clamp_compliance", "patch_damping", "modal_damping"), modes=4)
    assert any("prior bound" in w for w in result.laplace.warnings)
    draws = result.draws()
    z = result.problem.to_internal(draws)
    assert z.shape[0] == 4000 and np.all(result.problem.in_support(z))
    bands = result.bands
    assert np.all(np.isfinite(bands.mean)) and np.all(bands.prediction_lower <= bands.prediction_upper)
    assert np.isfinite(result.rmse_prediction) and result.rmse_prediction_map < 2e-3
