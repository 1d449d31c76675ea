"""A MuJoCo scene from outside mjsuff: the lava reacher with a payload and an effort feature.

The README's "Add a domain" example of a scene (run by ``tests/test_external_domain.py``). It has
its own model (``effort_reacher.xml``: the reacher's arm with a 0.3 kg payload at the fingertip and
a torque sensor on each joint servo) and one more feature than the lava reacher, from that sensor:

* ``effort`` — squared servo torque ``Σ τ²`` divided by ``EFFORT_SCALE`` ((N·m)²), a mean over the
  horizon's steps like the reacher's own features; about 1 for a brisk reach, 0 when still.

The rest (instances, starts, the other four features, planning) is the lava reacher's, and so is
the expert: mink follows the demonstrator's task-space paths on this model as on the shipped one.
A scenario names it by import path: ``[domain] name = "effort_reacher:SPEC"``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mjsuff.domains import scene_domain
from mjsuff.experts.reacher import ReacherExpert
from mjsuff.scenes.lava_reacher import FEATURE_NAMES, LavaReacher, LavaReacherParams
from mjsuff.scenes.simulate import Rollouts

#: Squared servo torque ((N·m)²) of a brisk reach with the payload.
EFFORT_SCALE = 0.4


class EffortReacher(LavaReacher):
    """One effort-reacher instance: a lava-reacher instance on ``effort_reacher.xml``."""

    model_file = Path(__file__).with_name("effort_reacher.xml")
    feature_names = (*FEATURE_NAMES, "effort")

    def step_features(self, rollouts: Rollouts, horizon: int | None = None) -> np.ndarray:
        """The lava reacher's features of each step, then its effort (module docs)."""
        steps = horizon or rollouts.sensordata.shape[1]
        torque = rollouts.sensordata[:, :, 3:6]  # after the fingertip's position (x, y, z)
        effort = (torque**2).sum(axis=2) / EFFORT_SCALE / steps
        return np.concatenate([super().step_features(rollouts, horizon), effort[:, :, None]], axis=2)


SPEC = scene_domain("effort_reacher:SPEC", EffortReacher, LavaReacherParams, lambda: ReacherExpert)
