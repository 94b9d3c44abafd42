"""Likelihoods against scipy.stats (independent covariance-matrix computations)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import linalg, stats

from beam.inference.likelihood import estimate_noise_parameters, log_likelihood, whiten


def _ar1_covariance(n, sd, rho):
    lags = np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    return sd**2 * rho**lags


def test_ar1_matches_multivariate_normal():
    rng = np.random.default_rng(0)
    n = 12
    resid = rng.normal(0.0, 0.7, size=(5, n))
    sd = np.array([0.3, 0.7, 1.0, 2.5, 0.9])
    rho = np.array([0.0, 0.5, -0.7, 0.95, 0.2])
    got = log_likelihood("ar1", resid, {"noise_sd": sd, "ar1_coefficient": rho})
    expected = [stats.multivariate_normal(mean=np.zeros(n), cov=_ar1_covariance(n, s, r)).logpdf(e) for e, s, r in zip(resid, sd, rho)]
    np.testing.assert_allclose(got, expected, rtol=1e-10)


def test_iid_matches_normal_logpdf_and_ar1_at_zero():
    rng = np.random.default_rng(1)
    resid = rng.normal(size=(3, 40))
    sd = np.array([0.5, 1.0, 3.0])
    got = log_likelihood("iid", resid, {"noise_sd": sd})
    expected = stats.norm(scale=sd[:, None]).logpdf(resid).sum(axis=1)
    np.testing.assert_allclose(got, expected, rtol=1e-12)
    ar1 = log_likelihood("ar1", resid, {"noise_sd": sd, "ar1_coefficient": np.zeros(3)})
    np.testing.assert_allclose(ar1, expected, rtol=1e-12)


def test_whitening_is_the_inverse_cholesky_factor():
    """Whitened AR(1) residuals equal L^-1 e with L the Cholesky factor of the covariance."""
    rng = np.random.default_rng(2)
    n, sd, rho = 9, 0.8, 0.6
    e = rng.normal(size=n)
    chol = linalg.cholesky(_ar1_covariance(n, sd, rho), lower=True)
    expected = linalg.solve_triangular(chol, e, lower=True)
    got = whiten("ar1", e[None, :], {"noise_sd": np.array([sd]), "ar1_coefficient": np.array([rho])})[0]
    np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-12)


def test_nonstationary_coefficient_is_minus_inf():
    r = np.zeros((2, 5))
    out = log_likelihood("ar1", r, {"noise_sd": np.ones(2), "ar1_coefficient": np.array([1.0, -1.0])})
    assert np.all(out == -np.inf)


def test_unknown_kind():
    with pytest.raises(ValueError, match="unknown likelihood"):
        log_likelihood("student", np.zeros((1, 3)), {"noise_sd": np.ones(1)})


def test_noise_moment_estimates_recover_an_ar1_process():
    rng = np.random.default_rng(4)
    n, sd, rho = 20000, 0.3, 0.8
    e = np.empty(n)
    e[0] = rng.normal(0, sd)
    innov = rng.normal(0, sd * np.sqrt(1 - rho**2), n)
    for i in range(1, n):
        e[i] = rho * e[i - 1] + innov[i]
    est = estimate_noise_parameters("ar1", e)
    assert est["noise_sd"] == pytest.approx(sd, rel=0.05)
    assert est["ar1_coefficient"] == pytest.approx(rho, abs=0.02)


@settings(max_examples=40, deadline=None)
@given(
    sd=st.floats(0.01, 10.0),
    rho=st.floats(-0.99, 0.99),
    n=st.integers(2, 25),
    seed=st.integers(0, 2**16),
)
def test_ar1_equals_dense_gaussian_for_random_cases(sd, rho, n, seed):
    e = np.random.default_rng(seed).normal(0.0, sd, n)
    got = log_likelihood("ar1", e[None, :], {"noise_sd": np.array([sd]), "ar1_coefficient": np.array([rho])})[0]
    cov = _ar1_covariance(n, sd, rho)
    expected = stats.multivariate_normal(mean=np.zeros(n), cov=cov, allow_singular=False).logpdf(e)
    assert got == pytest.approx(expected, rel=1e-7, abs=1e-7)
