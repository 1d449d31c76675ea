import numpy as np
import pytest

from mjsuff.domains import REGISTRY
from mjsuff.domains.tabular import OptimalPolicyCache
from mjsuff.sphere import random_unit_vectors

TABULAR = sorted(n for n, spec in REGISTRY.items() if spec.kind == "tabular")


def instance(name, seed=0):
    return REGISTRY[name].make(None, np.random.default_rng(seed))


@pytest.mark.parametrize("name", TABULAR)
def test_cache_matches_value_iteration_for_many_weights(name):
    domain = instance(name)
    weights = random_unit_vectors(np.random.default_rng(1), 300, domain.num_features)
    q_cache, _ = domain.cache.solve(weights)
    q_vi = domain.mdp.value_iteration(weights, tol=1e-12)
    np.testing.assert_allclose(q_cache, q_vi, atol=1e-7)
    # A second pass is served from the cache and gives the same answer.
    size = len(domain.cache)
    np.testing.assert_allclose(domain.cache.solve(weights)[0], q_cache)
    assert len(domain.cache) == size


@pytest.mark.parametrize("name", TABULAR)
def test_successor_features_give_policy_values(name):
    domain = instance(name, 2)
    mdp = domain.mdp
    rng = np.random.default_rng(3)
    policy = rng.integers(mdp.num_actions, size=mdp.num_states)
    w = random_unit_vectors(rng, 1, domain.num_features)[0]
    # Iterative policy evaluation as the reference.
    r = mdp.features @ w
    v = np.zeros(mdp.num_states)
    p_pi = mdp.transitions[np.arange(mdp.num_states), policy]
    for _ in range(2000):
        v = r + mdp.gamma * p_pi @ v
    np.testing.assert_allclose(mdp.successor_features(policy) @ w, v, atol=1e-8)


def test_optimal_values_never_below_any_policy():
    domain = instance("gridworld", 4)
    rng = np.random.default_rng(5)
    weights = random_unit_vectors(rng, 50, domain.num_features)
    v_opt = domain.optimal_start_values(weights)
    for _ in range(20):
        policy = rng.integers(domain.mdp.num_actions, size=domain.mdp.num_states)
        v = weights @ domain.start_feature_expectations(policy).T
        assert np.all(v <= v_opt + 1e-9)


def test_fresh_cache_and_shared_cache_agree():
    domain = instance("driving", 6)
    weights = random_unit_vectors(np.random.default_rng(7), 64, domain.num_features)
    fresh = OptimalPolicyCache(domain.mdp)
    np.testing.assert_allclose(fresh.optimal_values(weights), domain.cache.optimal_values(weights), atol=1e-9)
