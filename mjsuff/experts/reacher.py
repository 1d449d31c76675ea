"""The lava reacher's kinesthetic expert.

Candidate fingertip paths run from the start fingertip toward the goal along a quadratic Bézier
curve bulging sideways by ``offset`` (m, signed: detours on either side of the lava), reaching a
share ``reach`` ∈ [0, 1] of the way to the goal in ``duration`` s with minimum-jerk timing, then
holding. mink IK (a position task on the fingertip site, posture regularization toward the start,
configuration and velocity limits) turns each path into a joint reference, and the position servos
execute it with inverse-dynamics feedforward: ``ctrl = q_ref + (τ_ref + k_v q̇_ref) / k_p``, where
``τ_ref`` comes from ``mj_inverse`` on the reference, so the fingertip follows the intended path
closely (the servos' forces stay well inside their range on these paths). The coarse grid is
7 offsets × 4 durations × 3 reach shares plus holding still; refinement rounds perturb the best path.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjsuff.experts.expert import ExecutedPaths, Expert, ExpertSettings
from mjsuff.experts.ik import IKFailure, IKSettings, JointReference, PathTracker
from mjsuff.experts.paths import minimum_jerk, quadratic_bezier
from mjsuff.scenes.lava_reacher import LavaReacher, fingertip_xy

OFFSETS = np.linspace(-0.15, 0.15, 7)
DURATIONS = np.array([0.5, 0.8, 1.1, 1.4])
REACH = np.array([0.5, 0.8, 1.0])
#: Spread of one refinement step at scale 1: offset (m), duration (s), reach share.
STEP = np.array([0.05, 0.3, 0.25])


class ReacherExpert(Expert):
    """Demonstrates on a :class:`LavaReacher`; path parameters are ``(offset, duration, reach)``."""

    def __init__(self, scene: LavaReacher, settings: ExpertSettings | None = None,
                 ik: IKSettings | None = None) -> None:
        super().__init__(scene, settings)
        self.scene: LavaReacher = scene
        self.tracker = PathTracker(scene.model, "fingertip", "site", settings=ik)
        self._data = mujoco.MjData(scene.model)
        m = scene.model
        self._gain = m.actuator_gainprm[:, 0] * m.actuator_gear[:, 0]
        self._bias = m.actuator_biasprm[:, :3] * m.actuator_gear[:, :1]
        self.horizon = scene.spline.num_steps * m.opt.timestep

    def coarse_params(self, start_qpos: np.ndarray) -> np.ndarray:
        grid = np.stack(np.meshgrid(OFFSETS, DURATIONS, REACH, indexing="ij"), -1).reshape(-1, 3)
        return np.vstack([grid, [0.0, 1.0, 0.0]])  # the last: hold still

    def perturb(self, params: np.ndarray, rng: np.random.Generator, count: int,
                scale: float) -> np.ndarray:
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

    def feedforward(self, reference: JointReference) -> np.ndarray:
        """Servo targets ``(T, nu)`` that make the position actuators reproduce the reference.

        Discrete-time inversion of MuJoCo's step: velocities are the reference's position
        differences, ``v_{t+1} = (q_{t+1} − q_t)/dt``, the acceleration over step ``t`` is
        ``(v_{t+1} − v_t)/dt``, ``mj_inverse`` gives the joint torque, and the servo's damping acts
        on the end-of-step velocity (the implicit integrator treats it so).
        """
        d, m = self._data, self.scene.model
        dt = m.opt.timestep
        q = reference.qpos
        v = np.vstack([np.zeros((1, m.nv)), np.diff(q, axis=0) / dt])
        controls = np.empty((len(q) - 1, m.nu))
        for t in range(len(controls)):
            d.qpos[:], d.qvel[:], d.qacc[:] = q[t], v[t], (v[t + 1] - v[t]) / dt
            mujoco.mj_inverse(m, d)
            torque = d.qfrc_inverse  # joint order = actuator order for this arm
            controls[t] = (torque - self._bias[:, 0] - self._bias[:, 1] * q[t]
                           - self._bias[:, 2] * v[t + 1]) / self._gain
        return controls

    def execute(self, start_qpos: np.ndarray, params: np.ndarray) -> tuple[ExecutedPaths, list[str]]:
        dt = self.scene.model.opt.timestep
        kept, paths, controls, failures = [], [], [], []
        for p in params:
            path = self.intended_path(start_qpos, p)
            try:
                reference = self.tracker.track(start_qpos, path, dt)
            except IKFailure as err:
                failures.append(f"path {np.round(p, 3).tolist()}: {err}")
                continue
            kept.append(p)
            paths.append(path[1:])
            controls.append(self.feedforward(reference))
        if not kept:
            return ExecutedPaths.empty(), failures
        ctrl = self.scene.spline.clip(np.array(controls))
        rollouts, features = self.scene.simulate_controls(np.asarray(start_qpos), ctrl)
        intended = np.array(paths)[:, :, :2]
        executed = fingertip_xy(rollouts.qpos)  # after each step, aligned with the intended path
        error = np.linalg.norm(executed - intended, axis=2).max(axis=1)
        return ExecutedPaths(np.array(kept), intended, executed, rollouts, features, error), failures
