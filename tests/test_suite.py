"""The scenes as dm_control environments (issue #16): conformance, features equal to the rollout
featurizer's, demo replay, π_MAP in the env, the MuJoCo/dm_control pair, bad input."""

import unittest
from importlib import metadata

import mujoco
import numpy as np
import pytest
from dm_env import StepType, test_utils

from mjsuff import suite
from mjsuff.domains import REGISTRY, get_domain
from mjsuff.experiment.demo_generation import generate_demos
from mjsuff.experiment.scenario import load_scenario
from mjsuff.posterior import SamplerConfig, sample_posterior

from .test_demo_set import OVERRIDES, ROOT

SCENES = sorted(suite.SCENES)
SMALL_PLANNING = {
    "planner": {"population": 32, "elites": 4, "iterations": 8},
    "refine_groups": 4,
    "refine_rounds": 1,
    "seed_directions": 2,
}


def test_installed_mujoco_runs_dm_control():
    """dm_control reads MjModel fields by name: a MuJoCo release that renames one breaks
    ``suite.load`` and ``mjcf.Physics`` (dm-control 1.0.50 on mujoco 4.0.0: 'flex_vertedge').
    This fails on such a pair, so an upgrade of the pins is caught, not discovered."""
    from dm_control import mjcf
    from dm_control import suite as dm_suite

    env = dm_suite.load("reacher", "easy", task_kwargs={"random": 0})
    env.reset()
    timestep = env.step(np.zeros(env.action_spec().shape))
    assert timestep.step_type == StepType.MID and np.isfinite(timestep.observation["position"]).all()
    model = mjcf.RootElement()
    model.worldbody.add("body").add("geom", type="sphere", size=[0.1])
    physics = mjcf.Physics.from_mjcf_model(model)
    physics.step()
    pins = dict(
        r.replace(" ", "").split("==")
        for r in metadata.requires("mjsuff")
        if r.replace(" ", "").split("==")[0] in ("mujoco", "dm-control")
    )
    assert pins == {"mujoco": mujoco.__version__, "dm-control": metadata.version("dm-control")}


def test_every_registered_scene_has_an_environment():
    assert set(SCENES) == {n for n, spec in REGISTRY.items() if spec.kind == "scene"}


def _conformance(name):
    class Conformance(test_utils.EnvironmentTestMixin, unittest.TestCase):
        def make_object_under_test(self):
            return suite.load(name, seed=0)

        def make_action_sequence(self):  # a few episodes' worth, within the action spec
            spec = self.environment.action_spec()
            rng = np.random.default_rng(1)
            for _ in range(2 * self.environment.task.horizon + 3):
                yield rng.uniform(spec.minimum, spec.maximum)

    Conformance.__name__ = Conformance.__qualname__ = f"TestDmEnvConformance_{name}"
    return Conformance


for _name in SCENES:
    globals()[f"TestDmEnvConformance_{_name}"] = _conformance(_name)


def _play(env, controls):
    """One episode of ``controls``; -> per-step features (T, k), rewards (T,), last timestep."""
    env.reset()
    feats, rewards = [], []
    for u in controls:
        timestep = env.step(u)
        feats.append(env.physics.step_features(env.task.horizon))
        rewards.append(timestep.reward)
    return np.array(feats), np.array(rewards), timestep


@pytest.mark.parametrize("name", SCENES)
def test_step_features_and_rewards_equal_the_rollout_featurizers(name):
    instance = suite.load(name, seed=2).task.instance
    scene = instance.scene
    start = scene.sample_starts(np.random.default_rng(3), 1)[0]
    env = suite.load_instance(scene, instance.true_weights, starts=start[None])
    knots = scene.spline.uniform(np.random.default_rng(3), 1)
    controls = scene.spline.controls(knots, scene.anchor(start[None]) if scene.spline.anchored else None)[0]
    feats, rewards, last = _play(env, controls)
    rollouts, features = scene.simulate(start[None], knots)
    # One mj_step per control step, as in mujoco.rollout: the same states, the same features.
    np.testing.assert_allclose(feats, scene.step_features(rollouts)[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(feats.sum(axis=0), features[0], rtol=0, atol=1e-12)
    w = env.task.instance.true_weights
    np.testing.assert_allclose(rewards, feats @ w, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rewards.sum(), w @ features[0], rtol=0, atol=1e-12)
    assert last.step_type == StepType.LAST and last.discount == 1.0
    assert len(rewards) == scene.spline.num_steps


def test_episodes_draw_new_instances_reproducibly():
    env, again = suite.load("lava_reacher", seed=7), suite.load("lava_reacher", seed=7)
    goals = []
    for _ in range(3):
        env.reset()
        again.reset()
        goals.append(env.task.instance.scene.goal.copy())
        np.testing.assert_array_equal(env.task.instance.scene.goal, again.task.instance.scene.goal)
        np.testing.assert_array_equal(env.physics.data.qpos, again.physics.data.qpos)
        np.testing.assert_array_equal(env.physics.named.model.site_pos["goal", :2], goals[-1])
    assert len({tuple(g) for g in goals}) == 3


def test_a_saved_demo_set_replays_to_its_features(tmp_path):
    scenario = load_scenario(ROOT / "scenarios" / "lava_reacher.toml", OVERRIDES)
    path = generate_demos(scenario, 2).save(tmp_path / "demos.npz")
    env, demo_set = suite.load_demo_set(path)
    for i in range(len(demo_set)):
        feats, _, _ = _play(env, demo_set.arrays["controls"][i])
        np.testing.assert_array_equal(env.physics.data.qpos, demo_set.arrays["qpos"][i, -1])
        np.testing.assert_allclose(feats.sum(axis=0), demo_set.arrays["features"][i], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", SCENES)
def test_pi_map_runs_in_the_environment(name):
    domain = get_domain(name).make({"eval_starts": 3, "planning": SMALL_PLANNING}, np.random.default_rng(3))
    rng = np.random.default_rng(4)
    demos = [domain.demonstrate(0, rng)]
    post = sample_posterior(
        lambda w: domain.log_likelihood(w, demos, 10.0),
        domain.num_features,
        SamplerConfig(num_samples=100),
        rng,
    )
    policy = domain.plan(post.map_weights)  # π_MAP: knots from every evaluation start
    scene = domain.scene
    env = suite.load_instance(scene, domain.true_weights, starts=scene.starts)
    expected = domain.start_feature_expectations(policy)
    anchor = scene.anchor(scene.starts) if scene.spline.anchored else None
    for s, controls in enumerate(scene.spline.controls(policy, anchor)):
        feats, rewards, _ = _play(env, controls)
        np.testing.assert_allclose(feats.sum(axis=0), expected[s], rtol=0, atol=1e-12)
        np.testing.assert_allclose(rewards.sum(), domain.true_weights @ expected[s], atol=1e-12)


def test_bad_input_names_the_scene_and_what_was_expected():
    with pytest.raises(ValueError, match=r"unknown scene 'cartpole'.*\['lander', 'lava_reacher'\]"):
        suite.load("cartpole")
    with pytest.raises(ValueError, match=r"weights: scene 'lander' rewards 6 features.*shape \(3,\)"):
        suite.load("lander", weights=np.ones(3))
    with pytest.raises(ValueError, match="eval_starts"):
        suite.load("lava_reacher", params={"eval_starts": 0})
    with pytest.raises(ValueError, match="legacy_step must be False"):
        suite.load("lava_reacher", environment_kwargs={"legacy_step": True})
