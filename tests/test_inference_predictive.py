"""Predictive bands: exact mixture quantiles, coverage and RMSE."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import optimize, special, stats

from beam.inference import LogUniform, Normal, Parameter, Problem, predictive_bands
from beam.inference.predictive import PredictiveBands, mixture_normal_quantiles


def _reference_quantile(mu, sd, p):
    return optimize.brentq(lambda q: special.ndtr((q - mu) / sd).mean() - p, mu.min() - 20 * sd.max(), mu.max() + 20 * sd.max(), xtol=1e-14)


@pytest.mark.parametrize("p", [0.025, 0.5, 0.975, 1e-4])
def test_mixture_quantiles_match_root_finding(p):
    rng = np.random.default_rng(0)
    s, t = 300, 7
    mu = rng.normal(0, 1, (1, t)) + rng.uniform(0.01, 2.0, (1, t)) * rng.standard_normal((s, t))
    mu[:, 3] = np.where(np.arange(s) < s // 2, -4.0, 4.0)  # well-separated bimodal mixture
    sd = rng.uniform(0.05, 0.3, s)
    q = mixture_normal_quantiles(mu, sd, p)
    for j in range(t):
        assert q[j] == pytest.approx(_reference_quantile(mu[:, j], sd, p), abs=1e-8)


def test_single_component_is_the_normal_quantile():
    q = mixture_normal_quantiles(np.array([[1.0, -2.0]]), np.array([0.5]), 0.975)
    np.testing.assert_allclose(q, [1.0 + 0.5 * stats.norm.ppf(0.975), -2.0 + 0.5 * stats.norm.ppf(0.975)], rtol=1e-10)


def _const_problem():
    t = np.linspace(0, 1, 5)

    def model(values, time_s):
        return np.repeat(values["level"][:, None], time_s.size, axis=1)

    return Problem([Parameter("level", Normal(0, 1)), Parameter("noise_sd", LogUniform(0.01, 1))], model, t, np.zeros_like(t))


def test_bands_without_parameter_uncertainty():
    problem = _const_problem()
    draws = {"level": np.full(50, 2.0), "noise_sd": np.full(50, 0.3)}
    grid = np.linspace(0, 3, 4)
    b = predictive_bands(problem, draws, grid)
    np.testing.assert_allclose(b.credible_lower, 2.0)
    np.testing.assert_allclose(b.credible_upper, 2.0)
    np.testing.assert_allclose(b.prediction_upper, 2.0 + 0.3 * stats.norm.ppf(0.975), rtol=1e-9)
    np.testing.assert_allclose(b.prediction_lower, 2.0 - 0.3 * stats.norm.ppf(0.975), rtol=1e-9)


def test_bands_match_the_closed_form_of_a_normal_posterior():
    """level ~ N(1, 0.4²) and a fixed noise sd 0.3: the credible band is 1 ± 0.4 z and the
    prediction band 1 ± 0.5 z (0.5² = 0.4² + 0.3²), z the normal quantile; the draws are the
    normal quantiles at (i + ½)/n, so their empirical quantiles follow the closed form to O(1/n)."""
    problem = _const_problem()
    n = 4000
    level = 1.0 + 0.4 * stats.norm.ppf((np.arange(n) + 0.5) / n)
    b = predictive_bands(problem, {"level": level, "noise_sd": np.full(n, 0.3)}, np.zeros(1), level=0.9)
    z = stats.norm.ppf(0.95)
    assert b.credible_lower[0] == pytest.approx(1.0 - 0.4 * z, abs=2e-3)
    assert b.credible_upper[0] == pytest.approx(1.0 + 0.4 * z, abs=2e-3)
    assert b.prediction_lower[0] == pytest.approx(1.0 - 0.5 * z, abs=2e-3)
    assert b.prediction_upper[0] == pytest.approx(1.0 + 0.5 * z, abs=2e-3)


def test_bands_match_monte_carlo_with_parameter_uncertainty():
    problem = _const_problem()
    rng = np.random.default_rng(5)
    draws = {"level": rng.normal(1.0, 0.4, 2000), "noise_sd": rng.uniform(0.1, 0.3, 2000)}
    b = predictive_bands(problem, draws, np.zeros(1), level=0.9)
    y = draws["level"][:, None] + draws["noise_sd"][:, None] * rng.standard_normal((2000, 200))
    mc = np.quantile(y, [0.05, 0.95])
    assert b.prediction_lower[0] == pytest.approx(mc[0], abs=0.02)
    assert b.prediction_upper[0] == pytest.approx(mc[1], abs=0.02)


def test_coverage_and_rmse():
    b = PredictiveBands(
        time_s=np.arange(4.0),
        mean=np.zeros(4),
        credible_lower=-np.ones(4) * 0.5,
        credible_upper=np.ones(4) * 0.5,
        prediction_lower=-np.ones(4),
        prediction_upper=np.ones(4),
        level=0.95,
        n_draws=1,
    )
    y = np.array([0.5, -2.0, 1.0, 0.9])
    assert b.coverage(y) == pytest.approx(0.75)
    assert b.coverage(y, mask=np.array([False, True, True, False])) == pytest.approx(0.5)
    assert b.rmse(y) == pytest.approx(np.sqrt(np.mean(y**2)))
    assert b.credible_coverage(np.array([0.0, 0.6, -0.5, 0.1])) == pytest.approx(0.75)
    assert b.restrict(np.array([True, False, False, True])).mean.shape == (2,)
    d = b.to_dict()
    assert d["level"] == 0.95 and len(d["prediction_upper"]) == 4
