"""Differential IK with mink: a task-space path turned into a joint-space reference.

The path is tracked the way a person guiding the arm would move it: at every IK sample the frame
task's target moves to the next point of the path and mink solves one (or a few) QP steps with a
posture regularizer and the configuration and velocity limits. The joint reference between samples
is a cubic spline through the solved configurations, so its velocities and accelerations are
smooth (the executor's feedforward needs them).
"""

from __future__ import annotations

from dataclasses import dataclass

import mink
import mujoco
import numpy as np
from scipy.interpolate import CubicSpline


class IKFailure(RuntimeError):
    """mink could not follow a path: a target out of reach, a limit violated, or no QP solution."""


@dataclass(frozen=True)
class JointReference:
    """A joint-space reference at every simulation step.

    Attributes:
        qpos: ``(T, nq)`` joint positions (rad or m).
        qvel: ``(T, nv)`` their time derivatives.
        qacc: ``(T, nv)`` their second derivatives.
        residual: ``(samples,)`` task-space distance from each IK sample's solution to its target (m).
    """

    qpos: np.ndarray
    qvel: np.ndarray
    qacc: np.ndarray
    residual: np.ndarray


@dataclass(frozen=True)
class IKSettings:
    """How the path is tracked.

    Attributes:
        stride: Simulation steps between IK samples (the reference is interpolated in between).
        iterations: QP steps per sample (more converge further on sharp turns).
        posture_cost: Weight of the posture regularizer (pulls toward the start configuration).
        max_joint_speed: Velocity limit per joint (rad/s or m/s).
        tolerance: Largest task-space residual at a sample before the path counts as failed (m).
    """

    stride: int = 5
    iterations: int = 2
    posture_cost: float = 1e-3
    max_joint_speed: float = 8.0
    tolerance: float = 0.004

    def __post_init__(self) -> None:
        if self.stride < 1 or self.iterations < 1:
            raise ValueError("IK stride and iterations must be >= 1")
        if self.tolerance <= 0 or self.max_joint_speed <= 0 or self.posture_cost < 0:
            raise ValueError("IK tolerance and joint speed must be > 0, posture cost >= 0")


class PathTracker:
    """mink IK for one model and one frame (a site or a body).

    Args:
        model: The scene's model (only kinematics are used).
        frame: Name of the tracked frame.
        frame_type: ``"site"`` or ``"body"``.
        orientation_cost: Weight of the frame's orientation (0 tracks position only).
        settings: Sampling, limits and tolerance.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        frame: str,
        frame_type: str,
        orientation_cost: float = 0.0,
        settings: IKSettings | None = None,
    ) -> None:
        self.model = model
        self.settings = settings or IKSettings()
        self.frame, self.frame_type = frame, frame_type
        self.configuration = mink.Configuration(model)
        self.frame_task = mink.FrameTask(
            frame, frame_type, position_cost=1.0, orientation_cost=orientation_cost, lm_damping=1e-6
        )
        self.posture_task = mink.PostureTask(model, cost=self.settings.posture_cost)
        names = [model.joint(j).name for j in range(model.njnt)]
        speed = self.settings.max_joint_speed
        self.limits = [
            mink.ConfigurationLimit(model),
            mink.VelocityLimit(model, {name: speed for name in names}),
        ]

    def track(
        self, start_qpos: np.ndarray, positions: np.ndarray, dt: float, rotations: np.ndarray | None = None
    ) -> JointReference:
        """Joint reference following ``positions`` ``(T, 3)`` (world, m), one per step of ``dt`` s.

        ``rotations`` ``(T, 4)`` (wxyz quaternions) are the frame's target orientations when the
        orientation is tracked. Raises :class:`IKFailure` when a sample's residual exceeds the
        tolerance or mink raises.
        """
        cfg, s = self.configuration, self.settings
        steps = len(positions)
        samples = np.unique(np.append(np.arange(0, steps, s.stride), steps - 1))
        self.posture_task.set_target(start_qpos)
        cfg.update(np.asarray(start_qpos, dtype=float))
        solved = np.empty((len(samples), self.model.nq))
        residual = np.empty(len(samples))
        previous = 0
        for i, step in enumerate(samples):
            rotation = (
                mink.SO3(rotations[step])
                if rotations is not None
                else cfg.get_transform_frame_to_world(self.frame, self.frame_type).rotation()
            )
            self.frame_task.set_target(mink.SE3.from_rotation_and_translation(rotation, positions[step]))
            h = max(step - previous, 1) * dt / s.iterations
            try:
                for _ in range(s.iterations):
                    v = mink.solve_ik(
                        cfg, [self.frame_task, self.posture_task], h, "daqp", limits=self.limits
                    )
                    cfg.integrate_inplace(v, h)
            except mink.MinkError as err:
                raise IKFailure(f"mink failed at step {step}: {err}") from err
            reached = cfg.get_transform_frame_to_world(self.frame, self.frame_type).translation()
            residual[i] = np.linalg.norm(reached - positions[step])
            if not np.isfinite(residual[i]) or residual[i] > s.tolerance:
                raise IKFailure(
                    f"target at step {step} missed by {residual[i] * 1000:.1f} mm "
                    f"(tolerance {s.tolerance * 1000:.1f} mm)"
                )
            solved[i] = cfg.q
            previous = step
        spline = CubicSpline(samples * dt, solved, axis=0, bc_type="clamped")
        t = np.arange(steps) * dt
        return JointReference(spline(t), spline(t, 1), spline(t, 2), residual)
