"""Independent ensembles: the grouped DE move keeps them apart, R-hat compares them."""

from __future__ import annotations

import emcee
import numpy as np
import pytest

from beam.inference.convergence import ensemble_draws, rhat
from beam.inference.sampling import GroupedMove


def _gaussian(cov):
    prec = np.linalg.inv(cov)

    def log_prob(x):
        return -0.5 * np.einsum("ij,jk,ik->i", x, prec, x)

    return log_prob


def test_ensemble_draws_pools_each_ensemble_in_time_order():
    rng = np.random.default_rng(0)
    chain = rng.normal(size=(5, 8, 3))  # steps, walkers, parameters
    x = ensemble_draws(chain, 2)
    assert x.shape == (2, 20, 3)
    for k in range(2):
        expected = np.concatenate([chain[t, 4 * k:4 * (k + 1)] for t in range(5)])  # step by step
        np.testing.assert_array_equal(x[k], expected)


def test_rhat_over_ensembles_is_one_for_identical_chains_and_flags_a_shifted_ensemble():
    rng = np.random.default_rng(1)
    chain = rng.normal(size=(400, 16, 2))
    assert np.all(np.abs(rhat(chain, 4) - 1.0) < 0.01)
    shifted = chain.copy()
    shifted[:, :4, 0] += 0.5  # ensemble 0 centred half a standard deviation away
    r = rhat(shifted, 4)
    # classic R-hat: sqrt(1 + var(means) / var(within)) = sqrt(1 + 0.0625 / 1.05) ~ 1.03
    assert 1.015 < r[0] < 1.045 and abs(r[1] - 1.0) < 0.01


def test_grouped_de_keeps_an_ensemble_in_its_mode():
    """Two far-apart modes: ensemble 0 starts in one, the others in the other. DE vectors
    between the modes would carry walkers across (plain DEMove does); grouped, none moves."""
    centre = np.array([10.0, 0.0])

    def log_prob(x):
        a = -0.5 * np.sum((x - centre) ** 2, axis=1)
        b = -0.5 * np.sum((x + centre) ** 2, axis=1)
        return np.logaddexp(a, b)

    rng = np.random.default_rng(2)
    p0 = rng.normal(size=(32, 2)) + centre
    p0[:8] -= 2 * centre  # ensemble 0 (walkers 0-7) around -centre

    def run(move):
        sampler = emcee.EnsembleSampler(32, 2, log_prob, vectorize=True, moves=move)
        state = emcee.State(p0, random_state=np.random.RandomState(3).get_state())
        sampler.run_mcmc(state, 300)
        return sampler.get_chain()

    grouped = run(GroupedMove(emcee.moves.DEMove(), 4))
    assert np.all(grouped[:, :8, 0] < 0) and np.all(grouped[:, 8:, 0] > 0)
    assert rhat(grouped, 4)[0] > 1.5  # the stuck ensemble is flagged
    plain = run(emcee.moves.DEMove())
    assert np.any(plain[:, :8, 0] > 0) or np.any(plain[:, 8:, 0] < 0)


@pytest.mark.parametrize("move", [emcee.moves.DEMove, emcee.moves.DESnookerMove])
def test_other_ensembles_do_not_see_an_ensemble_moved_elsewhere(move):
    """Same random stream, ensemble 0 started elsewhere: ensembles 1-3 follow exactly the same
    path (the moves draw as many random numbers whatever the positions), so nothing of ensemble
    0 enters them. Without the grouping they do change."""
    log_prob = _gaussian(np.diag([1.0, 4.0, 0.25]))
    rng = np.random.default_rng(6)
    p0 = rng.normal(size=(32, 3))
    p1 = p0.copy()
    p1[:8] += 3.0

    def run(m, start):
        sampler = emcee.EnsembleSampler(32, 3, log_prob, vectorize=True, moves=m)
        sampler.run_mcmc(emcee.State(start, random_state=np.random.RandomState(7).get_state()), 50)
        return sampler.get_chain()

    a, b = run(GroupedMove(move(), 4), p0), run(GroupedMove(move(), 4), p1)
    np.testing.assert_array_equal(a[:, 8:], b[:, 8:])
    assert not np.array_equal(a[:, :8], b[:, :8])
    a, b = run(move(), p0), run(move(), p1)
    assert not np.array_equal(a[:, 8:], b[:, 8:])


def test_grouped_de_samples_a_correlated_gaussian():
    # DE only: emcee's DESnookerMove alone is off by itself here (variances ~15 % low with or
    # without the grouping, measured), so it cannot check the grouping.
    move = emcee.moves.DEMove
    cov = np.array([[1.0, 0.8, 0.0], [0.8, 1.0, -0.3], [0.0, -0.3, 2.0]])
    rng = np.random.default_rng(4)
    p0 = rng.normal(size=(24, 3)) * 0.1
    sampler = emcee.EnsembleSampler(24, 3, _gaussian(cov), vectorize=True, moves=GroupedMove(move(), 4))
    sampler.run_mcmc(emcee.State(p0, random_state=np.random.RandomState(5).get_state()), 4000)
    chain = sampler.get_chain()[500:]
    draws = chain.reshape(-1, 3)
    # Monte Carlo error with ~24 * 3500 / 15 effective draws: sd of the mean ~0.02-0.03
    np.testing.assert_allclose(draws.mean(axis=0), 0.0, atol=0.1)
    np.testing.assert_allclose(np.cov(draws.T), cov, atol=0.1)
    assert np.max(rhat(chain, 4)) < 1.01


def test_run_to_ess_adapts_each_ensembles_proposal_from_its_own_draws():
    from beam.inference import EnsembleRun, preview
    from beam.toy import ToyScenario, simulate, toy_problem

    data = simulate(ToyScenario(seed=0))
    problem = toy_problem(data.time_s[data.calibration], data.data[data.calibration])
    run = EnsembleRun(problem, preview(problem), seed=2)
    assert run.n_ensembles == 4
    proposal = run.moves[0][0].proposal
    np.testing.assert_array_equal(proposal.means, np.tile(run.laplace.mean, (4, 1)))  # before: the Laplace centre
    result = run.run_to_ess(1000, initial_steps=60)  # too short: a second chunk, adapted
    assert result.diagnostics.converged and result.diagnostics.n_ensembles == 4
    assert len({tuple(m) for m in proposal.means}) == 4  # each ensemble its own centre
    # each centre is its ensemble's mean, within the posterior sd (the draws it came from are fewer)
    sd = np.std(run.chain().reshape(-1, problem.ndim), axis=0)
    assert np.all(np.abs(proposal.means - run.laplace.mean) < sd)
