"""The local quadratic model that polishes V* (mjsuff.scenes.surrogate)."""

import numpy as np
import pytest
from scipy.optimize import minimize

from mjsuff.scenes.surrogate import (
    STEP_SHARES,
    propose,
    quadratic_design,
    quadratic_terms,
    trust_region_step,
)


def test_a_quadratic_is_recovered_exactly_from_its_design():
    rng = np.random.default_rng(0)
    n = 4
    a = rng.standard_normal((n, n))
    h = (a + a.T) / 2
    g = rng.standard_normal(n)
    d = rng.standard_normal((60, n))
    y = 3.0 + d @ g + 0.5 * np.einsum("mi,ij,mj->m", d, h, d)
    coef = np.linalg.lstsq(quadratic_design(d), y, rcond=None)[0]
    g_fit, h_fit = quadratic_terms(coef[None], n)
    np.testing.assert_allclose(g_fit[0], g, atol=1e-10)
    np.testing.assert_allclose(h_fit[0], h, atol=1e-10)


def test_trust_region_step_is_the_constrained_maximizer():
    """Against SLSQP from 8 starts on random quadratics, concave and not, with maximizers inside
    and outside the unit ball: never worse than the best SLSQP answer by more than its
    tolerance, never outside the ball."""
    rng = np.random.default_rng(1)
    n = 9
    for _ in range(30):
        a = rng.standard_normal((n, n))
        h = (a + a.T) / 2 - rng.uniform(-2.0, 6.0) * np.eye(n)
        g = rng.standard_normal(n) * rng.uniform(0.1, 5.0)
        d = trust_region_step(g[None], h[None])[0]
        assert np.linalg.norm(d) <= 1.0 + 1e-9

        def loss(x, g=g, h=h):
            return -(g @ x + 0.5 * x @ h @ x)

        best = min(
            minimize(
                loss, x0, method="SLSQP", constraints=[{"type": "ineq", "fun": lambda x: 1.0 - x @ x}]
            ).fun
            for x0 in rng.standard_normal((8, n)) * 0.3
        )
        assert -loss(d) >= -best - 1e-4 * (1.0 + abs(best))


def test_proposals_reach_a_maximizer_inside_the_neighbourhood():
    """A library sampled around a concave quadratic's maximizer: the full step lands on it."""
    rng = np.random.default_rng(2)
    n = 9
    peak = np.full(n, 0.5) + rng.uniform(-0.02, 0.02, n)
    a = rng.standard_normal((n, n))
    h = -(a @ a.T + n * np.eye(n))
    units = np.clip(0.5 + 0.05 * rng.standard_normal((400, n)), 0.0, 1.0)
    values = 0.5 * np.einsum("mi,ij,mj->m", units - peak, h, units - peak)
    proposals = propose(units, values[None], neighbours=160)
    assert proposals.shape == (1, len(STEP_SHARES), n)
    np.testing.assert_allclose(proposals[0, -1], peak, atol=1e-6)  # the full step (share 1)


@pytest.mark.parametrize("entries", [10, 40])
def test_too_few_entries_for_a_model_propose_nothing(entries):
    rng = np.random.default_rng(3)
    units = rng.uniform(size=(entries, 9))
    assert propose(units, rng.standard_normal((2, entries)), neighbours=160).shape == (2, 0, 9)
