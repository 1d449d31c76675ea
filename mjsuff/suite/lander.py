"""The lander as a dm_control environment (``mjsuff.scenes.lander``)."""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from mjsuff.scenes.lander import REST_HEIGHT, TOUCH_THRESHOLD, Lander
from mjsuff.suite.physics import ScenePhysics
from mjsuff.suite.task import SceneTask

SCENE = Lander


class LanderPhysics(ScenePhysics):
    """Feature readers of the craft's state (metres, radians, newtons)."""

    scene: Lander

    def to_pad(self) -> np.ndarray:
        """Pad centre minus craft x, and height above resting on the ground."""
        x, z = self.data.qpos[0], self.data.qpos[1]
        return np.array([self.scene.pad_x - x, z - REST_HEIGHT])

    def to_zones(self) -> np.ndarray:
        """Each keep-out zone's centre (habitat, array; on the ground) minus the craft's (x, z),
        flattened ``(4,)``."""
        x, z = self.data.qpos[0], self.data.qpos[1]
        return np.stack([self.scene.zone_x - x, np.full(2, -z)], axis=1).ravel()

    def feet_touching(self) -> np.ndarray:
        """Whether each foot (left, right) touches the ground (0 or 1)."""
        return (self.named.data.sensordata[["foot_left", "foot_right"]] > TOUCH_THRESHOLD).astype(float)


class LanderTask(SceneTask):
    """Land on the pad softly, frugally and upright, clear of the keep-out zones; reward ``w·φ_t``
    (landing error, impact, fuel, tilt, habitat zone, array zone)."""

    def observe(self, physics: LanderPhysics) -> OrderedDict[str, np.ndarray]:
        return OrderedDict(
            position=physics.data.qpos.copy(),
            velocity=physics.data.qvel.copy(),
            to_pad=physics.to_pad(),
            to_zones=physics.to_zones(),
            touching=physics.feet_touching(),
        )


PHYSICS, TASK = LanderPhysics, LanderTask
