"""The MCMC sampler against an exact posterior on a fine sphere grid (k = 3)."""

import warnings

import numpy as np
import pytest

from mjsuff.domains import get_domain
from mjsuff.posterior import (
    SamplerConfig,
    chain_diagnostics,
    grid_posterior,
    quantile_ess,
    rank_rhat,
    sample_posterior,
)


@pytest.fixture(scope="module")
def problem():
    domain = get_domain("gridworld").make({"num_features": 3}, np.random.default_rng(21))
    rng = np.random.default_rng(22)
    demos = [domain.demonstrate(int(s), rng) for s in rng.permutation(domain.pool.size)[:6]]
    return lambda w: domain.log_likelihood(w, demos, beta=5.0)


def test_mcmc_matches_the_exact_grid_posterior(problem):
    exact = grid_posterior(problem, num_points=40_000)
    # The posterior must be informative, or agreeing with it would prove nothing.
    assert np.linalg.norm(exact.mean) > 0.3
    post = sample_posterior(
        problem, 3, SamplerConfig(num_samples=12_000, chains=8, burn_in=400, thin=2), np.random.default_rng(0)
    )
    mean = post.samples.mean(axis=0)
    cov = np.cov(post.samples.T)
    # Tolerances: with ~1500 draws per chain and autocorrelation times of a few steps, the
    # Monte Carlo s.e. of a mean coordinate is ~0.01 (sd <= 0.6) and of a covariance entry
    # ~0.006; 0.04 and 0.025 are about four s.e. The grid (spacing ~0.018 rad) adds < 0.005.
    np.testing.assert_allclose(mean, exact.mean, atol=0.04)
    np.testing.assert_allclose(cov, exact.covariance, atol=0.025)
    assert post.converged and post.rhat <= 1.01
    assert post.acceptance_rate > 0.5  # the multiple-try jumps move most of the time


def test_map_is_the_best_point_visited(problem):
    post = sample_posterior(problem, 3, SamplerConfig(num_samples=200), np.random.default_rng(1))
    assert post.map_log_likelihood >= post.log_likelihoods.max() - 1e-12
    assert np.isclose(problem(post.map_weights[None])[0], post.map_log_likelihood)


def test_samples_are_unit_vectors_and_seeded(problem):
    a = sample_posterior(problem, 3, SamplerConfig(num_samples=100), np.random.default_rng(2))
    b = sample_posterior(problem, 3, SamplerConfig(num_samples=100), np.random.default_rng(2))
    assert a.samples.shape == (100, 3)
    np.testing.assert_allclose(np.linalg.norm(a.samples, axis=1), 1.0)
    np.testing.assert_array_equal(a.samples, b.samples)


def test_rank_rhat_detects_disagreeing_chains():
    rng = np.random.default_rng(3)
    same = rng.normal(size=(4, 500, 2))
    assert rank_rhat(same) < 1.02
    shifted = same + np.arange(4)[:, None, None]
    assert rank_rhat(shifted) > 1.5
    # A chain with the right mean but a wider spread: the folded (tail) R̂ catches it.
    wide = same.copy()
    wide[0] *= 3.0
    assert rank_rhat(wide) > 1.05


def test_ess_of_independent_and_dependent_draws():
    rng = np.random.default_rng(4)
    iid = rng.normal(size=(20, 100, 3))
    d = chain_diagnostics(iid)
    assert 1500 < d.ess_bulk < 2500 and 1500 < d.ess_tail < 2500
    sticky = np.repeat(iid[:, :20], 5, axis=1)  # every draw repeated 5 times
    assert chain_diagnostics(sticky).ess_bulk < 0.4 * 20 * 100
    assert quantile_ess(sticky[..., 0], 0.95) < 0.4 * 20 * 100


def test_converged_posterior_meets_its_targets(problem):
    config = SamplerConfig(num_samples=500)
    post = sample_posterior(problem, 3, config, np.random.default_rng(5))
    assert post.converged
    assert post.rhat <= config.rhat_target
    assert min(post.ess_bulk, post.ess_tail) >= config.ess_target
    assert config.burn_in < post.steps <= config.max_steps
    # The kept draws are grouped by chain as the samples interleave them.
    np.testing.assert_array_equal(post.by_chain(post.samples[:, 0]), post.chain_samples[:, :, 0])


def test_a_run_that_hits_the_cap_is_flagged_not_converged(problem):
    # An unreachable R̂ target and a cap of one round: the sampler stops at the cap and says so.
    config = SamplerConfig(num_samples=200, burn_in=20, rhat_target=1.000001, max_steps=60)
    post = sample_posterior(problem, 3, config, np.random.default_rng(6))
    assert not post.converged
    assert post.steps == 60
    assert post.samples.shape == (200, 3)


def test_effective_size_of_per_sample_values(problem):
    post = sample_posterior(problem, 3, SamplerConfig(num_samples=500), np.random.default_rng(7))
    values = post.samples[:, 0]
    ess = post.effective_size(values, 0.95)
    assert 100 < ess <= 500
    # Constant values: every order statistic is the same, so they count as independent.
    assert post.effective_size(np.zeros(500), 0.95) == 500


def test_a_likelihood_of_minus_infinity_is_never_entered():
    # Zero likelihood on the half-sphere w_0 < 0 (a hard constraint): jumps whose candidates
    # all land there must stay put, never produce NaN or a draw there; the other half is
    # uniform, so its mean is (1/2, 0, 0) for k = 3 (E|w_0| = 1/2 on the 2-sphere).
    def half(w):
        return np.where(w[:, 0] >= 0.0, 0.0, -np.inf)

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "invalid value" from −inf − (−inf) either
        post = sample_posterior(half, 3, SamplerConfig(num_samples=2000), np.random.default_rng(8))
    assert post.converged
    assert np.isfinite(post.samples).all() and (post.samples[:, 0] >= 0).all()
    # 2000 near-independent draws: s.e. of each mean coordinate ≤ 0.6/√2000 ≈ 0.013; 0.05 ≈ 4 s.e.
    np.testing.assert_allclose(post.samples.mean(axis=0), [0.5, 0.0, 0.0], atol=0.05)
