"""Lava reacher (analog of the paper's Lavaworld): a planar 3-link arm brings its fingertip to a
goal from either side, past a hazard that lies across the way on that side, moving smoothly.

Features (k = 4), from the simulated fingertip (``framepos`` sensor) and joint velocities, each a
mean over the horizon's steps (so a step's share is its value divided by the steps):

* ``distance`` — fingertip-to-goal distance divided by ``DISTANCE_SCALE`` (0.2 m); about 2 at the
  start, 0 once at the goal: how soon the arm gets there.
* ``lava`` — penetration depth into the lava disk, ``max(0, r − ‖tip − c‖) / r``, divided by
  ``HAZARD_SCALE`` (0.03); 0 outside the disk: a smooth exposure, not a 0/1 hit. A straight pass
  through the disk's middle at a brisk pace scores about 3–10, several times a slow reach, so a
  reward that weighs the hazard at all goes around it, and one that ignores it goes through: what
  the learner believes of a hazard it has not seen demonstrated decides the motion (issue #17:
  at 0.1, crossing cost about as much as a slow reach and the first demo was nearly enough).
* ``water`` — the same depth for the water disk.
* ``motion`` — squared joint speed ``Σ q̇²`` divided by ``MOTION_SCALE`` (10 (rad/s)²); about 1
  for a brisk reach, 0 when still.

The scales make the features comparable where policies differ, so that reward weights drawn
uniformly from the all-negative orthant trade them off: cross the hazard (short and quick) or go
around it (longer: more distance and motion), and how fast.

Instances randomize the goal (in reach, in front of the arm), two start regions on either side of
it (about 1.5–2 rad away, fingertips 17–33 cm from the base) and the two hazard disks (radius
8–11 cm): the lava where a plain joint-space move from the right region's centre to the goal would
carry the fingertip halfway, the water likewise for the left region. From a start on the right the
lava is in the way and the water out of reach of any sensible motion; from the left, the reverse.
So a demonstration from one side says how the demonstrator trades reaching and effort against that
side's hazard, and nothing about the other's: the learner needs demos from both sides. Postures
come from the analytic inverse kinematics with a random tool angle and elbow, so from some starts
the way inside the hazard is short and from others the way outside. The evaluation starts
alternate sides; the demonstration pool's sides are a balanced random order; both are drawn apart
from the same distribution. True weights are drawn uniformly from the all-negative part of the
sphere: every feature is a cost.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydantic import Field, model_validator

from mjsuff.scenes.params import SceneParams
from mjsuff.scenes.planner_config import PlannerConfig
from mjsuff.scenes.scene import Scene, load_model
from mjsuff.scenes.simulate import Rollouts
from mjsuff.scenes.spline import ControlSpline

LINK = 0.12
REACH = 3 * LINK
#: Joint ranges (rad), as in the MJCF file.
JOINT_LIMITS = np.array([3.1, 2.6, 2.6])
FEATURE_NAMES = ("distance", "lava", "water", "motion")
#: Hazard disks, in feature order after ``distance``: the lava on the right, the water on the left.
HAZARDS = ("lava", "water")
DISTANCE_SCALE = 0.2
HAZARD_SCALE = 0.03
MOTION_SCALE = 10.0
#: Starts keep this far from every joint limit (rad): near a limit mink's IK cannot follow most paths.
START_LIMIT_MARGIN = 0.5
#: Range of a hazard disk's radius (m).
HAZARD_RADII = (0.08, 0.11)
#: Joint-space primitives (``LavaReacher.primitive_knots``): goal postures' tool angles and the
#: shares of the move; the paces are the move done by knot ``j`` of ``K``: all at the first knot,
#: by the middle (``min(1, 2j/K)``), evenly (``j/K``).
PRIMITIVE_TOOL_ANGLES = 12
PRIMITIVE_REACH = (0.25, 0.5, 0.75, 1.0)


class LavaReacherParams(SceneParams):
    """Instance parameters of the lava reacher."""

    feature_names = FEATURE_NAMES

    horizon: float = Field(1.5, gt=0.2, le=10.0, description="trajectory length (s)")
    knots: int = Field(3, ge=2, le=20, description="control knots per joint")

    @model_validator(mode="after")
    def _scene_defaults(self) -> LavaReacherParams:
        # Unset budgets become the scene's tested ones, so a resolved scenario says what ran.
        self.planning = self.planning.resolved(
            LavaReacher.planner_config, LavaReacher.refine_config, LavaReacher.seed_config
        )
        return self


def fingertip_xy(qpos: np.ndarray) -> np.ndarray:
    """Planar forward kinematics: fingertip (x, y) for joint angles ``(..., 3)`` (metres)."""
    angles = np.cumsum(qpos, axis=-1)
    return LINK * np.stack([np.cos(angles).sum(-1), np.sin(angles).sum(-1)], axis=-1)


def inverse_kinematics(
    tip: np.ndarray, tool_angle: np.ndarray | float, elbow: np.ndarray | float
) -> np.ndarray:
    """Joint angles ``(..., 3)`` that put the fingertip at ``tip`` ``(..., 2)`` with the last link
    at ``tool_angle`` (rad, world frame) and the elbow on side ``elbow`` (±1); NaN where out of
    reach or out of the joint ranges."""
    tip, tool_angle, elbow = np.broadcast_arrays(
        np.asarray(tip, float), np.asarray(tool_angle, float)[..., None], np.asarray(elbow, float)[..., None]
    )
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


def _posture(tip: np.ndarray, tool_angle: float) -> np.ndarray:
    """A posture with the fingertip at ``tip`` and the tool at ``tool_angle``: elbow +1 if it is
    in range, else −1."""
    for elbow in (1.0, -1.0):
        q = inverse_kinematics(tip, tool_angle, elbow)
        if np.isfinite(q).all():
            return q
    raise RuntimeError(f"lava reacher: no posture reaches {np.round(tip, 3).tolist()}")


class LavaReacher(Scene):
    """One lava-reacher instance drawn from ``rng``."""

    feature_names = FEATURE_NAMES
    #: The MJCF model: a shipped model's name, or a path (a scene built on this one elsewhere).
    model_file: str | Path = "lava_reacher.xml"
    path_axes = (0, 1)  # the fingertip moves in the world x-y plane
    # π and V* refinement: CMA-ES from the library's best trajectory for the reward (the
    # demonstrator's path family, the seed plans, every plan since), a local search. The seed
    # plans need the global search: from a left start the way around the water is a narrow basin
    # that a local search from holding still or from a way through never reaches, so they are a wide
    # CEM (benchmarks/tail_vstar.py).
    planner_config = PlannerConfig(iterations=0, cma_population=24, cma_iterations=40, cma_sigma=0.05)
    refine_config = PlannerConfig(iterations=0, cma_population=24, cma_iterations=24, cma_sigma=0.05)
    seed_config = PlannerConfig(population=48, elites=6, iterations=10, initial_std=0.5)

    def __init__(
        self, params: LavaReacherParams, rng: np.random.Generator, threads: int | None = None
    ) -> None:
        self.params = params
        self.model = load_model(self.model_file)
        # The goal in front of the arm; a start region on each side, 1.5–2 rad away.
        goal_angle = self.goal_angle = rng.uniform(-0.25, 0.25)
        self.goal = rng.uniform(0.2, 0.3) * np.array([np.cos(goal_angle), np.sin(goal_angle)])
        q_goal = _posture(self.goal, goal_angle)
        #: Centre direction (rad) of the right (lava) and left (water) start regions.
        self.region_angles = goal_angle + np.array([-1.0, 1.0]) * rng.uniform(1.5, 2.0, 2)
        # A side's hazard sits where a plain joint-space move from the region's centre posture to
        # the goal posture would carry the fingertip halfway: in the way of the easy motion.
        self.hazard_centres = np.empty((2, 2))
        self.hazard_radii = rng.uniform(*HAZARD_RADII, 2)
        for side, angle in enumerate(self.region_angles):
            q_from = _posture(0.25 * np.array([np.cos(angle), np.sin(angle)]), angle)
            centre = fingertip_xy((q_from + q_goal) / 2) + rng.uniform(-0.02, 0.02, 2)
            away = centre - self.goal  # the goal stays outside the hazard with room to stop
            gap = np.linalg.norm(away) - self.hazard_radii[side]
            if gap < 0.03:
                centre += (0.03 - gap) * away / np.linalg.norm(away)
            self.hazard_centres[side] = centre
            self.model.geom(HAZARDS[side]).pos[:2] = centre
            self.model.geom(HAZARDS[side]).size[0] = self.hazard_radii[side]
        self.model.site("goal").pos[:2] = self.goal
        steps = round(params.horizon / self.model.opt.timestep)
        ctrl = self.model.actuator_ctrlrange
        self.spline = ControlSpline(params.knots, steps, ctrl[:, 0], ctrl[:, 1], anchored=True)
        #: Side of each evaluation start (0 right, 1 left): alternating.
        self.start_sides = np.arange(params.eval_starts) % 2
        #: Side of each pool start: a balanced random order.
        self.pool_sides = rng.permutation(np.arange(params.pool_starts) % 2)
        self.starts = self.sample_starts(rng, params.eval_starts, self.start_sides)
        self.pool_starts = self.sample_starts(rng, params.pool_starts, self.pool_sides)
        super().__init__(threads)

    @property
    def lava_centre(self) -> np.ndarray:
        """Lava disk centre (x, y) (m)."""
        return self.hazard_centres[0]

    @property
    def lava_radius(self) -> float:
        """Lava disk radius (m)."""
        return float(self.hazard_radii[0])

    @property
    def water_centre(self) -> np.ndarray:
        """Water disk centre (x, y) (m)."""
        return self.hazard_centres[1]

    @property
    def water_radius(self) -> float:
        """Water disk radius (m)."""
        return float(self.hazard_radii[1])

    def sample_starts(
        self, rng: np.random.Generator, count: int, sides: np.ndarray | None = None
    ) -> np.ndarray:
        """``count`` starts, on ``sides`` (0 right, 1 left; unset: each side at random): a
        fingertip in its side's region
        (radius 0.17–0.33 m, within ±0.5 rad of its centre direction), the posture by inverse
        kinematics with a random tool angle and elbow, at least ``START_LIMIT_MARGIN`` inside the
        joint ranges (so that the demonstrator's IK can move from it) and 2 cm outside both
        hazards."""
        sides = rng.integers(0, 2, count) if sides is None else np.asarray(sides)
        out = np.empty((count, 3))
        for side in (0, 1):
            rows = np.flatnonzero(np.asarray(sides) == side)
            filled = 0
            while filled < len(rows):
                n = 8 * len(rows)
                angle = self.region_angles[side] + rng.uniform(-0.5, 0.5, n)
                tip = rng.uniform(0.17, 0.33, n)[:, None] * np.stack([np.cos(angle), np.sin(angle)], 1)
                tool = angle + rng.uniform(-1.2, 1.2, n)
                q = inverse_kinematics(tip, tool, rng.choice([-1.0, 1.0], n))
                ok = (np.abs(q) <= JOINT_LIMITS - START_LIMIT_MARGIN).all(axis=1)  # NaN: False
                for centre, radius in zip(self.hazard_centres, self.hazard_radii, strict=True):
                    ok &= np.linalg.norm(tip - centre, axis=1) > radius + 0.02
                take = q[ok][: len(rows) - filled]
                out[rows[filled : filled + len(take)]] = take
                filled += len(take)
        return out

    def initial_knots(self, start_qpos: np.ndarray) -> np.ndarray:
        """Search starts from holding the start pose."""
        return np.repeat(start_qpos[:, None, :], self.spline.num_knots, axis=1)

    def primitive_knots(self, start_qpos: np.ndarray) -> np.ndarray:
        """Straight joint-space moves from ``start_qpos`` toward every goal posture: the
        analytic IK's postures at the goal for ``PRIMITIVE_TOOL_ANGLES`` tool angles and both
        elbows, a share ``PRIMITIVE_REACH`` of the way, at three paces (module constants).
        Cheap and reward-agnostic, they hold motions that a local search from holding still or
        from the demonstrator's Cartesian paths rarely finds (unfolding or refolding the arm,
        stopping part-way when motion is dear)."""
        tools = self.goal_angle + np.linspace(-np.pi, np.pi, PRIMITIVE_TOOL_ANGLES, endpoint=False)
        postures = inverse_kinematics(self.goal, tools[:, None], np.array([1.0, -1.0]))
        postures = postures.reshape(-1, 3)
        postures = postures[np.isfinite(postures).all(axis=1)]
        move = postures - start_qpos  # (G, 3)
        j = np.arange(1, self.spline.num_knots + 1) / self.spline.num_knots
        paces = np.stack([np.ones_like(j), np.minimum(1.0, 2 * j), j])  # (3, K)
        share = np.asarray(PRIMITIVE_REACH)[:, None, None] * paces[None]  # (R, 3, K)
        knots = start_qpos + share[None, :, :, :, None] * move[:, None, None, None, :]
        return self.spline.clip(knots.reshape(-1, self.spline.num_knots, 3))

    def anchor(self, start_qpos: np.ndarray) -> np.ndarray:
        """The servos start targeting the start pose: motion begins smoothly."""
        return start_qpos

    def path(self, rollouts: Rollouts) -> np.ndarray:
        return rollouts.sensordata[:, :, :2]

    def step_features(self, rollouts: Rollouts, horizon: int | None = None) -> np.ndarray:
        """Each step's distance, lava and water depth and squared joint speed (module docs),
        divided by the horizon's steps: their sum over a whole trajectory is the features' mean."""
        tip = self.path(rollouts)
        steps = horizon or tip.shape[1]
        distance = np.linalg.norm(tip - self.goal, axis=2) / DISTANCE_SCALE
        hazards = [
            np.clip(r - np.linalg.norm(tip - c, axis=2), 0.0, None) / r / HAZARD_SCALE
            for c, r in zip(self.hazard_centres, self.hazard_radii, strict=True)
        ]
        motion = (rollouts.qvel**2).sum(axis=2) / MOTION_SCALE
        return np.stack([distance, *hazards, motion], axis=2) / steps

    def baseline_knots(self) -> np.ndarray:
        """Hold the start posture (targets = start angles): the do-nothing baseline."""
        return np.repeat(self.starts[:, None, :], self.spline.num_knots, axis=1)
