"""The MCMC sampler against an exact posterior on a fine sphere grid (k = 3)."""

import numpy as np
import pytest

from mjsuff.domains import get_domain
from mjsuff.posterior import SamplerConfig, grid_posterior, sample_posterior, split_rhat


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
    post = sample_posterior(problem, 3, SamplerConfig(
        num_samples=12_000, chains=8, burn_in=400, thin=2), np.random.default_rng(0))
    mean = post.samples.mean(axis=0)
    cov = np.cov(post.samples.T)
    # Tolerances: with ~1500 draws per chain and autocorrelation times of a few steps, the
    # Monte Carlo s.e. of a mean coordinate is ~0.01 (sd <= 0.6) and of a covariance entry
    # ~0.006; 0.04 and 0.025 are about four s.e. The grid (spacing ~0.018 rad) adds < 0.005.
    np.testing.assert_allclose(mean, exact.mean, atol=0.04)
    np.testing.assert_allclose(cov, exact.covariance, atol=0.025)
    assert post.rhat < 1.05
    assert 0.2 < post.acceptance_rate < 0.6


def test_map_is_the_best_point_visited(problem):
    post = sample_posterior(problem, 3, SamplerConfig(num_samples=200),
                            np.random.default_rng(1))
    assert post.map_log_likelihood >= post.log_likelihoods.max() - 1e-12
    assert np.isclose(problem(post.map_weights[None])[0], post.map_log_likelihood)


def test_samples_are_unit_vectors_and_seeded(problem):
    a = sample_posterior(problem, 3, SamplerConfig(num_samples=100), np.random.default_rng(2))
    b = sample_posterior(problem, 3, SamplerConfig(num_samples=100), np.random.default_rng(2))
    assert a.samples.shape == (100, 3)
    np.testing.assert_allclose(np.linalg.norm(a.samples, axis=1), 1.0)
    np.testing.assert_array_equal(a.samples, b.samples)


def test_split_rhat_detects_disagreeing_chains():
    rng = np.random.default_rng(3)
    same = rng.normal(size=(4, 500, 2))
    assert split_rhat(same) < 1.02
    shifted = same + np.arange(4)[:, None, None]
    assert split_rhat(shifted) > 1.5
