import numpy as np
import pytest
from scipy.stats import binom

from mjsuff.bounds.var_bound import lower_var_bound, upper_var_bound, var_bound_index


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
