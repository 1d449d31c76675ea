"""The paper's world variants and PIOB baseline (domain.params world / weight_ranges / baseline):
the defaults draw exactly what they always drew, the paper's variants follow its code."""

import numpy as np
import pytest

from mjsuff.domains import get_domain
from mjsuff.domains.baselines import nonpessimal_actions
from mjsuff.domains.driving import WEIGHT_RANGES
from mjsuff.experiment.scenario import ScenarioError, load_scenario
from mjsuff.sphere import random_unit_vectors

GOOD = 'name = "x"\n[domain]\nname = "{}"\n'


@pytest.mark.parametrize("seed", range(5))
def test_default_gridworld_makes_the_draws_it_always_made(seed):
    """Terrain cell, k − 1 terrain features, sorted weights, a random baseline: in this order."""
    d = get_domain("gridworld").make(None, np.random.default_rng(seed))
    rng = np.random.default_rng(seed)
    goal = int(rng.integers(25))
    terrain = rng.integers(3, size=25)
    terrain[goal] = 3
    weights = np.sort(random_unit_vectors(rng, 1, 4)[0])
    baseline = rng.integers(4, size=25)
    assert np.array_equal(d.mdp.features, np.eye(4)[terrain])
    assert np.flatnonzero(d.mdp.terminal).tolist() == [goal]
    assert np.array_equal(d.true_weights, weights / np.linalg.norm(weights))
    assert np.array_equal(d.baseline_policy, baseline)


@pytest.mark.parametrize("seed", range(5))
def test_default_driving_makes_the_draws_it_always_made(seed):
    d = get_domain("driving").make(None, np.random.default_rng(seed))
    rng = np.random.default_rng(seed)
    cars = rng.choice([s for s in range(25) if s % 5 in (1, 2, 3)], size=5, replace=False)
    weights = np.array(
        [
            rng.integers(1, 10),
            rng.integers(1, 10),
            rng.integers(1, 10),
            rng.integers(-20, -10),
            rng.integers(-10, 0),
        ],
        dtype=float,
    )
    baseline = rng.integers(3, size=25)
    assert sorted(np.flatnonzero(d.mdp.features[:, 3])) == sorted(cars)
    assert np.array_equal(d.true_weights, weights / np.linalg.norm(weights))
    assert np.array_equal(d.baseline_policy, baseline)


def test_paper_gridworld_has_no_goal_feature_and_unsorted_weights():
    worlds = [get_domain("gridworld").make({"world": "paper"}, np.random.default_rng(s)) for s in range(40)]
    terminal_features = set()
    for d in worlds:
        goal = np.flatnonzero(d.mdp.terminal)
        assert goal.size == 1 and goal[0] not in d.pool and d.pool.size == 24
        assert d.mdp.features.shape == (25, 4) and np.all(d.mdp.features.sum(axis=1) == 1)
        terminal_features.add(int(d.mdp.features[goal[0]].argmax()))
    # Terminal cells keep their random terrain: every feature appears there over 40 worlds; the
    # weights are not sorted (sorted ones would put the largest last in every world).
    assert terminal_features == {0, 1, 2, 3}
    assert len({int(d.true_weights.argmax()) for d in worlds}) == 4
    assert not all(np.all(np.diff(d.true_weights) >= 0) for d in worlds)


def test_paper_gridworld_uses_every_terrain_feature_per_cell():
    d = get_domain("gridworld").make(
        {"world": "paper", "num_features": 3, "rows": 12, "cols": 12}, np.random.default_rng(0)
    )
    counts = d.mdp.features.sum(axis=0)
    assert counts.shape == (3,) and np.all(counts > 30)  # about 48 cells each of 144


def test_safe_driving_draws_integers_from_the_safe_ranges():
    """The same draws as the default variant, from the paper's randint bounds for "safe"."""
    assert WEIGHT_RANGES["safe"] == ((1, 5), (1, 5), (5, 10), (-10, -5), (-5, 0))
    d = get_domain("driving").make({"weight_ranges": "safe"}, np.random.default_rng(7))
    rng = np.random.default_rng(7)
    rng.choice([s for s in range(25) if s % 5 in (1, 2, 3)], size=5, replace=False)
    weights = np.array([rng.integers(lo, hi) for lo, hi in WEIGHT_RANGES["safe"]], dtype=float)
    assert np.array_equal(d.true_weights, weights / np.linalg.norm(weights))
    assert 1 <= weights[0] <= 4 and 5 <= weights[2] <= 9 and -10 <= weights[3] <= -6


@pytest.mark.parametrize("name", ["gridworld", "driving"])
def test_nonpessimal_baseline_never_takes_a_worst_action(name):
    for seed in range(10):
        d = get_domain(name).make({"baseline": "nonpessimal"}, np.random.default_rng(seed))
        q = d.cache.solve(d.true_weights[None])[0][0][d.pool]
        chosen = q[np.arange(d.pool.size), d.baseline_policy[d.pool]]
        low = q.min(axis=1)
        spread = q.max(axis=1) - low
        assert np.all((chosen > low + 1e-9) | (spread <= 1e-9))


@pytest.mark.parametrize("name", ["gridworld", "driving"])
def test_nonpessimal_baseline_leaves_the_instance_unchanged(name):
    """The baseline is the last draw, so the world and w* are those of the random baseline."""
    a = get_domain(name).make({"baseline": "nonpessimal"}, np.random.default_rng(4))
    b = get_domain(name).make(None, np.random.default_rng(4))
    assert np.array_equal(a.mdp.features, b.mdp.features)
    assert np.array_equal(a.true_weights, b.true_weights)


def test_nonpessimal_actions_are_uniform_over_the_non_minimal_ones():
    q = np.array(
        [
            [0.0, 1.0, 1.0, 2.0],  # any of 1, 2, 3
            [5.0, 5.0, 5.0, 5.0],  # all equal (a terminal state): any action
            [3.0, 0.0, 0.0, 0.0],  # only 0
        ]
    )
    picks = np.array([nonpessimal_actions(q, np.random.default_rng(s)) for s in range(3000)])
    assert set(picks[:, 0]) == {1, 2, 3} and set(picks[:, 1]) == {0, 1, 2, 3}
    assert set(picks[:, 2]) == {0}
    shares = np.bincount(picks[:, 0], minlength=4)[1:] / len(picks)
    assert np.allclose(shares, 1 / 3, atol=0.04)


@pytest.mark.parametrize(
    ("domain", "key", "value"),
    [
        ("gridworld", "world", '"goals"'),
        ("gridworld", "baseline", '"worst"'),
        ("driving", "weight_ranges", '"nasty"'),
        ("driving", "world", '"paper"'),
    ],
)
def test_bad_variant_is_a_one_line_error(tmp_path, domain, key, value):
    path = tmp_path / "s.toml"
    path.write_text(GOOD.format(domain))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, [f"domain.params.{key}={value}"])
    message = str(info.value)
    assert f"domain.params.{key}" in message and "\n" not in message


def test_variants_load_from_a_scenario(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD.format("driving"))
    s = load_scenario(path, ['domain.params.weight_ranges="safe"', 'domain.params.baseline="nonpessimal"'])
    params = s.domain_params()
    assert (params.weight_ranges, params.baseline) == ("safe", "nonpessimal")
    assert 'weight_ranges = "safe"' in s.to_toml()
