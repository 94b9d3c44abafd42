"""The emcee engine against an independent sampler, plus its streaming API and outputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from beam.inference import (
    EnsembleRun,
    Progress,
    load_inference_data,
    preview,
    sample_posterior,
)
from beam.toy import ToyScenario, simulate, toy_problem


def _toy_problem(seed=0, likelihood="iid"):
    data = simulate(ToyScenario(seed=seed))
    cal = data.calibration
    return toy_problem(data.time_s[cal], data.data[cal], likelihood=likelihood)


# --------------------------------------------------------------------------------------------
# Independent reference: random-walk Metropolis on the toy posterior, written from scratch in
# natural coordinates with scipy.stats densities (no code shared with beam.inference).
# --------------------------------------------------------------------------------------------
def _independent_log_posterior(theta, t, y):
    """theta (K, 4) = amplitude, frequency_Hz, phase_rad, noise_sd; the toy priors.

    Densities written out here (log-uniform: -log x - log log(hi/lo); uniform: -log width;
    Gaussian likelihood), checked once against scipy.stats below.
    """
    a, f, phi, s = theta.T
    inside = (a >= 0.01) & (a <= 100) & (f >= 0.2) & (f <= 5.0) & (phi >= -math.pi) & (phi <= math.pi) & (s >= 1e-3) & (s <= 10)
    out = np.full(theta.shape[0], -np.inf)
    if np.any(inside):
        a, f, phi, s = a[inside], f[inside], phi[inside], s[inside]
        lp = -np.log(a) - math.log(math.log(1e4)) - math.log(4.8) - math.log(2 * math.pi) - np.log(s) - math.log(math.log(1e4))
        resid = y - a[:, None] * np.sin(2 * math.pi * f[:, None] * t + phi[:, None])
        ll = -0.5 * np.sum(resid**2, axis=1) / s**2 - y.size * np.log(s) - 0.5 * y.size * math.log(2 * math.pi)
        out[inside] = lp + ll
    return out


def test_independent_log_posterior_matches_scipy():
    problem = _toy_problem(seed=3)
    t, y = problem.time_s, problem.data
    theta = np.array([[1.1, 0.97, 0.2, 0.12], [0.5, 2.0, -3.0, 0.5]])
    a, f, phi, s = theta.T
    expected = (
        stats.loguniform(0.01, 100.0).logpdf(a)
        + stats.uniform(0.2, 4.8).logpdf(f)
        + stats.uniform(-math.pi, 2 * math.pi).logpdf(phi)
        + stats.loguniform(1e-3, 10.0).logpdf(s)
        + stats.norm.logpdf(y, loc=a[:, None] * np.sin(2 * math.pi * f[:, None] * t + phi[:, None]), scale=s[:, None]).sum(axis=1)
    )
    np.testing.assert_allclose(_independent_log_posterior(theta, t, y), expected, rtol=1e-12)


def _random_walk_metropolis(t, y, start, n_chains=16, n_pilot=3000, n_main=12000, seed=5):
    rng = np.random.default_rng(seed)
    d = start.size
    x = start + 1e-4 * rng.standard_normal((n_chains, d)) * np.abs(start)
    lp = _independent_log_posterior(x, t, y)
    step = 1e-3 * np.abs(start)
    pilot = []
    for i in range(n_pilot):  # diagonal proposal, scale tuned towards ~30 % acceptance
        prop = x + step * rng.standard_normal((n_chains, d))
        lp_prop = _independent_log_posterior(prop, t, y)
        accept = np.log(rng.random(n_chains)) < lp_prop - lp
        x[accept], lp[accept] = prop[accept], lp_prop[accept]
        if i % 100 == 99:
            step *= math.exp(np.mean(accept) - 0.3)
        if i >= n_pilot // 2:
            pilot.append(x.copy())
    cov = np.cov(np.concatenate(pilot).T)
    chol = np.linalg.cholesky(2.38**2 / d * cov)
    chain = np.empty((n_main, n_chains, d))
    for i in range(n_main):
        prop = x + rng.standard_normal((n_chains, d)) @ chol.T
        lp_prop = _independent_log_posterior(prop, t, y)
        accept = np.log(rng.random(n_chains)) < lp_prop - lp
        x[accept], lp[accept] = prop[accept], lp_prop[accept]
        chain[i] = x
    return chain


@pytest.mark.slow
def test_emcee_agrees_with_independent_random_walk_metropolis():
    import arviz as az

    problem = _toy_problem(seed=3)
    t, y = problem.time_s, problem.data
    names = ["amplitude", "frequency_Hz", "phase_rad", "noise_sd"]
    truth = np.array([1.0, 1.0, 0.3, 0.1])
    rwm = _random_walk_metropolis(t, y, truth)
    rwm_ess = np.array([float(az.ess(np.ascontiguousarray(rwm[:, :, i].T), method="bulk")) for i in range(4)])
    assert np.all(rwm_ess > 2000), rwm_ess

    result = sample_posterior(problem, target_ess=2000, seed=7)
    assert result.diagnostics.converged, result.diagnostics.warnings
    draws = result.draws()
    ess = dict(zip(result.diagnostics.names, result.diagnostics.ess_bulk))
    for i, name in enumerate(names):
        ref = rwm[:, :, i].ravel()
        sd = ref.std(ddof=1)
        mc_mean = sd * math.sqrt(1 / rwm_ess[i] + 1 / ess[name])
        mc_sd = sd * math.sqrt(1 / (2 * rwm_ess[i]) + 1 / (2 * ess[name]))
        assert abs(draws[name].mean() - ref.mean()) < 4 * mc_mean, name
        assert abs(draws[name].std(ddof=1) - sd) < 5 * mc_sd, name


# --------------------------------------------------------------------------------------------
# Streaming API, seeding, diagnostics, InferenceData.
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def toy_preview():
    problem = _toy_problem(seed=1)
    return problem, preview(problem)


def test_sample_streams_progress_and_can_stop_and_resume(toy_preview):
    problem, lap = toy_preview
    run = EnsembleRun(problem, lap, seed=2)
    reports = []
    for progress in run.sample(100, every=10):
        assert isinstance(progress, Progress)
        reports.append(progress)
        if progress.step == 40:
            break  # a dashboard pressing "stop"
    assert [p.step for p in reports] == [10, 20, 30, 40]
    assert all(p.total == 100 for p in reports)
    assert all(0.0 < p.acceptance_fraction <= 1.0 for p in reports)
    assert run.n_steps == 40
    last = list(run.sample(25, every=5))
    assert [p.step for p in last] == [45, 50, 55, 60, 65]
    assert run.chain().shape == (65, run.n_walkers, problem.ndim)


def test_same_seed_same_chain_different_seed_different_chain(toy_preview):
    problem, lap = toy_preview
    chains = []
    for seed in (4, 4, 5):
        run = EnsembleRun(problem, lap, seed=seed)
        for _ in run.sample(30, every=30):
            pass
        chains.append(run.chain())
    np.testing.assert_array_equal(chains[0], chains[1])
    assert not np.array_equal(chains[0], chains[2])


def test_short_run_is_flagged_not_converged(toy_preview):
    problem, lap = toy_preview
    run = EnsembleRun(problem, lap, seed=3)
    for _ in run.sample(30, every=30):
        pass
    result = run.result(target_ess=1000)
    assert not result.diagnostics.converged
    assert any("ESS" in w for w in result.diagnostics.warnings)
    assert any("autocorrelation times" in w for w in result.diagnostics.warnings)


def test_run_to_ess_reaches_target_and_reports_diagnostics(toy_preview):
    problem, lap = toy_preview
    run = EnsembleRun(problem, lap, seed=6)
    result = run.run_to_ess(800)
    d = result.diagnostics
    assert d.converged, d.warnings
    assert d.ess_min >= 800 and d.rhat_max <= 1.01
    assert d.n_steps - d.n_burn >= 20 * d.autocorr_time_max
    assert 0.1 < d.acceptance_fraction < 0.9
    # emcee's integrated autocorrelation time is consistent with ArviZ's ESS (walkers as chains)
    naive = d.n_walkers * (d.n_steps - d.n_burn) / d.autocorr_time
    assert np.all(d.ess_bulk > 0.4 * naive) and np.all(d.ess_bulk < 2.5 * naive)
    summary = result.summary()
    assert set(summary) == set(problem.names)
    for s in summary.values():
        assert set(s) == {"mean", "sd", "q025", "q975"}
        assert s["q025"] < s["mean"] < s["q975"] and s["sd"] > 0


def test_inference_data_netcdf_round_trip(toy_preview, tmp_path):
    problem, lap = toy_preview
    result = EnsembleRun(problem, lap, seed=8).run_to_ess(300)
    idata = result.idata
    assert set(idata.groups()) >= {"posterior", "sample_stats", "observed_data"}
    assert idata.posterior["frequency_Hz"].shape == (result.diagnostics.n_walkers, result.chain.shape[0])
    assert idata.posterior["frequency_Hz"].attrs["units"] == "Hz"
    path = result.to_netcdf(tmp_path / "toy_posterior.nc")
    back = load_inference_data(path)
    for name in problem.names:
        np.testing.assert_array_equal(back.posterior[name].values, idata.posterior[name].values)
    np.testing.assert_array_equal(back.sample_stats["lp"].values, idata.sample_stats["lp"].values)
    np.testing.assert_array_equal(back.observed_data["y"].values, problem.data)
    np.testing.assert_array_equal(back.observed_data["time_s"].values, problem.time_s)
    assert back.posterior.attrs["likelihood"] == "iid"
    assert back.posterior["phase_rad"].attrs["prior"] == problem.parameter("phase_rad").prior.describe()
    # the netCDF4 engine reads the same file
    back4 = load_inference_data(path, engine="netcdf4")
    np.testing.assert_array_equal(back4.posterior["amplitude"].values, idata.posterior["amplitude"].values)


def test_sampled_log_prob_is_the_problem_log_posterior(toy_preview):
    problem, lap = toy_preview
    result = EnsembleRun(problem, lap, seed=9).run_to_ess(200)
    flat = result.chain.reshape(-1, problem.ndim)[:50]
    np.testing.assert_allclose(result.log_prob.reshape(-1)[:50], problem.log_posterior(flat), rtol=1e-12)


def test_ar1_problem_samples_and_reports_coefficient():
    problem = _toy_problem(seed=2, likelihood="ar1")
    result = sample_posterior(problem, target_ess=400, seed=1)
    s = result.summary()
    assert "ar1_coefficient" in s
    # no discrepancy: the residuals are white, the coefficient is near 0
    assert s["ar1_coefficient"]["q025"] < 0.0 < s["ar1_coefficient"]["q975"]
    assert result.diagnostics.converged, result.diagnostics.warnings


def test_streamed_run_to_ess_equals_run_to_ess(toy_preview):
    problem, lap = toy_preview
    streamed = EnsembleRun(problem, lap, seed=12)
    reports = list(streamed.sample_to_ess(500, every=50))
    steps = [p.step for p in reports]
    assert steps == sorted(steps) and steps[-1] == streamed.n_steps
    assert all(p.step <= p.total for p in reports) and reports[-1].total == streamed.n_steps
    direct = EnsembleRun(problem, lap, seed=12).run_to_ess(500)
    np.testing.assert_array_equal(streamed.result(target_ess=500).chain, direct.chain)


def test_autocorr_time_equals_emcee_and_survives_a_stuck_walker():
    """The autocorrelation time is emcee's (an AR(1) chain of known tau = (1 + phi) / (1 - phi) = 9
    recovered to 20 %); a walker that never moved does not make it NaN but lengthens it."""
    import emcee

    from beam.inference.convergence import autocorr_time

    rng = np.random.default_rng(5)
    phi, n_steps, n_walkers = 0.8, 4000, 16
    chain = np.zeros((n_steps, n_walkers, 2))
    noise = rng.standard_normal(chain.shape)
    for i in range(1, n_steps):
        chain[i] = phi * chain[i - 1] + noise[i]
    ours = autocorr_time(chain)
    np.testing.assert_allclose(ours, emcee.autocorr.integrated_time(chain, tol=0, quiet=True), rtol=1e-12)
    np.testing.assert_allclose(ours, (1 + phi) / (1 - phi), rtol=0.2)
    stuck = chain.copy()
    stuck[:, 3, :] = 0.7  # every proposal of walker 3 rejected
    tau = autocorr_time(stuck)
    assert np.all(np.isfinite(tau)) and np.all(tau > ours)
