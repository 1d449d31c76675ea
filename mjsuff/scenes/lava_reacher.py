"""Lava reacher (analog of the paper's Lavaworld): a planar 3-link arm brings its fingertip to a
goal past a lava disk that lies across the way, moving smoothly.

Features (k = 3), from the simulated fingertip (``framepos`` sensor) and joint velocities, each a
mean over the horizon's steps (so a step's share is its value divided by the steps):

* ``distance`` — fingertip-to-goal distance divided by ``DISTANCE_SCALE`` (0.2 m); about 1 at the
  start, 0 once at the goal: how soon the arm gets there.
* ``lava`` — penetration depth into the lava disk, ``max(0, r − ‖tip − c‖) / r``, divided by
  ``LAVA_SCALE`` (0.3); 0 outside the disk: a smooth exposure, not a 0/1 hit. A straight pass
  through the disk's middle at a brisk pace scores about 1.
* ``motion`` — squared joint speed ``Σ q̇²`` divided by ``MOTION_SCALE`` (10 (rad/s)²); about 1
  for a brisk reach, 0 when still.

The scales make the three comparable where policies differ, so that reward weights drawn
uniformly from the all-negative orthant trade them off: cross the lava (short and quick) or go
around it on either side (longer: more distance and motion), and how fast.

Instances randomize the goal (in reach, on the arm's left), the lava disk (radius 8–11 cm,
centred where a plain joint-space move from the start region's centre to the goal would carry the
fingertip halfway: in the way of the easy motion, so going around means folding the arm in or
stretching it out) and the starts: fingertips in a start region on the arm's right (17–33 cm
from the base), postures from the analytic inverse kinematics with a random tool angle and
elbow, so from some starts the way inside the lava is short and from others the way outside.
The evaluation starts and the demonstration pool are drawn apart from the same distribution.
True weights are drawn uniformly from the all-negative part of the sphere: every feature is a
cost.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from mjsuff.scenes.planner_config import PlannerConfig
from mjsuff.scenes.planning import PlanningSettings
from mjsuff.scenes.scene import Scene, load_model
from mjsuff.scenes.simulate import Rollouts
from mjsuff.scenes.spline import ControlSpline

LINK = 0.12
REACH = 3 * LINK
#: Joint ranges (rad), as in the MJCF file.
JOINT_LIMITS = np.array([3.1, 2.6, 2.6])
FEATURE_NAMES = ("distance", "lava", "motion")
DISTANCE_SCALE = 0.2
LAVA_SCALE = 0.3
MOTION_SCALE = 10.0
#: Range of the lava disk's radius (m).
LAVA_RADII = (0.08, 0.11)


class LavaReacherParams(BaseModel):
    """Instance parameters of the lava reacher."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)

    eval_starts: int = Field(6, ge=1, le=256, description="fixed evaluation starts (never demonstrated)")
    pool_starts: int = Field(10, ge=1, le=256, description="starts a demonstration can be asked from")
    horizon: float = Field(1.5, gt=0.2, le=10.0, description="trajectory length (s)")
    knots: int = Field(3, ge=2, le=20, description="control knots per joint")
    planning: PlanningSettings = Field(PlanningSettings(), description="planning budgets")

    @model_validator(mode="after")
    def _scene_defaults(self) -> LavaReacherParams:
        # Unset budgets become the scene's tested ones, so a resolved scenario says what ran.
        self.planning = self.planning.resolved(LavaReacher.planner_config, LavaReacher.refine_config,
                                               LavaReacher.seed_config)
        return self


def fingertip_xy(qpos: np.ndarray) -> np.ndarray:
    """Planar forward kinematics: fingertip (x, y) for joint angles ``(..., 3)`` (metres)."""
    angles = np.cumsum(qpos, axis=-1)
    return LINK * np.stack([np.cos(angles).sum(-1), np.sin(angles).sum(-1)], axis=-1)


def inverse_kinematics(tip: np.ndarray, tool_angle: np.ndarray, elbow: np.ndarray) -> np.ndarray:
    """Joint angles ``(..., 3)`` that put the fingertip at ``tip`` ``(..., 2)`` with the last link
    at ``tool_angle`` (rad, world frame) and the elbow on side ``elbow`` (±1); NaN where out of
    reach or out of the joint ranges."""
    tip, tool_angle, elbow = np.broadcast_arrays(np.asarray(tip, float),
                                                 np.asarray(tool_angle, float)[..., None],
                                                 np.asarray(elbow, float)[..., None])
    tool_angle, elbow = tool_angle[..., 0], elbow[..., 0]
    wrist = tip - LINK * np.stack([np.cos(tool_angle), np.sin(tool_angle)], axis=-1)
    c2 = ((wrist**2).sum(-1) - 2 * LINK**2) / (2 * LINK**2)
    q2 = elbow * np.arccos(np.clip(c2, -1.0, 1.0))
    q1 = np.arctan2(wrist[..., 1], wrist[..., 0]) - np.arctan2(np.sin(q2), 1.0 + np.cos(q2))
    q3 = tool_angle - q1 - q2
    q = np.stack([q1, q2, q3], axis=-1)
    q = np.angle(np.exp(1j * q))  # wrapped to [−π, π]
    ok = (np.abs(c2) <= 1.0) & (np.abs(q) <= JOINT_LIMITS).all(axis=-1)
    return np.where(ok[..., None], q, np.nan)


class LavaReacher(Scene):
    """One lava-reacher instance drawn from ``rng``."""

    feature_names = FEATURE_NAMES
    path_axes = (0, 1)  # the fingertip moves in the world x-y plane
    # CMA-ES from the library's best trajectory for the reward: the library (the demonstrator's
    # path family through mink IK from every start, the seed plans, every plan since) already
    # holds each way around the lava, so the search is local (tests/test_planner.py).
    planner_config = PlannerConfig(iterations=0, cma_population=24, cma_iterations=40,
                                   cma_sigma=0.05)
    refine_config = PlannerConfig(iterations=0, cma_population=16, cma_iterations=12,
                                  cma_sigma=0.05)
    seed_config = PlannerConfig(iterations=0, cma_population=16, cma_iterations=16, cma_sigma=0.05)

    def __init__(self, params: LavaReacherParams, rng: np.random.Generator,
                 threads: int | None = None) -> None:
        self.params = params
        self.model = load_model("lava_reacher.xml")
        # Goal on the arm's left; the start region on its right, about 1.5–2.3 rad away.
        goal_angle = rng.uniform(1.0, 1.8)
        self.goal = rng.uniform(0.2, 0.3) * np.array([np.cos(goal_angle), np.sin(goal_angle)])
        self.start_angle = goal_angle - rng.uniform(1.5, 2.3)
        # The lava sits where a plain joint-space move from the start region's centre posture to
        # the goal posture would carry the fingertip halfway: in the way of the easy motion.
        region = 0.25 * np.array([np.cos(self.start_angle), np.sin(self.start_angle)])
        q_from = inverse_kinematics(region, self.start_angle, 1.0)
        q_to = inverse_kinematics(self.goal, goal_angle, 1.0)
        if not (np.isfinite(q_from).all() and np.isfinite(q_to).all()):
            raise RuntimeError("lava reacher: the region centre or goal is out of reach")
        halfway = fingertip_xy((q_from + q_to) / 2)
        self.lava_radius = float(rng.uniform(*LAVA_RADII))
        self.lava_centre = halfway + rng.uniform(-0.02, 0.02, 2)
        # The goal stays outside the lava with room to stop.
        away = self.lava_centre - self.goal
        gap = np.linalg.norm(away) - self.lava_radius
        if gap < 0.03:
            self.lava_centre += (0.03 - gap) * away / np.linalg.norm(away)
        self.model.site("goal").pos[:2] = self.goal
        self.model.geom("lava").pos[:2] = self.lava_centre
        self.model.geom("lava").size[0] = self.lava_radius
        steps = round(params.horizon / self.model.opt.timestep)
        ctrl = self.model.actuator_ctrlrange
        self.spline = ControlSpline(params.knots, steps, ctrl[:, 0], ctrl[:, 1], anchored=True)
        self.starts = self.sample_starts(rng, params.eval_starts)
        self.pool_starts = self.sample_starts(rng, params.pool_starts)
        super().__init__(threads)

    def sample_starts(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """Fingertips in the start region (radius 0.17–0.33 m, within ±0.5 rad of its centre
        direction), postures by inverse kinematics with a random tool angle and elbow, at least
        2 cm outside the lava."""
        out = np.empty((count, 3))
        filled = 0
        while filled < count:
            n = 8 * count
            angle = self.start_angle + rng.uniform(-0.5, 0.5, n)
            tip = rng.uniform(0.17, 0.33, n)[:, None] * np.stack([np.cos(angle), np.sin(angle)], 1)
            tool = angle + rng.uniform(-1.2, 1.2, n)
            q = inverse_kinematics(tip, tool, rng.choice([-1.0, 1.0], n))
            ok = np.isfinite(q).all(axis=1)
            ok &= np.linalg.norm(tip - self.lava_centre, axis=1) > self.lava_radius + 0.02
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
        distance = np.linalg.norm(tip - self.goal, axis=2) / DISTANCE_SCALE
        depth = self.lava_radius - np.linalg.norm(tip - self.lava_centre, axis=2)
        lava = np.clip(depth, 0.0, None) / self.lava_radius / LAVA_SCALE
        motion = (rollouts.qvel**2).sum(axis=2) / MOTION_SCALE
        return np.stack([distance, lava, motion], axis=2) / steps

    def baseline_knots(self) -> np.ndarray:
        """Hold the start posture (targets = start angles): the do-nothing baseline."""
        return np.repeat(self.starts[:, None, :], self.spline.num_knots, axis=1)
