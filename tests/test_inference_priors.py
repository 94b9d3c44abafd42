"""Prior densities and internal-coordinate Jacobians against scipy.stats and quadrature."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, stats

from beam.inference.priors import LogNormal, LogUniform, Normal, Uniform


def _scipy_logpdf(prior, x):
    """Independent reference: the natural-coordinate density from scipy.stats."""
    if isinstance(prior, Uniform):
        return stats.uniform(loc=prior.lower, scale=prior.upper - prior.lower).logpdf(x)
    if isinstance(prior, LogUniform):
        return stats.loguniform(prior.lower, prior.upper).logpdf(x)
    if isinstance(prior, Normal):
        a, b = (prior.lower - prior.mean) / prior.sd, (prior.upper - prior.mean) / prior.sd
        return stats.truncnorm(a, b, loc=prior.mean, scale=prior.sd).logpdf(x)
    if isinstance(prior, LogNormal):
        dist = stats.lognorm(s=prior.sigma, scale=prior.median)
        mass = dist.cdf(prior.upper) - dist.cdf(prior.lower)
        inside = (x >= prior.lower) & (x <= prior.upper)
        return np.where(inside, dist.logpdf(x) - np.log(mass), -np.inf)
    raise TypeError(prior)


PRIORS = [
    Uniform(-2.0, 3.0),
    Uniform(-1.0, 1.0, coordinate="logit"),
    LogUniform(0.01, 100.0),
    Normal(0.5, 2.0),
    Normal(1.0, 0.5, lower=0.2, upper=1.4),
    Normal(0.0, 1.0, lower=3.0, upper=6.0),  # far tail: the normaliser must stay accurate
    LogNormal(2.0, 0.7),
    LogNormal(1.0, 0.3, lower=0.5, upper=1.6),
]


def _inside_points(prior, n=57):
    lo, hi = prior.lower, prior.upper
    if not math.isfinite(lo):
        lo = prior.mean - 6 * prior.sd
    if not math.isfinite(hi):
        hi = (prior.mean + 6 * prior.sd) if isinstance(prior, Normal) else prior.median * math.exp(6 * prior.sigma)
    if isinstance(prior, LogNormal) and lo == 0.0:
        lo = prior.median * math.exp(-6 * prior.sigma)
    return np.linspace(lo, hi, n)[1:-1]


@pytest.mark.parametrize("prior", PRIORS, ids=lambda p: p.describe())
def test_natural_log_density_matches_scipy(prior):
    x = _inside_points(prior)
    np.testing.assert_allclose(prior.log_density(x), _scipy_logpdf(prior, x), rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("prior", PRIORS, ids=lambda p: p.describe())
def test_internal_density_is_natural_density_times_jacobian(prior):
    x = _inside_points(prior)
    z = prior.to_internal(x)
    if isinstance(prior, (LogUniform, LogNormal)):
        log_dxdz = np.log(x)  # x = exp(z)
    elif prior.coordinate == "logit":
        w = prior.upper - prior.lower
        log_dxdz = np.log((x - prior.lower) * (prior.upper - x) / w)  # dx/dz = (x-lo)(hi-x)/w
    else:
        log_dxdz = np.zeros_like(x)
    np.testing.assert_allclose(prior.log_density_internal(z), _scipy_logpdf(prior, x) + log_dxdz, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(prior.from_internal(z), x, rtol=1e-12)


@pytest.mark.parametrize("prior", PRIORS, ids=lambda p: p.describe())
def test_internal_density_integrates_to_one(prior):
    lo, hi = prior.internal_bounds
    total, _ = integrate.quad(lambda z: math.exp(prior.log_density_internal(z)), lo, hi, limit=200)
    assert total == pytest.approx(1.0, abs=1e-7)


@pytest.mark.parametrize("prior", PRIORS, ids=lambda p: p.describe())
def test_outside_support_is_minus_inf(prior):
    if math.isfinite(prior.lower):
        assert prior.log_density(prior.lower - 1e-3) == -np.inf
    if math.isfinite(prior.upper):
        assert prior.log_density(prior.upper + 1e-3) == -np.inf
    lo, hi = prior.internal_bounds
    if math.isfinite(hi):
        assert prior.log_density_internal(hi + 1e-6) == -np.inf
    if math.isfinite(lo):
        assert prior.log_density_internal(lo - 1e-6) == -np.inf


@pytest.mark.parametrize("prior", PRIORS, ids=lambda p: p.describe())
def test_sampling_matches_the_distribution(prior):
    x = prior.sample(np.random.default_rng(3), 4000)
    assert np.all((x >= prior.lower) & (x <= prior.upper))
    reference = {
        Uniform: lambda: stats.uniform(loc=prior.lower, scale=prior.upper - prior.lower).cdf,
        LogUniform: lambda: stats.loguniform(prior.lower, prior.upper).cdf,
    }
    if type(prior) in reference:
        cdf = reference[type(prior)]()
    elif isinstance(prior, Normal):
        a, b = (prior.lower - prior.mean) / prior.sd, (prior.upper - prior.mean) / prior.sd
        cdf = stats.truncnorm(a, b, loc=prior.mean, scale=prior.sd).cdf
    else:
        dist = stats.lognorm(s=prior.sigma, scale=prior.median)
        lo_c, hi_c = dist.cdf(prior.lower), dist.cdf(prior.upper)
        cdf = lambda v: (dist.cdf(v) - lo_c) / (hi_c - lo_c)
    assert stats.kstest(x, cdf).pvalue > 1e-3


def test_quadratic_form_matches_density():
    for prior in PRIORS:
        quad = prior.internal_quadratic()
        if quad is None:
            continue
        c, mu, sigma = quad
        z = prior.to_internal(_inside_points(prior, 9))
        expected = c - 0.5 * ((z - mu) / sigma) ** 2 if math.isfinite(sigma) else np.full_like(z, c)
        np.testing.assert_allclose(prior.log_density_internal(z), expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(
    "bad",
    [
        lambda: Uniform(1.0, 1.0),
        lambda: Uniform(0.0, math.inf),
        lambda: LogUniform(0.0, 1.0),
        lambda: Normal(0.0, -1.0),
        lambda: LogNormal(-1.0, 1.0),
        lambda: Uniform(0.0, 1.0, coordinate="tan"),
    ],
)
def test_invalid_priors_are_rejected(bad):
    with pytest.raises(ValueError):
        bad()


@settings(max_examples=60, deadline=None)
@given(
    lo=st.floats(-50, 50),
    width=st.floats(1e-3, 100),
    frac=st.floats(0.001, 0.999),
    logit=st.booleans(),
)
def test_uniform_round_trip(lo, width, frac, logit):
    prior = Uniform(lo, lo + width, coordinate="logit" if logit else "linear")
    x = lo + frac * width
    assert prior.from_internal(prior.to_internal(x)) == pytest.approx(x, rel=1e-9, abs=1e-9 * width)


@settings(max_examples=60, deadline=None)
@given(lo=st.floats(1e-6, 1.0), ratio=st.floats(1.01, 1e6), frac=st.floats(0.0, 1.0))
def test_log_uniform_round_trip_and_flat_internal_density(lo, ratio, frac):
    prior = LogUniform(lo, lo * ratio)
    x = lo * ratio**frac
    z = prior.to_internal(x)
    assert prior.from_internal(z) == pytest.approx(x, rel=1e-9)
    assert prior.log_density_internal(z) == pytest.approx(-math.log(math.log(ratio)), rel=1e-9)


def test_the_log_coordinate_saturates_beyond_the_float_range_without_a_warning():
    """An interval end exp(z) of a parameter the data do not identify (z = centre ± a huge spread)
    is inf or 0, as the exact exponential rounds, and no RuntimeWarning reaches the user (#38)."""
    import warnings

    prior = LogUniform(1e-6, 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        z = np.array([-1e4, -800.0, 0.0, 709.0, 800.0, 1e4])
        x = prior.from_internal(z)
    assert x[0] == 0.0 and x[1] == 0.0 and x[2] == 1.0 and x[-2] == math.inf and x[-1] == math.inf
    assert x[3] == pytest.approx(math.exp(709.0), rel=1e-15)
    assert prior.from_internal(prior.to_internal(0.37)) == pytest.approx(0.37, rel=1e-15)
