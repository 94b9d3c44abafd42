"""Linear-Gaussian check: with frequency, phase and noise known, the amplitude posterior is exact.

``y = A g(t) + e`` with ``g = sin(2π f t + φ)`` known and ``e ~ N(0, σ²)``: the posterior of ``A``
is Gaussian with closed-form mean and sd (flat or normal prior), and the evidence is a
multivariate normal density. The Laplace preview must reproduce these to rounding error and the
emcee posterior to Monte-Carlo error.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from beam.inference import (
    Normal,
    Parameter,
    Problem,
    Uniform,
    preview,
    sample_posterior,
)
from beam.toy import sine_model

F_HZ, PHI, SIGMA, A_TRUE = 1.0, 0.3, 0.1, 0.8


def _data(seed=0, n=61):
    t = np.arange(n) / 20.0
    g = np.sin(2 * math.pi * F_HZ * t + PHI)
    y = A_TRUE * g + np.random.default_rng(seed).normal(0.0, SIGMA, n)
    return t, g, y


def _problem(prior, seed=0):
    t, g, y = _data(seed)
    problem = Problem(
        parameters=[Parameter("amplitude", prior, "du")],
        model=sine_model,
        time_s=t,
        data=y,
        likelihood="iid",
        fixed={"frequency_Hz": F_HZ, "phase_rad": PHI, "noise_sd": SIGMA},
    )
    return problem, g, y


def _exact(g, y, prior_mean=None, prior_sd=None):
    precision = g @ g / SIGMA**2
    weighted = g @ y / SIGMA**2
    if prior_sd is not None:
        precision += 1.0 / prior_sd**2
        weighted += prior_mean / prior_sd**2
    return weighted / precision, 1.0 / math.sqrt(precision)


PRIORS = {
    "flat": (Uniform(-10.0, 10.0), None, None),
    "normal": (Normal(0.5, 0.05), 0.5, 0.05),  # informative: pulls the posterior visibly
}


@pytest.mark.parametrize("name", PRIORS)
def test_laplace_is_exact_for_linear_gaussian(name):
    prior, m0, s0 = PRIORS[name]
    problem, g, y = _problem(prior)
    mean, sd = _exact(g, y, m0, s0)
    lap = preview(problem)
    assert lap.ok, lap.warnings
    assert lap.mean[0] == pytest.approx(mean, rel=1e-7)
    assert math.sqrt(lap.cov[0, 0]) == pytest.approx(sd, rel=1e-5)
    # evidence: y ~ N(m0 g, σ² I + s0² g gᵀ) for the normal prior; flat prior: 1/20 × ∫ L dA
    n = y.size
    if s0 is not None:
        cov = SIGMA**2 * np.eye(n) + s0**2 * np.outer(g, g)
        log_z = stats.multivariate_normal(mean=m0 * g, cov=cov).logpdf(y)
    else:
        a_hat = (g @ y) / (g @ g)
        rss = np.sum((y - a_hat * g) ** 2)
        log_z = (
            -0.5 * n * math.log(2 * math.pi * SIGMA**2)
            - 0.5 * rss / SIGMA**2
            + 0.5 * math.log(2 * math.pi * SIGMA**2 / (g @ g))
            - math.log(20.0)
        )
    assert lap.log_evidence == pytest.approx(log_z, abs=1e-6)


@pytest.mark.parametrize("name", PRIORS)
def test_emcee_matches_exact_posterior_within_mc_error(name):
    prior, m0, s0 = PRIORS[name]
    problem, g, y = _problem(prior)
    mean, sd = _exact(g, y, m0, s0)
    result = sample_posterior(problem, target_ess=2000, seed=11)
    assert result.diagnostics.converged, result.diagnostics.warnings
    ess = result.diagnostics.ess_min
    draws = result.draws()["amplitude"]
    mc_mean = sd / math.sqrt(ess)
    mc_sd = sd / math.sqrt(2 * ess)
    assert abs(draws.mean() - mean) < 4 * mc_mean
    assert abs(draws.std(ddof=1) - sd) < 4 * mc_sd
    # 2.5 % / 97.5 % quantiles: MC error sqrt(p (1-p) / ESS_tail) / density at the quantile
    import arviz as az

    ess_tail = float(az.ess(result.idata, var_names=["amplitude"], method="tail")["amplitude"])
    z = stats.norm.ppf(0.975)
    mc_q = math.sqrt(0.025 * 0.975 / ess_tail) / (stats.norm.pdf(z) / sd)
    summary = result.summary()["amplitude"]
    assert summary["q025"] == pytest.approx(mean - z * sd, abs=4 * mc_q)
    assert summary["q975"] == pytest.approx(mean + z * sd, abs=4 * mc_q)
