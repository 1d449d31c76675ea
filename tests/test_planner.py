"""Planner quality on fixed seeds (issue #3 acceptance), and its settings.

Values are compared in units of the instance's scale, ``V* − V_rand`` (per start and reward):
a gap of 0.01 is 1% of the way from the random policy to the optimum.
"""

import numpy as np
import pytest
from pydantic import ValidationError

from mjsuff.domains import get_domain
from mjsuff.scenes.domain import SceneDomain
from mjsuff.scenes.planner import SamplingPlanner
from mjsuff.scenes.planner_config import PlannerConfig
from mjsuff.sphere import random_unit_vectors

STARTS = 4
LIMIT = {"lava_reacher": 0.01}


def scene_domain(name: str) -> SceneDomain:
    return get_domain(name).make({"eval_starts": STARTS, "pool_starts": 2}, np.random.default_rng(0))


def scaled_gap(better, value, v_rand):
    best = np.maximum(better, value)
    return (best - value) / (best - v_rand)


@pytest.mark.parametrize("name", ["lava_reacher"])
def test_planner_is_near_ten_times_its_budget(name):
    """π against a 10×-budget plan from the same warm start. The lander's case (2 rewards × 4
    starts, limit 2.5%; measured mean 1.8%, max 3.6%) cost the suite 113–157 s, the most of any
    test: it is measured by ``python benchmarks/scenes.py --scenes lander --starts 4 --rewards 50
    --subset 4 --quality 2`` (the same comparison on the benchmark's instance, printed) instead:
    stop 62, mean 0.77%, max 1.72%."""
    domain = scene_domain(name)
    scene, starts = domain.scene, np.arange(STARTS)
    weights = -np.abs(random_unit_vectors(np.random.default_rng(9), 2, scene.num_features))
    gaps = []
    for w in weights:
        warm = np.stack([domain.library.arrays(s)[1][domain.library.best(s, w[None])[1][0]] for s in starts])
        value = domain.start_feature_expectations(domain.plan(w)) @ w
        reference = (
            SamplingPlanner(scene, domain.planner.config.scaled(10))
            .plan(starts, np.tile(w, (STARTS, 1)), np.random.default_rng(5), warm_knots=warm)
            .values
        )
        gaps.append(scaled_gap(reference, value, domain.random_start_feature_expectations() @ w))
    # Mean over 2 rewards x 4 starts. The unit is V* − V_rand with the random policy of the
    # redesigned scenes (issue #17: random goal-directed paths of the demonstrator), several times
    # smaller than the uniform-random splines' of issue #3, so the same absolute error is a larger
    # share. Measured: reacher within 1% (CMA-ES from the library's best); lander 1.8% (max 3.6%):
    # its landscape has other basins that a 10x-wider search finds.
    assert np.mean(gaps) <= LIMIT[name], np.round(gaps, 4)


def test_planner_improves_on_its_warm_start_and_keeps_it_otherwise():
    domain = scene_domain("lava_reacher")
    scene = domain.scene
    w = -np.abs(random_unit_vectors(np.random.default_rng(4), 1, scene.num_features))[0]
    warm = scene.spline.uniform(np.random.default_rng(6), STARTS)
    _, warm_features = scene.simulate(scene.starts, warm)
    for config in (
        PlannerConfig(population=16, elites=4, iterations=3),
        PlannerConfig(iterations=0, cma_population=8, cma_iterations=3),
    ):
        plans = SamplingPlanner(scene, config).plan(
            np.arange(STARTS), np.tile(w, (STARTS, 1)), np.random.default_rng(7), warm_knots=warm
        )
        # The warm start is evaluated first, so a plan is never worse than it.
        assert np.all(plans.values >= warm_features @ w - 1e-12)
        _, replayed = scene.simulate(scene.starts, plans.knots)
        np.testing.assert_allclose(replayed @ w, plans.values)


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"population": 8, "elites": 9}, "exceed the population"),
        ({"cma_population": 8}, "both be 0"),
        ({"cma_iterations": 8}, "both be 0"),
        ({"cma_population": 3, "cma_iterations": 8}, "at least 4"),
        ({"iterations": 0}, "needs CEM iterations or a CMA-ES phase"),
    ],
)
def test_invalid_planner_settings_are_clear_errors(settings, message):
    with pytest.raises(ValidationError, match=message):
        PlannerConfig(**settings)


def test_budget_and_scaling_count_both_phases():
    config = PlannerConfig(population=64, elites=6, iterations=12, cma_population=24, cma_iterations=96)
    assert config.budget == 64 * 12 + 24 * 96
    assert config.scaled(10).budget == 10 * config.budget


def test_polished_v_star_of_samples_off_w_star_is_near_ten_times_the_planner_budget():
    """V* for prior draws (off w*, as a one-demo posterior's tail is), after refinement and the
    local quadratic model's proposals (mjsuff.scenes.surrogate), against a 10×-budget plan of
    each (sample, start) from the library's best. Measured: mean 0.29%, max 1.0% of V* − V_rand
    over 3 draws × 4 starts (benchmarks/tail_vstar.py measures the shipped settings' tail)."""
    domain = scene_domain("lava_reacher")
    scene, starts = domain.scene, np.arange(STARTS)
    weights = domain.sample_prior(np.random.default_rng(12), 3)
    learner = domain.optimal_start_values(weights)  # no robot policy: every sample is refined
    problems = np.repeat(weights, STARTS, axis=0), np.tile(starts, len(weights))
    warm = np.stack(
        [
            domain.library.arrays(int(s))[1][domain.library.best(int(s), w[None])[1][0]]
            for w, s in zip(*problems, strict=True)
        ]
    )
    reference = (
        SamplingPlanner(scene, domain.planner.config.stronger(10))
        .plan(problems[1], problems[0], np.random.default_rng(13), warm_knots=warm)
        .values
    )
    v_rand = np.einsum("nk,nk->n", problems[0], domain.random_start_feature_expectations()[problems[1]])
    gaps = scaled_gap(reference, learner.reshape(-1), v_rand)
    assert np.mean(gaps) <= 0.01 and np.max(gaps) <= 0.03, np.round(gaps, 4)
