"""Problem definition, MAP search, finite-difference derivatives and the Laplace preview."""

from __future__ import annotations

import math

import numpy as np
import pytest

from beam.inference import (
    LogUniform,
    Normal,
    Parameter,
    Problem,
    Uniform,
    find_map,
    laplace,
    preview,
)
from beam.inference.optimize import fd_derivatives
from beam.toy import ToyScenario, simulate, sine_model, toy_problem


def _line_model(values, time_s):
    return values["slope"][:, None] * time_s[None, :] + values["offset"][:, None]


def _line_problem(likelihood="iid", **kw):
    t = np.linspace(0.0, 2.0, 41)
    y = 0.7 * t - 0.2 + np.random.default_rng(0).normal(0.0, 0.05, t.size)
    params = [
        Parameter("slope", Normal(0.0, 10.0), "du/s"),
        Parameter("offset", Uniform(-5.0, 5.0), "du"),
        Parameter("noise_sd", LogUniform(1e-3, 10.0), "du"),
    ]
    if likelihood == "ar1":
        params.append(Parameter("ar1_coefficient", Uniform(-1.0, 1.0, coordinate="logit")))
    return Problem(params, _line_model, t, y, likelihood=likelihood, **kw)


def test_problem_validation_messages():
    t = np.linspace(0, 1, 10)
    good = [Parameter("slope", Normal(0, 1)), Parameter("offset", Normal(0, 1)), Parameter("noise_sd", LogUniform(0.01, 1))]
    with pytest.raises(ValueError, match="needs 'noise_sd'"):
        Problem(good[:2], _line_model, t, t)
    with pytest.raises(ValueError, match="needs 'ar1_coefficient'"):
        Problem(good, _line_model, t, t, likelihood="ar1")
    with pytest.raises(ValueError, match="duplicate"):
        Problem(good + good[:1], _line_model, t, t)
    with pytest.raises(ValueError, match="same length"):
        Problem(good, _line_model, t, t[:-1])
    with pytest.raises(ValueError, match="both sampled and fixed"):
        Problem(good, _line_model, t, t, fixed={"slope": 1.0})
    with pytest.raises(ValueError, match="unknown likelihood"):
        Problem(good, _line_model, t, t, likelihood="t")


def test_log_posterior_rejects_out_of_support_without_calling_the_model():
    calls = []

    def model(values, time_s):
        calls.append(values["noise_sd"].copy())
        return _line_model(values, time_s)

    problem = _line_problem()
    problem.model = model
    z = problem.to_internal({"slope": np.array([0.7, 0.7]), "offset": np.array([0.0, 9.0]), "noise_sd": np.array([0.05, 0.05])})
    lp = problem.log_posterior(z)
    assert np.isfinite(lp[0]) and lp[1] == -np.inf
    assert len(calls) == 1 and calls[0].shape == (1,)


def test_log_posterior_is_prior_plus_likelihood_in_internal_coordinates():
    problem = _line_problem()
    values = {"slope": 0.6, "offset": -0.1, "noise_sd": 0.07}
    z = problem.to_internal(values)
    resid = problem.data - (0.6 * problem.time_s - 0.1)
    from scipy import stats

    expected = (
        stats.norm(0, 10).logpdf(0.6)
        + stats.uniform(-5, 10).logpdf(-0.1)
        + stats.loguniform(1e-3, 10).logpdf(0.07)
        + math.log(0.07)  # Jacobian of z = log(noise_sd)
        + stats.norm(0, 0.07).logpdf(resid).sum()
    )
    assert problem.log_posterior(z)[0] == pytest.approx(expected, rel=1e-12)


def test_fd_derivatives_of_a_quadratic_are_exact():
    """On a linear model with known noise the log posterior is exactly quadratic."""
    problem = _line_problem(fixed={})
    problem = Problem(problem.parameters[:2], _line_model, problem.time_s, problem.data, fixed={"noise_sd": 0.05})
    t = problem.time_s
    design = np.column_stack([t, np.ones_like(t)])
    hess_exact = -(design.T @ design) / 0.05**2
    hess_exact[0, 0] -= 1.0 / 10.0**2  # normal prior on the slope
    z = np.array([0.5, 0.1])
    _, grad, hess, zc = fd_derivatives(problem, z, np.array([1e-3, 1e-3]))
    np.testing.assert_allclose(zc, z)
    np.testing.assert_allclose(hess, hess_exact, rtol=1e-6)
    resid = problem.data - design @ z
    grad_exact = design.T @ resid / 0.05**2 - np.array([z[0] / 100.0, 0.0])
    np.testing.assert_allclose(grad, grad_exact, rtol=1e-6)


@pytest.mark.parametrize("likelihood", ["iid", "ar1"])
def test_map_of_linear_problem_matches_least_squares(likelihood):
    problem = _line_problem(likelihood)
    m = find_map(problem)
    assert m.converged, m.message
    design = np.column_stack([problem.time_s, np.ones_like(problem.time_s)])
    coef, *_ = np.linalg.lstsq(design, problem.data, rcond=None)
    tol = 0.02 if likelihood == "ar1" else 1e-3  # ar1: generalised, not ordinary least squares
    assert m.values["slope"] == pytest.approx(coef[0], abs=tol)
    assert m.values["offset"] == pytest.approx(coef[1], abs=tol)
    if likelihood == "iid":  # log-uniform prior is flat in log sd: MAP sd = RMS residual
        rms = math.sqrt(np.mean((problem.data - design @ coef) ** 2))
        assert m.values["noise_sd"] == pytest.approx(rms, rel=1e-4)
    # gradient in units of the conditional posterior sd: the optimum is resolved to 1 % of it
    assert np.all(np.abs(m.gradient) / np.sqrt(-np.diag(m.hessian)) < 1e-2)


def test_toy_map_from_spectral_start_finds_the_global_mode():
    data = simulate(ToyScenario(seed=4, window_s=12.0))
    cal = data.calibration
    problem = toy_problem(data.time_s[cal], data.data[cal])
    m = find_map(problem)
    assert m.converged
    assert m.values["frequency_Hz"] == pytest.approx(1.0, abs=2e-3)
    assert m.values["amplitude"] == pytest.approx(1.0, abs=0.05)
    # a start one Fourier bin off lands in a local optimum with a much worse posterior
    bad = find_map(problem, guesses=[{"amplitude": 1.0, "frequency_Hz": 1.0 + 1.5 / 12.0, "phase_rad": 0.3}])
    assert bad.log_posterior < m.log_posterior - 50.0


def test_initial_guess_hook_is_used():
    seen = []

    def hook(problem):
        seen.append(problem)
        return [{"slope": 0.5, "offset": 0.0}]

    problem = _line_problem(initial_guesses=hook)
    find_map(problem)
    assert seen == [problem]


def test_laplace_flags_a_map_on_a_prior_bound():
    t = np.arange(61) / 20.0
    y = np.sin(2 * math.pi * t + 0.3) + np.random.default_rng(1).normal(0, 0.1, t.size)
    problem = Problem(
        [Parameter("amplitude", Uniform(0.0, 0.5)), Parameter("noise_sd", LogUniform(1e-3, 10))],
        sine_model,
        t,
        y,
        fixed={"frequency_Hz": 1.0, "phase_rad": 0.3},
    )
    lap = preview(problem)
    assert "amplitude" in lap.map.at_bound
    assert not lap.ok and any("bound" in w for w in lap.warnings)
    draws = lap.draws(500, seed=0)
    assert np.all(draws["amplitude"] <= 0.5)


def test_laplace_summary_and_predictive_shapes():
    problem = _line_problem()
    lap = laplace(problem)
    s = lap.summary()
    assert set(s) == {"slope", "offset", "noise_sd"}
    assert s["noise_sd"]["q025"] > 0
    grid = np.linspace(0, 4, 17)
    bands = lap.predict(grid, n_draws=200, seed=1)
    assert bands.mean.shape == grid.shape
    assert np.all(bands.prediction_lower < bands.credible_lower)
    assert np.all(bands.credible_upper < bands.prediction_upper)
    # deterministic for a seed
    again = lap.predict(grid, n_draws=200, seed=1)
    np.testing.assert_array_equal(bands.prediction_upper, again.prediction_upper)
