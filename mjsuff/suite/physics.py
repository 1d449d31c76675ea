"""A scene instance's physics for dm_control: it steps as ``mujoco.rollout`` does and reads the
episode's reward features with the scene's own featurizer.

Assumptions: one ``mj_step`` per control step, controls applied as given (``legacy_step`` off, so
the state and sensors after a step are exactly those ``mujoco.rollout`` records); an episode starts
at rest at time 0, like the rollouts of ``Scene.simulate``.
"""

from __future__ import annotations

import copy

import numpy as np

from mjsuff.scenes.scene import Scene
from mjsuff.scenes.simulate import Rollouts
from mjsuff.suite._dm_control import MjModel, Physics

#: Model arrays an instance's randomization may change (positions and sizes of geoms and sites).
INSTANCE_FIELDS = ("geom_pos", "geom_size", "geom_rbound", "site_pos", "site_size")


class ScenePhysics(Physics):
    """Physics of one scene instance that records its episode.

    Use :meth:`for_scene` to build one; :meth:`place` moves an existing one to another instance of
    the same scene (a new episode's goal, lava or pad).
    """

    legacy_step = False

    @classmethod
    def for_scene(cls, scene: Scene) -> ScenePhysics:
        """Physics with a copy of ``scene``'s compiled model (its instance in place)."""
        physics = cls.from_model(MjModel(copy.copy(scene.model)))
        physics.scene = scene
        physics.clear_episode()
        return physics

    def place(self, scene: Scene) -> None:
        """Take ``scene``'s instance geometry (same MJCF model, other positions and sizes)."""
        for field in INSTANCE_FIELDS:
            getattr(self.model.ptr, field)[:] = getattr(scene.model, field)
        self.scene = scene

    # -- the episode ----------------------------------------------------------------------------
    def clear_episode(self) -> None:
        """Forget the recorded steps (a new episode starts)."""
        self._steps: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []

    def record(self, control: np.ndarray) -> None:
        """Record the step just taken with ``control`` (the state and sensors after it)."""
        d = self.data.ptr
        self._steps.append(
            (d.qpos.copy(), d.qvel.copy(), d.sensordata.copy(), np.asarray(control, dtype=float).copy())
        )

    @property
    def steps_taken(self) -> int:
        return len(self._steps)

    def trajectory(self) -> Rollouts:
        """The episode so far as a batch of one rollout (``(1, t, ·)`` arrays, ``t ≥ 1``)."""
        if not self._steps:
            raise RuntimeError("no step recorded in this episode yet")
        qpos, qvel, sensors, controls = (np.stack(x)[None] for x in zip(*self._steps, strict=True))
        return Rollouts(qpos, qvel, sensors, controls, np.array([True]))

    # -- feature readers ------------------------------------------------------------------------
    def step_features(self, horizon: int) -> np.ndarray:
        """``φ_t`` ``(k,)`` of the last step of an episode of ``horizon`` steps
        (``Scene.step_features``: the rollout featurizer's own code)."""
        if not self._steps:
            return np.zeros(self.scene.num_features)
        return self.scene.step_features(self.trajectory(), horizon)[0, -1]

    def episode_features(self, horizon: int) -> np.ndarray:
        """``Σ_t φ_t`` ``(k,)`` over the steps so far; the trajectory's features once it is whole."""
        if not self._steps:
            return np.zeros(self.scene.num_features)
        return self.scene.step_features(self.trajectory(), horizon)[0].sum(axis=0)

    def set_start(self, qpos: np.ndarray) -> None:
        """Joint positions ``qpos`` at rest (call inside ``reset_context``)."""
        self.data.qpos[:] = qpos
        self.data.qvel[:] = 0.0
