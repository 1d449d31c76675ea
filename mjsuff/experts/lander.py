"""The lander's kinesthetic expert.

A candidate descent path drops the craft from its start (at rest) to touchdown height
``REST_HEIGHT``: it falls with downward acceleration ``fall`` × g, then brakes at ``brake`` × (the
engine's margin over gravity) to arrive with ``touchdown_speed`` (m/s). Sideways it moves by tilting
the thrust: ``tan θ = A cos(π F)``, where ``F`` is the share of the descent's vertical thrust
impulse spent so far, so the craft leans toward the pad, then back, and arrives with no sideways
speed; ``A`` makes it shift by ``lateral`` × (pad − start), capped by the largest allowed pitch.
The pitch is blended in from the start's own. Every path is thus one the engine can fly.
mink IK (a frame task on the craft body, position and orientation) turns the pose path into
references for the x, z and pitch joints, and a controller tracks them in closed loop (all
candidates stepped side by side): a PD law on position gives the desired force, its component
along the body axis the thrust (through the engine's climb-rate loop, whose set-point it sets)
and its direction the pitch set-point of the attitude servo; after touchdown the engine is cut
and the craft is held level. The demonstrator then hands the robot the set-points at its control
knots: the spline closest to the controller's set-points (least squares), flown open loop by the
craft's own loops, is the demo. So a demo is a trajectory the robot's controls can express, and
the planner is not handicapped against the demonstrator.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjsuff.experts.expert import ExecutedPaths, Expert, ExpertSettings
from mjsuff.experts.ik import IKFailure, IKSettings, PathTracker
from mjsuff.experts.paths import fall_and_brake, minimum_jerk
from mjsuff.scenes.lander import REST_HEIGHT, TOUCH_THRESHOLD, Lander

#: Coarse grid: fall acceleration (share of g), braking (share of the thrust's margin over
#: gravity), touchdown speed (m/s), lateral share of the way to the pad.
FALL = np.array([0.5, 0.9])
BRAKE = np.array([0.45, 0.8])
TOUCHDOWN_SPEEDS = np.array([0.1, 0.6, 1.5, 3.0])
LATERAL = np.array([0.6, 1.0])
LOW = np.array([0.2, 0.2, 0.0, 0.0])
HIGH = np.array([1.0, 0.9, 4.0, 1.0])
#: Spread of one refinement step at scale 1, per parameter.
STEP = np.array([0.2, 0.15, 0.5, 0.2])
#: Position loop gains (1/s², 1/s).
KP, KD = 4.0, 4.0
MAX_PITCH = 0.6  # rad, within the attitude servo's range


class LanderExpert(Expert):
    """Demonstrates on a :class:`Lander`; path parameters are
    ``(fall, brake, touchdown_speed, lateral)``."""

    def __init__(
        self, scene: Lander, settings: ExpertSettings | None = None, ik: IKSettings | None = None
    ) -> None:
        super().__init__(scene, settings)
        self.scene: Lander = scene
        m = scene.model
        self.tracker = PathTracker(
            m,
            "craft",
            "body",
            orientation_cost=1.0,
            settings=ik or IKSettings(stride=10, iterations=3, tolerance=0.01),
        )
        self.mass = float(m.body_subtreemass[m.body("craft").id])
        self.gravity = -float(m.opt.gravity[2])
        main = m.actuator("main").id
        self.max_thrust = float(m.actuator_forcerange[main, 1])
        #: The climb-rate loop: thrust = weight + gain × (set-point − axial speed).
        self.loop_gain = float(m.actuator_gainprm[main, 0])
        self.feedforward = float(m.actuator_biasprm[main, 0])
        self.horizon = scene.spline.num_steps * m.opt.timestep
        #: Largest upward acceleration the engine gives an upright craft (m/s²).
        self.brake_margin = self.max_thrust / self.mass - self.gravity

    def coarse_params(self, start_qpos: np.ndarray) -> np.ndarray:
        axes = np.meshgrid(FALL, BRAKE, TOUCHDOWN_SPEEDS, LATERAL, indexing="ij")
        return np.stack(axes, -1).reshape(-1, 4)

    def random_params(self, start_qpos: np.ndarray, rng: np.random.Generator, count: int) -> np.ndarray:
        """Any fall, brake and touchdown speed of the family's ranges; at least half of the way
        to the pad sideways."""
        params = rng.uniform(LOW, HIGH, size=(count, 4))
        params[:, 3] = rng.uniform(0.5, HIGH[3], count)
        return params

    def perturb(self, params: np.ndarray, rng: np.random.Generator, count: int, scale: float) -> np.ndarray:
        return np.clip(params + rng.standard_normal((count, 4)) * STEP * scale, LOW, HIGH)

    def intended_path(self, start_qpos: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Craft positions ``(T + 1, 3)`` (m) and orientations ``(T + 1, 4)`` (wxyz) at times
        0, dt, …, T·dt for one candidate."""
        fall, brake, speed, lateral = params
        steps, dt = self.scene.spline.num_steps, self.scene.model.opt.timestep
        t = np.arange(steps + 1) * dt
        x0, z0, pitch0 = start_qpos
        drop, downward, arrival = fall_and_brake(
            t, z0 - REST_HEIGHT, fall * self.gravity, brake * self.brake_margin, speed
        )
        # Vertical thrust per unit mass, a_z + g, along the descent (0 once landed).
        lift = np.where(t < arrival, self.gravity - downward, 0.0)
        # tan θ = A cos(π F), F the share of the lift impulse so far: sideways speed is zero again
        # on arrival; A scales the sideways shift to its target (capped by the largest pitch).
        impulse = np.concatenate([[0.0], np.cumsum(lift[:-1]) * dt])
        share = impulse / max(impulse[-1], 1e-9)
        profile = lift * np.cos(np.pi * share)
        unit_shift = np.concatenate([[0.0], np.cumsum(np.cumsum(profile[:-1]) * dt) * dt])
        reach = unit_shift[min(int(np.ceil(arrival / dt)), steps)]
        gain = lateral * (self.scene.pad_x - x0) / reach if reach > 1e-9 else 0.0
        gain = float(np.clip(gain, -np.tan(MAX_PITCH), np.tan(MAX_PITCH)))
        x = x0 + gain * unit_shift
        pitch = np.where(t < arrival, np.arctan(gain * np.cos(np.pi * share)), 0.0)
        # From the start's own pitch, blended into the path's over the first second.
        pitch += (pitch0 - pitch[0]) * (1.0 - minimum_jerk(t / 1.0))
        positions = np.column_stack([x, np.zeros_like(x), z0 - drop])
        quats = np.column_stack([np.cos(pitch / 2), np.zeros_like(x), np.sin(pitch / 2), np.zeros_like(x)])
        return positions, quats

    def control(
        self,
        qpos: np.ndarray,
        qvel: np.ndarray,
        touched: np.ndarray,
        q_ref: np.ndarray,
        v_ref: np.ndarray,
        a_ref: np.ndarray,
    ) -> np.ndarray:
        """Climb-rate and pitch set-points ``(C, 2)`` for all candidates, from their states and
        references ``(C, 3)`` at this step: a PD law on position gives the force wanted, its
        component along the body axis the thrust (through the climb-rate loop), its direction
        the pitch."""
        force = self.mass * (
            a_ref[:, :2] + KP * (q_ref[:, :2] - qpos[:, :2]) + KD * (v_ref[:, :2] - qvel[:, :2])
        )
        force[:, 1] += self.mass * self.gravity
        pitch = qpos[:, 2]
        pitch_target = np.where(
            force[:, 1] > 0, np.clip(np.arctan2(force[:, 0], force[:, 1]), -MAX_PITCH, MAX_PITCH), q_ref[:, 2]
        )
        pitch_target = np.where(touched, 0.0, pitch_target)
        thrust = np.clip(force[:, 0] * np.sin(pitch) + force[:, 1] * np.cos(pitch), 0.0, self.max_thrust)
        # The set-point that makes the climb-rate loop give that thrust now; after touchdown the
        # lowest set-point, which cuts the engine.
        axial = qvel[:, 0] * np.sin(pitch) + qvel[:, 1] * np.cos(pitch)
        low, high = self.scene.spline.low[0], self.scene.spline.high[0]
        setpoint = np.clip(axial + (thrust - self.feedforward) / self.loop_gain, low, high)
        setpoint = np.where(touched, low, setpoint)
        return np.column_stack([setpoint, pitch_target])

    def task_path(self, qpos: np.ndarray) -> np.ndarray:
        """The craft's (x, z) position ``(B, T, 2)`` (m)."""
        return qpos[:, :, :2]

    def execute(self, start_qpos: np.ndarray, params: np.ndarray) -> tuple[ExecutedPaths, list[str]]:
        m, dt = self.scene.model, self.scene.model.opt.timestep
        kept, paths, references, failures = [], [], [], []
        for p in params:
            positions, quats = self.intended_path(start_qpos, p)
            try:
                references.append(self.tracker.track(start_qpos, positions, dt, rotations=quats))
            except IKFailure as err:
                failures.append(f"path {np.round(p, 3).tolist()}: {err}")
                continue
            kept.append(p)
            paths.append(positions[1:, [0, 2]])
        if not kept:
            return ExecutedPaths.empty(), failures
        datas = [mujoco.MjData(m) for _ in kept]
        for d in datas:
            d.qpos[:] = start_qpos
            mujoco.mj_forward(m, d)
        steps = self.scene.spline.num_steps
        controls = np.empty((len(kept), steps, m.nu))
        touched = np.zeros(len(kept), dtype=bool)
        q_ref, v_ref, a_ref = (
            np.stack([getattr(r, name) for r in references]) for name in ("qpos", "qvel", "qacc")
        )
        for t in range(steps):
            qpos = np.array([d.qpos for d in datas])
            qvel = np.array([d.qvel for d in datas])
            touched |= np.array([(d.sensordata[:2] > TOUCH_THRESHOLD).any() for d in datas])
            controls[:, t] = self.control(qpos, qvel, touched, q_ref[:, t], v_ref[:, t], a_ref[:, t])
            for d, u in zip(datas, controls[:, t], strict=True):
                d.ctrl[:] = u
                mujoco.mj_step(m, d)
        # The demonstrator hands the robot set-points at its control knots: the spline closest
        # to the controller's set-points (least squares), flown open loop by the craft's own
        # loops. The demo is then a trajectory the robot's controls can express.
        spline = self.scene.spline
        knots = spline.clip(np.einsum("kt,ctu->cku", np.linalg.pinv(spline.basis), controls))
        rollouts, features = self.scene.simulate(np.asarray(start_qpos), knots)
        intended = np.array(paths)
        executed = self.task_path(rollouts.qpos)
        error = np.linalg.norm(executed - intended, axis=2).max(axis=1)
        return ExecutedPaths(np.array(kept), intended, executed, rollouts, features, error, knots), failures
