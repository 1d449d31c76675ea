"""The lava reacher's kinesthetic expert.

Candidate fingertip paths run from the start fingertip toward the goal along a quadratic Bézier
curve bulging sideways by ``offset`` (m, signed: detours on either side of the lava, or straight
through it), reaching a share ``reach`` ∈ [0, 1] of the way to the goal in ``duration`` s with
minimum-jerk timing, then holding. mink IK (a position task on the fingertip site, posture
regularization toward the start, configuration and velocity limits) turns each path into a joint
reference; the demonstrator guides the arm through via-postures at the control knots
(kinesthetic teaching), chosen so that the joint-space spline through them is closest to the
whole reference (least squares), and the stiff position servos execute that spline: the demo is
a trajectory the robot's own controls can express, so the planner is not handicapped against it.
The coarse grid is 9 offsets × 4 durations × 3 reach shares plus holding still; refinement rounds
perturb the best path.
"""

from __future__ import annotations

import numpy as np

from mjsuff.experts.expert import ExecutedPaths, Expert, ExpertSettings
from mjsuff.experts.ik import IKFailure, IKSettings, PathTracker
from mjsuff.experts.paths import minimum_jerk, quadratic_bezier
from mjsuff.scenes.lava_reacher import LavaReacher, fingertip_xy

OFFSETS = np.linspace(-0.24, 0.24, 9)
DURATIONS = np.array([0.5, 0.8, 1.1, 1.4])
REACH = np.array([0.5, 0.8, 1.0])
#: Spread of one refinement step at scale 1: offset (m), duration (s), reach share.
STEP = np.array([0.06, 0.3, 0.25])


class ReacherExpert(Expert):
    """Demonstrates on a :class:`LavaReacher`; path parameters are ``(offset, duration, reach)``."""

    def __init__(
        self, scene: LavaReacher, settings: ExpertSettings | None = None, ik: IKSettings | None = None
    ) -> None:
        super().__init__(scene, settings)
        self.scene: LavaReacher = scene
        self.tracker = PathTracker(scene.model, "fingertip", "site", settings=ik)
        self.horizon = scene.spline.num_steps * scene.model.opt.timestep

    def coarse_params(self, start_qpos: np.ndarray) -> np.ndarray:
        grid = np.stack(np.meshgrid(OFFSETS, DURATIONS, REACH, indexing="ij"), -1).reshape(-1, 3)
        return np.vstack([grid, [0.0, 1.0, 0.0]])  # the last: hold still

    def primitives(self, start_qpos: np.ndarray) -> np.ndarray:
        """Every offset and duration of the coarse grid, all the way to the goal, and holding
        still: the ways around (and through) the lava at each pace."""
        grid = np.stack(np.meshgrid(OFFSETS, DURATIONS, [1.0], indexing="ij"), -1).reshape(-1, 3)
        return np.vstack([grid, [0.0, 1.0, 0.0]])

    def random_params(self, start_qpos: np.ndarray, rng: np.random.Generator, count: int) -> np.ndarray:
        """Any offset of the grid's range, any duration from 0.5 s to the horizon, to the goal."""
        return np.column_stack(
            [
                rng.uniform(OFFSETS[0], OFFSETS[-1], count),
                rng.uniform(DURATIONS[0], self.horizon, count),
                np.ones(count),
            ]
        )

    def perturb(self, params: np.ndarray, rng: np.random.Generator, count: int, scale: float) -> np.ndarray:
        out = params + rng.standard_normal((count, 3)) * STEP * scale
        out[:, 1] = np.clip(out[:, 1], 0.3, self.horizon)
        out[:, 2] = np.clip(out[:, 2], 0.0, 1.0)
        return out

    def intended_path(self, start_qpos: np.ndarray, params: np.ndarray) -> np.ndarray:
        """Fingertip positions ``(T + 1, 3)`` at times 0, dt, …, T·dt (m) for one candidate."""
        offset, duration, reach = params
        steps, dt = self.scene.spline.num_steps, self.scene.model.opt.timestep
        tip = fingertip_xy(np.asarray(start_qpos))
        end = tip + reach * (self.scene.goal - tip)
        chord = end - tip
        length = np.linalg.norm(chord)
        normal = np.array([-chord[1], chord[0]]) / length if length > 1e-9 else np.zeros(2)
        # The Bézier curve's largest sideways deviation is half its middle point's.
        middle = (tip + end) / 2 + 2 * offset * normal
        s = minimum_jerk(np.arange(steps + 1) * dt / duration)
        xy = quadratic_bezier(tip, middle, end, s)
        return np.column_stack([xy, np.zeros(len(xy))])

    def task_path(self, qpos: np.ndarray) -> np.ndarray:
        """The fingertip's path in the plane ``(B, T, 2)`` (m)."""
        return fingertip_xy(qpos)

    def execute(self, start_qpos: np.ndarray, params: np.ndarray) -> tuple[ExecutedPaths, list[str]]:
        dt = self.scene.model.opt.timestep
        spline = self.scene.spline
        # The knots whose joint-space spline (anchored at the start) is closest to the whole
        # reference, in least squares: the arm then follows the path between the knots too.
        basis = spline.basis
        fit = np.linalg.pinv(basis[:, 1:])
        kept, paths, knots, failures = [], [], [], []
        for p in params:
            path = self.intended_path(start_qpos, p)
            try:
                reference = self.tracker.track(start_qpos, path, dt)
            except IKFailure as err:
                failures.append(f"path {np.round(p, 3).tolist()}: {err}")
                continue
            kept.append(p)
            paths.append(path[1:])
            q = reference.qpos[1:]  # the posture to be in after each step
            knots.append(fit @ (q - basis[:, :1] * np.asarray(start_qpos)[None]))
        if not kept:
            return ExecutedPaths.empty(), failures
        fitted = spline.clip(np.array(knots))
        rollouts, features = self.scene.simulate(np.asarray(start_qpos), fitted)
        intended = np.array(paths)[:, :, :2]
        executed = self.task_path(rollouts.qpos)  # after each step, aligned with the intended path
        error = np.linalg.norm(executed - intended, axis=2).max(axis=1)
        return ExecutedPaths(np.array(kept), intended, executed, rollouts, features, error, fitted), failures
