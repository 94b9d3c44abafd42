"""Draws of a box-truncated Gaussian (the Laplace preview's fallback when rejection accepts almost
nothing) against rejection sampling from the untruncated Gaussian, an independent method."""

from __future__ import annotations

import numpy as np
import pytest

from beam.inference.laplace import truncated_gaussian_gibbs


def rejection(mean, cov, lower, upper, n, rng):
    out = []
    while sum(len(o) for o in out) < n:
        z = rng.multivariate_normal(mean, cov, size=200_000)
        out.append(z[np.all((z >= lower) & (z <= upper), axis=1)])
    return np.concatenate(out)[:n]


@pytest.mark.parametrize("rho", [0.0, 0.8, -0.6])
def test_gibbs_matches_rejection_with_the_mean_on_a_corner(rho):
    """Mean at the lower corner (as a MAP with two parameters on their bounds), correlated."""
    mean = np.array([0.0, 1.0])
    cov = np.array([[1.0, rho * 0.5], [rho * 0.5, 0.25]])
    lower, upper = np.array([0.0, 1.0]), np.array([3.0, np.inf])
    n = 20_000
    gibbs = truncated_gaussian_gibbs(mean, cov, lower, upper, n, np.random.default_rng(1))
    reference = rejection(mean, cov, lower, upper, n, np.random.default_rng(2))
    assert np.all((gibbs >= lower) & (gibbs <= upper))
    se = reference.std(axis=0) / np.sqrt(n)
    assert np.all(np.abs(gibbs.mean(axis=0) - reference.mean(axis=0)) < 6 * np.sqrt(2) * se)
    assert np.allclose(gibbs.std(axis=0), reference.std(axis=0), rtol=0.03)
    assert np.corrcoef(gibbs.T)[0, 1] == pytest.approx(np.corrcoef(reference.T)[0, 1], abs=0.03)


def test_gibbs_reaches_a_region_rejection_cannot():
    """Twelve coordinates, each mean 3 sd outside its box: rejection would accept ~1e-36 of its
    draws; the Gibbs draws stay in the box and pile up at the near edges as the conditionals say
    (a truncated normal far in its tail is nearly exponential: mean edge + sd²/distance)."""
    d = 12
    mean = np.full(d, -3.0)
    cov = np.eye(d)
    lower, upper = np.zeros(d), np.full(d, 10.0)
    z = truncated_gaussian_gibbs(mean, cov, lower, upper, 4000, np.random.default_rng(0))
    assert np.all((z >= lower) & (z <= upper))
    # exact mean of N(-3, 1) truncated to [0, 10]: phi(3) / (1 - Phi(3)) - 3
    from scipy.stats import norm

    exact = norm.pdf(3.0) / norm.sf(3.0) - 3.0
    assert z.mean() == pytest.approx(exact, rel=0.03)
