"""Kinesthetic experts (issue #4): tracking, quality against the planner, behaviour under w*.

Gaps are in units of the start's scale, ``(V_plan − V_demo) / (V_plan − V_rand)``; a negative gap
means the expert beat the planner.
"""

import numpy as np
import pytest

from mjsuff.domains import REGISTRY
from mjsuff.experts.expert import ExpertError, ExpertSettings
from mjsuff.experts.lander import LanderExpert
from mjsuff.experts.reacher import ReacherExpert
from mjsuff.scenes.lander import Lander, LanderParams
from mjsuff.scenes.lava_reacher import LavaReacher, LavaReacherParams
from mjsuff.scenes.perturbation import perturb_controls
from mjsuff.scenes.planner import SamplingPlanner

STARTS = 3
SCENES = {
    n: (spec.scene, spec.params, spec.expert())
    for n, spec in REGISTRY.items()
    if spec.scene is not None and spec.expert is not None
}
# Stated gaps (mean over the starts), against a planner without a library. Measured on these
# seeds: reacher 0.001–0.054, mean 0.029 (two hazards that cost 3× more than in v0.1: a 3-knot fit
# of the expert's path pays for near misses the planner's free search avoids); lander 0.14-0.18
# per start, mean 0.16: its fall-and-brake family flies less tilted and burns more fuel than the
# planner's free spline, and the knots it hands the robot are a least-squares fit of its
# closed-loop set-points, flown open loop.
MEAN_GAP = {"lava_reacher": 0.04, "lander": 0.25}


def unit(w):
    w = np.asarray(w, dtype=float)
    return w / np.linalg.norm(w)


@pytest.fixture(scope="module", params=sorted(SCENES))
def setup(request):
    scene_type, params_type, expert_type = SCENES[request.param]
    scene = scene_type(params_type(eval_starts=STARTS), np.random.default_rng(0))
    return request.param, scene, expert_type(scene)


def test_demos_are_near_the_planners_optimum(setup):
    name, scene, expert = setup
    w = -unit([0.5, 0.6, 0.4, 0.3, 0.4, 0.4][: scene.num_features])
    demos = [expert.demonstrate(scene.starts[s], w, np.random.default_rng(s)) for s in range(STARTS)]
    planned = (
        SamplingPlanner(scene, scene.planner_config)
        .plan(np.arange(STARTS), np.tile(w, (STARTS, 1)), np.random.default_rng(0))
        .values
    )
    _, random_features = scene.simulate(
        np.repeat(scene.starts, 32, axis=0), scene.spline.uniform(np.random.default_rng(1), 32 * STARTS)
    )
    v_rand = np.nanmean(random_features.reshape(STARTS, 32, -1), axis=1) @ w
    values = np.array([d.value for d in demos])
    np.testing.assert_allclose(values, [d.features @ w for d in demos])
    gaps = (planned - values) / (np.maximum(planned, values) - v_rand)
    assert gaps.mean() <= MEAN_GAP[name], gaps.round(3)
    assert all(d.value == d.best_value for d in demos)  # a rational expert shows its best


def test_reacher_executes_the_spline_nearest_its_reference():
    """The demo is the knot spline closest (least squares) to mink's reference. Three knots in
    1.5 s follow a path coarsely: measured 5–7 cm off the intended path at its worst instant for
    the slowest paths (1.4 s), 8–12 cm for the fast ones the expert prefers (0.5–1.1 s)."""
    scene = LavaReacher(LavaReacherParams(eval_starts=4), np.random.default_rng(3))
    expert = ReacherExpert(scene, ExpertSettings(refine_rounds=0))
    for s, w in enumerate(
        [[-0.3, -0.9, -0.9, -0.3], [-0.9, -0.05, -0.05, -0.4], [-0.2, -0.2, -0.2, -0.96], [-1, -1, -1, -0.1]]
    ):
        demo = expert.demonstrate(scene.starts[s], unit(w), np.random.default_rng(s))
        assert demo.tracking_error <= 0.15, demo.tracking_error
        assert demo.qpos.shape == (scene.spline.num_steps, 3) and np.isfinite(demo.qpos).all()
    # The slow straight path, from the first start whose IK can track it (not all can).
    tracked = [
        (q, done)
        for q in scene.starts
        for done in [expert.execute(q, np.array([[0.0, 1.4, 1.0]]))[0]]
        if len(done.params)
    ]
    assert tracked
    start, slow = tracked[0]
    assert slow.tracking_error[0] <= 0.08, slow.tracking_error
    # The executed trajectory is the spline of the returned knots.
    _, features = scene.simulate(start, slow.knots)
    np.testing.assert_array_equal(features, slow.features)


def test_reacher_detours_around_the_lava_only_when_it_costs():
    scene = LavaReacher(LavaReacherParams(eval_starts=2), np.random.default_rng(0))
    expert = ReacherExpert(scene)
    start = scene.starts[0]
    careful = expert.demonstrate(start, unit([-0.2, -0.97, -0.97, -0.1]), np.random.default_rng(0))
    hasty = expert.demonstrate(start, unit([-0.97, -0.01, -0.01, -0.2]), np.random.default_rng(0))
    assert careful.features[1] < 0.2 * hasty.features[1]
    assert hasty.features[1] > 0.0
    # Paid for with distance: a way around, or stopping short of the goal.
    assert careful.features[0] > hasty.features[0]


def test_lander_fuel_weight_trades_fuel_for_a_harder_landing():
    scene = Lander(LanderParams(eval_starts=2), np.random.default_rng(0))
    expert = LanderExpert(scene)
    start = scene.starts[0]
    frugal = expert.demonstrate(
        start, unit([-0.3, -0.05, -0.95, -0.1, -0.05, -0.05]), np.random.default_rng(0)
    )
    gentle = expert.demonstrate(
        start, unit([-0.3, -0.95, -0.05, -0.1, -0.05, -0.05]), np.random.default_rng(0)
    )
    assert frugal.features[2] < gentle.features[2]  # fuel
    assert frugal.features[1] > 2 * gentle.features[1]  # impact


def test_poor_and_boltzmann_demos(setup):
    _, scene, expert = setup
    w = -unit(np.ones(scene.num_features))
    best = expert.demonstrate(scene.starts[0], w, np.random.default_rng(0))
    poor = expert.demonstrate(scene.starts[0], w, np.random.default_rng(0), poor=True)
    assert poor.poor and poor.value < best.value
    noisy = type(expert)(scene, ExpertSettings(rationality=1.0, refine_rounds=0))
    values = {
        round(noisy.demonstrate(scene.starts[0], w, np.random.default_rng(i)).value, 9) for i in range(6)
    }
    assert len(values) > 1  # low rationality: different choices under different seeds


def test_same_seed_same_demo(setup):
    _, scene, expert = setup
    w = -unit(np.arange(1, scene.num_features + 1))
    a = expert.demonstrate(scene.starts[1], w, np.random.default_rng(4))
    b = expert.demonstrate(scene.starts[1], w, np.random.default_rng(4))
    np.testing.assert_array_equal(a.controls, b.controls)
    np.testing.assert_array_equal(a.features, b.features)


def test_demo_replays_to_its_features(setup):
    _, scene, expert = setup
    w = -unit(np.ones(scene.num_features))
    demo = expert.demonstrate(scene.starts[0], w, np.random.default_rng(0))
    rollouts, features = scene.simulate_controls(demo.start_qpos, demo.controls[None])
    np.testing.assert_allclose(features[0], demo.features)
    np.testing.assert_allclose(rollouts.qpos[0], demo.qpos)


def test_ik_failures_are_counted_and_an_all_failed_start_is_an_error():
    scene = LavaReacher(LavaReacherParams(eval_starts=2), np.random.default_rng(0))
    expert = ReacherExpert(scene)
    done, failures = expert.execute(scene.starts[0], np.array([[0.0, 1.0, 1.0], [0.6, 0.3, 1.0]]))
    assert len(done.params) == 1 and len(failures) == 1 and "missed by" in failures[0]

    class Hopeless(ReacherExpert):
        def coarse_params(self, start_qpos):
            return np.array([[0.8, 0.3, 1.0]])

    with pytest.raises(ExpertError, match="no candidate path"):
        Hopeless(scene).demonstrate(scene.starts[0], -unit([1, 1, 1, 1]), np.random.default_rng(0))


def test_scene_domain_demonstrates_through_its_expert():
    from mjsuff.domains import get_domain

    domain = get_domain("lava_reacher").make({"eval_starts": 2, "pool_starts": 2}, np.random.default_rng(0))
    demo = domain.demonstrate(1, np.random.default_rng(0))
    assert demo.start == 1 and not demo.poor
    direct = domain.expert.demonstrate(
        domain.scene.pool_starts[1], domain.true_weights, np.random.default_rng(0)
    )
    np.testing.assert_array_equal(demo.data["features"], direct.features)
    np.testing.assert_array_equal(demo.data["controls"], direct.controls)


def test_correction_makes_the_demo_locally_optimal_under_w_star():
    """Correction (issue #17) replaces the chosen demo by better perturbations of its own controls
    until it stops improving: the demo is then worth at least the uncorrected one, is the rollout
    of its own controls, and a fresh batch of the likelihood's perturbations (64, another stream)
    rarely beats it. Measured on 19 demos of 2 calibration instances: 0–1 of 64 beat it."""
    scene = LavaReacher(LavaReacherParams(eval_starts=3), np.random.default_rng(5))
    plain = ReacherExpert(scene)
    corrected = ReacherExpert(scene, ExpertSettings(correction_rounds=100, correction_patience=3))
    w = -unit([0.5, 0.6, 0.4, 0.3])
    improved = 0
    for s, start in enumerate(scene.starts):
        before = plain.demonstrate(start, w, np.random.default_rng(s))
        after = corrected.demonstrate(start, w, np.random.default_rng(s))
        assert after.value >= before.value
        improved += after.value > before.value
        assert after.tracking_error < 0.5 and after.executed.shape == before.executed.shape
        _, replay = scene.simulate_controls(start, after.controls[None])
        np.testing.assert_allclose(replay[0], after.features, rtol=1e-9, atol=1e-12)
        batch = perturb_controls(scene.spline, after.controls, np.random.default_rng(100 + s))
        _, features = scene.simulate_controls(start, batch)
        assert np.sum(features @ w > after.value) <= 2
    assert improved >= 1  # the expert's path family is not locally optimal (docs/issue-17-history.md)


def test_first_candidates_run_once_per_start_and_change_no_demo(setup):
    """The demo from a start and its candidate set share one execution of the first candidates
    (``Expert.first_candidates``): it runs once per start, equals a fresh execution bit for bit,
    and a demo made from the kept one equals a demo made cold."""
    _, scene, expert = setup
    w = -unit(np.arange(1, scene.num_features + 1))
    start = scene.starts[2]
    cold = type(expert)(scene).demonstrate(start, w, np.random.default_rng(7))
    warm_expert = type(expert)(scene)
    calls = []
    execute = warm_expert.execute
    warm_expert.execute = lambda q, params: calls.append(params) or execute(q, params)
    done, failures = warm_expert.first_candidates(start)
    failures.append("changed by the caller")
    again, failures_again = warm_expert.first_candidates(start)
    warm = warm_expert.demonstrate(start, w, np.random.default_rng(7))
    coarse = warm_expert.coarse_params(start)
    assert sum(np.array_equal(p, coarse) for p in calls) == 1 and again is done
    assert "changed by the caller" not in failures_again
    fresh, _ = expert.execute(start, expert.coarse_params(start))
    np.testing.assert_array_equal(done.features, fresh.features)
    np.testing.assert_array_equal(done.rollouts.qpos, fresh.rollouts.qpos)
    for name in ("controls", "qpos", "features", "executed", "intended", "params"):
        np.testing.assert_array_equal(getattr(warm, name), getattr(cold, name))
    assert warm.value == cold.value and warm.candidates == cold.candidates
