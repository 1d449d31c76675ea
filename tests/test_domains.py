"""Every registered tabular domain: create, demonstrate, likelihood, shapes, no NaNs, seeded.

The MuJoCo scenes' contract tests are in tests/test_scene_domain.py (their demos are not optimal
and their policies are trajectories, so the exact-optimality checks here do not apply)."""

import numpy as np
import pytest

from mjsuff.domains import REGISTRY, get_domain
from mjsuff.sphere import random_unit_vectors

RUNNABLE = sorted(n for n, spec in REGISTRY.items() if spec.kind == "tabular")


@pytest.fixture(params=RUNNABLE)
def domain(request):
    return get_domain(request.param).make(None, np.random.default_rng(11))


def test_shapes_and_normalization(domain):
    k = domain.num_features
    s = domain.start_weights.size
    assert domain.true_weights.shape == (k,)
    assert np.isclose(np.linalg.norm(domain.true_weights), 1.0)
    assert np.isclose(domain.start_weights.sum(), 1.0)
    assert domain.random_start_feature_expectations().shape == (s, k)
    assert domain.baseline_start_feature_expectations().shape == (s, k)
    w = random_unit_vectors(np.random.default_rng(0), 7, k)
    v = domain.optimal_start_values(w)
    assert v.shape == (7, s) and np.all(np.isfinite(v))
    assert domain.optimal_values(w).shape == (7,)


def test_expert_demos_are_optimal_and_most_likely_under_true_weights(domain):
    rng = np.random.default_rng(1)
    demos = [domain.demonstrate(int(i), rng) for i in range(domain.pool.size)]
    policy = domain.plan(domain.true_weights)
    assert domain.policy_optimality(policy) == 1.0
    assert all(domain.agrees_with_demo(policy, d) for d in demos)
    # Demos from every start favour w* over almost all random weight vectors (not all: a vector
    # with the same optimal policy but larger Q-gaps is more likely under Boltzmann rationality).
    w = random_unit_vectors(rng, 500, domain.num_features)
    ll = domain.log_likelihood(w, demos, beta=10.0)
    ll_true = domain.log_likelihood(domain.true_weights[None], demos, beta=10.0)[0]
    assert np.all(np.isfinite(ll)) and ll_true >= np.quantile(ll, 0.9)


def test_poor_demos_are_not_optimal(domain):
    rng = np.random.default_rng(2)
    policy = domain.plan(domain.true_weights)
    poor = [domain.demonstrate(int(i), rng, poor=True) for i in range(domain.pool.size)]
    assert sum(d.poor for d in poor) > 0
    assert not any(domain.agrees_with_demo(policy, d) for d in poor if d.poor)


@pytest.mark.parametrize("name", RUNNABLE)
def test_instances_are_reproducible_and_vary_by_seed(name):
    spec = get_domain(name)
    a = spec.make(None, np.random.default_rng(5))
    b = spec.make(None, np.random.default_rng(5))
    c = spec.make(None, np.random.default_rng(6))
    assert np.array_equal(a.true_weights, b.true_weights)
    assert np.array_equal(a.mdp.features, b.mdp.features)
    assert not (
        np.array_equal(a.true_weights, c.true_weights) and np.array_equal(a.mdp.features, c.mdp.features)
    )


def test_gridworld_goal_is_absorbing_with_the_largest_weight():
    d = get_domain("gridworld").make({"num_features": 4}, np.random.default_rng(3))
    goal = np.flatnonzero(d.mdp.terminal)
    assert goal.size == 1 and d.mdp.features[goal[0], -1] == 1
    assert d.true_weights.argmax() == 3
    assert goal[0] not in d.pool


def test_driving_has_five_motorists_and_wraps():
    d = get_domain("driving").make(None, np.random.default_rng(3))
    assert d.mdp.features[:, 3].sum() == 5
    # From the last row, moving on lands in the first row.
    last_row_state = 4 * 5 + 2
    assert d.mdp.transitions[last_row_state, 0].argmax() == 2
