"""The task of a scene environment: an instance per episode, a start, ``w·φ_t`` per step.

An episode lasts the scene's horizon (``horizon`` seconds of control steps), so its return
``Σ_t w·φ_t`` is ``w·φ(τ)``: the value mjsuff's learner and expert give the trajectory. It ends
with discount 1 (a time limit, not a terminal state).
"""

from __future__ import annotations

import abc
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mjsuff.scenes.scene import Scene
from mjsuff.suite._dm_control import base, control
from mjsuff.suite.physics import ScenePhysics


@dataclass(frozen=True)
class Instance:
    """A scene instance and its hidden weights ``w*`` (unit norm)."""

    scene: Scene
    true_weights: np.ndarray


class SceneTask(base.Task, abc.ABC):
    """Episodes on instances of one scene.

    Args:
        instance: The first episode's instance (every episode's, without ``draw``).
        rng: Randomness of instances and starts.
        weights: Reward weights ``(k,)``; None rewards each episode with its instance's ``w*``.
        starts: Start joint positions ``(n, nq)`` taken in turn by the episodes; None draws each
            episode's start from the instance's start distribution.
        draw: Draws a new instance from ``rng`` for each episode after the first; None keeps
            ``instance``.
    """

    def __init__(
        self,
        instance: Instance,
        rng: np.random.Generator,
        weights: np.ndarray | None = None,
        starts: np.ndarray | None = None,
        draw: Callable[[np.random.Generator], Instance] | None = None,
    ) -> None:
        super().__init__(random=np.random.RandomState(rng.integers(2**31)))  # unused by mjsuff
        self.instance, self._rng, self._draw = instance, rng, draw
        self.weights = None if weights is None else np.asarray(weights, dtype=float)
        self._starts = None if starts is None else np.atleast_2d(np.asarray(starts, dtype=float))
        self._episodes = 0

    @property
    def horizon(self) -> int:
        """Control steps per episode."""
        return self.instance.scene.spline.num_steps

    @property
    def reward_weights(self) -> np.ndarray:
        """The weights ``w`` of this episode's reward ``w·φ_t``."""
        return self.instance.true_weights if self.weights is None else self.weights

    def initialize_episode(self, physics: ScenePhysics) -> None:
        if self._draw is not None and self._episodes > 0:
            self.instance = self._draw(self._rng)
        physics.place(self.instance.scene)
        if self._starts is not None:
            start = self._starts[self._episodes % len(self._starts)]
        else:
            start = self.instance.scene.sample_starts(self._rng, 1)[0]
        self._episodes += 1
        physics.set_start(start)
        physics.clear_episode()
        # base.Task.initialize_episode only recolours geoms for visualize_reward (not offered).

    def before_step(self, action: np.ndarray, physics: ScenePhysics) -> None:
        self._action = np.asarray(action, dtype=float)
        physics.set_control(self._action)

    def after_step(self, physics: ScenePhysics) -> None:
        physics.record(self._action)

    def get_reward(self, physics: ScenePhysics) -> float:
        return float(self.reward_weights @ physics.step_features(self.horizon))

    def get_termination(self, physics: ScenePhysics) -> float | None:
        return 1.0 if physics.steps_taken >= self.horizon else None

    def get_observation(self, physics: ScenePhysics) -> OrderedDict[str, np.ndarray]:
        obs = self.observe(physics)
        obs["time_left"] = np.array([(self.horizon - physics.steps_taken) * physics.model.opt.timestep])
        return obs

    @abc.abstractmethod
    def observe(self, physics: ScenePhysics) -> OrderedDict[str, np.ndarray]:
        """What a policy needs of the current state (the scene's own part of the observation)."""


def environment(
    physics: ScenePhysics, task: SceneTask, environment_kwargs: dict | None = None
) -> control.Environment:
    """A ``control.Environment`` whose episodes end with the task's horizon (not a time limit),
    stepping with ``mj_step`` as ``mujoco.rollout`` does."""
    kwargs = dict(environment_kwargs or {})
    if kwargs.get("legacy_step", False):
        raise ValueError(
            "environment_kwargs: legacy_step must be False (a step is one mj_step, "
            "as in mujoco.rollout, or the sensors lag the featurizer's)"
        )
    kwargs.setdefault("time_limit", float("inf"))
    return control.Environment(
        physics, task, legacy_step=False, **{k: v for k, v in kwargs.items() if k != "legacy_step"}
    )
