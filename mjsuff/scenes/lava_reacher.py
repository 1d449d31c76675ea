"""Lava reacher (analog of the paper's Lavaworld): a planar 3-link arm brings its fingertip to a
goal while avoiding a lava disk, moving smoothly.

Features (k = 3), from the simulated fingertip (``framepos`` sensor) and joint velocities, each a
mean over the horizon's steps:

* ``distance`` — fingertip-to-goal distance divided by the arm's reach (0.36 m); range [0, 2].
* ``lava`` — penetration depth into the lava disk, ``max(0, r − ‖tip − c‖) / r``; range [0, 1]
  (0 outside the disk, 1 at its centre): a smooth exposure, not a 0/1 hit.
* ``motion`` — squared joint speed ``Σ q̇²`` divided by 100 (rad/s)²; range [0, ∞): about 0.9
  for uniformly random controls, below 0.1 for a smooth reach, 0 when still.

Instances randomize the goal (in reach, in front of the arm), the lava disk (radius 4–7 cm,
centred near the straight path from the usual start region to the goal, never over the goal) and
the start configurations (the home posture plus noise, fingertip outside the lava). True weights
are drawn uniformly from the all-negative part of the sphere: every feature is a cost.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from mjsuff.scenes.planner_config import PlannerConfig
from mjsuff.scenes.planning import PlanningSettings
from mjsuff.scenes.scene import Scene, load_model
from mjsuff.scenes.simulate import Rollouts
from mjsuff.scenes.spline import ControlSpline

REACH = 0.36
LINK = 0.12
HOME = np.array([-1.2, 1.3, 0.9])
FEATURE_NAMES = ("distance", "lava", "motion")


class LavaReacherParams(BaseModel):
    """Instance parameters of the lava reacher."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)

    eval_starts: int = Field(16, ge=1, le=256, description="fixed evaluation starts")
    horizon: float = Field(1.5, gt=0.2, le=10.0, description="trajectory length (s)")
    knots: int = Field(5, ge=2, le=20, description="control knots per joint")
    start_noise: float = Field(0.35, ge=0.0, le=1.5, description="start joint noise (rad)")
    planning: PlanningSettings = Field(PlanningSettings(), description="planning budgets")

    @model_validator(mode="after")
    def _scene_defaults(self) -> LavaReacherParams:
        # Unset budgets become the scene's tested ones, so a resolved scenario says what ran.
        self.planning = self.planning.resolved(LavaReacher.planner_config, LavaReacher.refine_config)
        return self


def fingertip_xy(qpos: np.ndarray) -> np.ndarray:
    """Planar forward kinematics: fingertip (x, y) for joint angles ``(..., 3)`` (metres)."""
    angles = np.cumsum(qpos, axis=-1)
    return LINK * np.stack([np.cos(angles).sum(-1), np.sin(angles).sum(-1)], axis=-1)


class LavaReacher(Scene):
    """One lava-reacher instance drawn from ``rng``."""

    feature_names = FEATURE_NAMES
    path_axes = (0, 1)  # the fingertip moves in the world x-y plane
    # CEM picks the side of the lava, CMA-ES polishes the path (2112 rollouts per problem;
    # 5x closer to a 10x-budget reference than 2048 rollouts of CEM alone, tests/test_planner.py).
    planner_config = PlannerConfig(population=64, elites=6, iterations=12,
                                   cma_population=24, cma_iterations=56, cma_sigma=0.1)

    def __init__(self, params: LavaReacherParams, rng: np.random.Generator,
                 threads: int | None = None) -> None:
        self.params = params
        self.model = load_model("lava_reacher.xml")
        home_tip = fingertip_xy(HOME)
        # Goal: in reach, in front of the arm, away from the start region.
        for _ in range(1000):
            radius, angle = rng.uniform(0.17, 0.32), rng.uniform(-0.9, 1.3)
            goal = radius * np.array([np.cos(angle), np.sin(angle)])
            if np.linalg.norm(goal - home_tip) > 0.15:
                break
        lava_radius = rng.uniform(0.04, 0.07)
        along = rng.uniform(0.4, 0.6)
        normal = np.array([-(goal - home_tip)[1], (goal - home_tip)[0]])
        normal /= np.linalg.norm(normal)
        lava = home_tip + along * (goal - home_tip) + rng.uniform(-0.02, 0.02) * normal
        self.goal, self.lava_centre, self.lava_radius = goal, lava, lava_radius
        self.model.site("goal").pos[:2] = goal
        self.model.geom("lava").pos[:2] = lava
        self.model.geom("lava").size[0] = lava_radius
        steps = round(params.horizon / self.model.opt.timestep)
        ctrl = self.model.actuator_ctrlrange
        self.spline = ControlSpline(params.knots, steps, ctrl[:, 0], ctrl[:, 1], anchored=True)
        self.starts = self.sample_starts(rng, params.eval_starts)
        super().__init__(threads)

    def sample_starts(self, rng: np.random.Generator, count: int) -> np.ndarray:
        out = np.empty((count, 3))
        filled = 0
        while filled < count:
            q = HOME + rng.uniform(-1, 1, size=(4 * count, 3)) * self.params.start_noise
            ok = np.linalg.norm(fingertip_xy(q) - self.lava_centre, axis=1) > self.lava_radius + 0.02
            take = q[ok][: count - filled]
            out[filled : filled + len(take)] = take
            filled += len(take)
        return out

    def initial_knots(self, start_qpos: np.ndarray) -> np.ndarray:
        """Search starts from holding the start pose."""
        return np.repeat(start_qpos[:, None, :], self.spline.num_knots, axis=1)

    def anchor(self, start_qpos: np.ndarray) -> np.ndarray:
        """The servos start targeting the start pose: motion begins smoothly."""
        return start_qpos

    def path(self, rollouts: Rollouts) -> np.ndarray:
        return rollouts.sensordata[:, :, :2]

    def step_features(self, rollouts: Rollouts, horizon: int | None = None) -> np.ndarray:
        """Each step's distance, lava depth and squared joint speed (module docs), divided by the
        horizon's steps: their sum over a whole trajectory is the features' mean."""
        tip = self.path(rollouts)
        steps = horizon or tip.shape[1]
        distance = np.linalg.norm(tip - self.goal, axis=2) / REACH
        depth = self.lava_radius - np.linalg.norm(tip - self.lava_centre, axis=2)
        lava = np.clip(depth, 0.0, None) / self.lava_radius
        motion = (rollouts.qvel**2).sum(axis=2) / 100.0
        return np.stack([distance, lava, motion], axis=2) / steps

    def baseline_knots(self) -> np.ndarray:
        """Hold the start posture (targets = start angles): the do-nothing baseline."""
        return np.repeat(self.starts[:, None, :], self.spline.num_knots, axis=1)
