"""Library-based V* (``SceneDomain.optimal_start_values``) against planning every reward
(issue #3 acceptance), on fixed seeds; values in units of ``V* − V_rand``."""

import numpy as np
import pytest

from mjsuff.scenes.planner import SamplingPlanner
from mjsuff.sphere import random_unit_vectors
from tests.test_planner import SCENES, STARTS, scene_domain

REWARDS = 200
#: Planning every one of the 800 (reward, start) pairs from scratch takes minutes per scene;
#: a random 64 of them are planned and compared.
PAIRS = 64


@pytest.mark.parametrize("name", sorted(SCENES))
def test_library_values_match_planning_every_reward(name):
    domain = scene_domain(name)
    rng = np.random.default_rng(2)
    weights = -np.abs(random_unit_vectors(rng, REWARDS, domain.num_features))
    before = domain.optimal_start_values(weights, refine=False)
    fast = domain.optimal_start_values(weights)
    assert np.all(fast >= before - 1e-12)  # never below the library maximum
    pairs = rng.choice(REWARDS * STARTS, size=PAIRS, replace=False)
    w_idx, s_idx = np.divmod(pairs, STARTS)
    full = SamplingPlanner(domain.scene, domain.planner.config).plan(
        s_idx, weights[w_idx], np.random.default_rng(3)).values
    v_rand = np.einsum("nk,nk->n", weights[w_idx],
                       domain.random_start_feature_expectations()[s_idx])
    gap = (full - fast[w_idx, s_idx]) / (np.maximum(full, fast[w_idx, s_idx]) - v_rand)
    # Measured: reacher −0.1% (the library is better), lander 0.1%; a negative mean is the
    # library beating per-reward planning.
    assert gap.mean() <= 0.01, gap.round(4)
