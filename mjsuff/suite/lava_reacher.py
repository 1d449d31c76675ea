"""The lava reacher as a dm_control environment (``mjsuff.scenes.lava_reacher``)."""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from mjsuff.scenes.lava_reacher import LavaReacher
from mjsuff.suite.physics import ScenePhysics
from mjsuff.suite.task import SceneTask

SCENE = LavaReacher


class ReacherPhysics(ScenePhysics):
    """Feature readers of the reacher's state (metres, radians)."""

    scene: LavaReacher

    def fingertip(self) -> np.ndarray:
        """Fingertip (x, y) now."""
        return self.named.data.site_xpos["fingertip", :2].copy()

    def to_goal(self) -> np.ndarray:
        """Goal minus fingertip (x, y)."""
        return self.scene.goal - self.fingertip()

    def to_lava(self) -> np.ndarray:
        """Lava centre minus fingertip (x, y)."""
        return self.scene.lava_centre - self.fingertip()

    def to_water(self) -> np.ndarray:
        """Water centre minus fingertip (x, y)."""
        return self.scene.water_centre - self.fingertip()


class ReacherTask(SceneTask):
    """Reach the goal past the hazards, smoothly; reward ``w·φ_t`` (distance, lava, water,
    motion)."""

    def observe(self, physics: ReacherPhysics) -> OrderedDict[str, np.ndarray]:
        return OrderedDict(
            position=physics.data.qpos.copy(),
            velocity=physics.data.qvel.copy(),
            to_goal=physics.to_goal(),
            to_lava=physics.to_lava(),
            lava_radius=np.array([physics.scene.lava_radius]),
            to_water=physics.to_water(),
            water_radius=np.array([physics.scene.water_radius]),
        )


PHYSICS, TASK = ReacherPhysics, ReacherTask
