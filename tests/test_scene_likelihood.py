"""The scenes' trajectory likelihood (``mjsuff.scenes.likelihood``)."""

import numpy as np
import pytest
from scipy.special import logsumexp

from mjsuff.scenes import likelihood
from mjsuff.scenes.likelihood import demo_log_likelihoods, row_log_sum_exp
from mjsuff.threads import SIM_THREADS_ENV


def test_row_log_sum_exp_is_scipys_with_ties_and_wide_rows():
    rng = np.random.default_rng(0)
    for scale in (1.0, 1e2, 1e5):  # β·w·φ reaches 10^4 and more: a naive exp overflows
        values = scale * rng.normal(size=(40, 70))
        values[::3, 7] = values[::3].max(axis=1)  # tied maxima in every third row
        np.testing.assert_allclose(row_log_sum_exp(values), logsumexp(values, axis=1), rtol=1e-15, atol=0)
    assert np.isfinite(row_log_sum_exp(np.array([[-1e300, 1e300]]))).all()


@pytest.mark.parametrize("threads", ["1", "2"])
def test_demos_shared_among_threads_give_the_same_bits_as_one_by_one(threads, monkeypatch):
    """The sampler's batches (4,096 rows, ~10 demos of ~150 candidates) go to threads; every
    column must be what the demo alone gives, bit for bit (a run's results must not depend on
    the machine's cores), and the Boltzmann formula written out."""
    monkeypatch.setenv(SIM_THREADS_ENV, threads)
    rng = np.random.default_rng(1)
    weights = rng.normal(size=(4096, 5))
    sets = [rng.normal(size=(int(rng.integers(20, 200)), 5)) for _ in range(10)]
    beta = 260.0
    batched = demo_log_likelihoods(weights, sets, beta)
    monkeypatch.setattr(likelihood, "PARALLEL_PRODUCTS", np.inf)
    one_by_one = np.column_stack([demo_log_likelihoods(weights, [c], beta)[:, 0] for c in sets])
    np.testing.assert_array_equal(batched, one_by_one)
    direct = np.column_stack([beta * weights @ c[0] - logsumexp(beta * weights @ c.T, axis=1) for c in sets])
    np.testing.assert_allclose(batched, direct, rtol=1e-12, atol=1e-9)
