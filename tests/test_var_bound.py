import numpy as np
import pytest
from scipy.stats import binom, norm

from mjsuff.bounds.var_bound import (
    bound_is_valid,
    least_effective_size,
    lower_var_bound,
    upper_var_bound,
    var_bound_index,
)
from mjsuff.posterior.diagnostics import quantile_ess


@pytest.mark.parametrize("n", [500, 2_000, 20_000])
@pytest.mark.parametrize("alpha", [0.9, 0.95, 0.99])
def test_normal_and_binomial_indices_agree_for_large_n(n, alpha):
    normal = var_bound_index(n, alpha, 0.05, "normal")
    exact = var_bound_index(n, alpha, 0.05, "binomial")
    assert abs(normal - exact) <= 1


def test_paper_index_for_500_samples():
    # Algorithm 1: ceil(500*0.95 + 1.6449*sqrt(500*0.95*0.05) - 0.5) = 483
    assert var_bound_index(500, 0.95, 0.05) == 483


def test_exact_index_has_the_promised_confidence():
    n, alpha, delta = 500, 0.95, 0.05
    j = var_bound_index(n, alpha, delta, "binomial")
    assert binom.cdf(j, n, alpha) >= 1 - delta > binom.cdf(j - 1, n, alpha)


def test_index_is_clipped_to_the_last_sample():
    assert var_bound_index(10, 0.99, 0.05) == 9


@pytest.mark.parametrize("method", ["normal", "binomial"])
def test_upper_bound_covers_the_true_quantile(method):
    # Uniform(0, 1) samples: the true 0.95-quantile is 0.95. Over 4000 repetitions the bound
    # must lie above it in at least 1 - delta of them (binomial s.e. of the rate ~0.0035, so
    # 0.935 leaves > 4 s.e. of slack while a point estimate would cover only ~50%).
    rng = np.random.default_rng(0)
    samples = rng.random((4000, 500))
    covered = np.mean([upper_var_bound(s, 0.95, 0.05, method) >= 0.95 for s in samples])
    assert covered >= 0.935


def test_lower_bound_mirrors_the_upper_bound():
    rng = np.random.default_rng(1)
    x = rng.normal(size=500)
    assert lower_var_bound(x, 0.95, 0.05) == -upper_var_bound(-x, 0.95, 0.05)
    samples = rng.random((2000, 500))
    covered = np.mean([lower_var_bound(s, 0.95, 0.05) <= 0.05 for s in samples])
    assert covered >= 0.93


def test_bad_arguments_are_rejected():
    with pytest.raises(ValueError, match="alpha"):
        var_bound_index(10, 1.5, 0.05)
    with pytest.raises(ValueError, match="finite"):
        upper_var_bound(np.array([0.1, np.nan]), 0.95, 0.05)


@pytest.mark.parametrize("method", ["normal", "binomial"])
def test_effective_size_index_reduces_to_the_independent_one(method):
    assert var_bound_index(500, 0.95, 0.05, method, ess=500) == var_bound_index(500, 0.95, 0.05, method)
    assert var_bound_index(500, 0.95, 0.05, method, ess=5000) == var_bound_index(500, 0.95, 0.05, method)
    # Fewer effective draws: a higher order statistic, never a lower one.
    indices = [var_bound_index(500, 0.95, 0.05, method, ess=e) for e in (500, 300, 150, 80)]
    assert indices == sorted(indices) and indices[-1] > indices[0]


def test_normal_index_for_an_effective_size():
    # j = ceil(n·α + z·n·sqrt(α(1−α)/n_eff) − ½) with n = 500, n_eff = 100: 475 + 17.93 − 0.5
    assert var_bound_index(500, 0.95, 0.05, "normal", ess=100) == 493


def test_too_few_effective_draws_is_reported():
    assert bound_is_valid(500, 0.95, 0.05, "normal", ess=60)
    assert not bound_is_valid(500, 0.95, 0.05, "normal", ess=50)
    assert var_bound_index(500, 0.95, 0.05, "normal", ess=50) == 499  # clipped
    with pytest.raises(ValueError, match="effective sample size"):
        var_bound_index(500, 0.95, 0.05, ess=0.0)


def _ar1_chains(rng, rho, chains=20, draws=25):
    x = np.empty((chains, draws))
    x[:, 0] = rng.standard_normal(chains)
    for t in range(1, draws):
        x[:, t] = rho * x[:, t - 1] + np.sqrt(1 - rho**2) * rng.standard_normal(chains)
    return x


def test_effective_size_restores_coverage_for_dependent_draws():
    # 20 stationary AR(1) chains (ρ = 0.8, N(0, 1) marginals) × 25 draws, as MCMC gives them:
    # the independent-draw index covers the true 0.95-quantile far less often than 0.95; the
    # index for the draws' quantile ESS (estimated from the chains each time) restores it. With
    # 1000 repetitions the s.e. of a rate is ~0.007: measured 0.83 and 0.94 (seed 0).
    rng = np.random.default_rng(0)
    q = norm.ppf(0.95)
    plain, corrected = [], []
    for _ in range(1000):
        x = _ar1_chains(rng, 0.8)
        flat = x.T.reshape(-1)
        plain.append(upper_var_bound(flat, 0.95, 0.05) >= q)
        ess = min(quantile_ess(x, 0.95), flat.size)
        corrected.append(upper_var_bound(flat, 0.95, 0.05, ess=ess) >= q)
    assert np.mean(plain) <= 0.88
    assert np.mean(corrected) >= 0.92


def test_least_effective_size_is_the_smallest_valid_one():
    for alpha in (0.9, 0.95, 0.99):
        m = least_effective_size(500, alpha, 0.05)
        assert bound_is_valid(500, alpha, 0.05, ess=m)
        assert not bound_is_valid(500, alpha, 0.05, ess=m - 1)
    assert least_effective_size(60, 0.95, 0.05) is None  # too few draws for the normal index
    assert least_effective_size(59, 0.95, 0.05, "binomial") == 59  # the maximum: 0.95^59 < 0.05
