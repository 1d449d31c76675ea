"""Batched open-loop simulation through ``mujoco.rollout`` (multi-threaded C), with divergence checks.

A rollout is diverged when its state becomes non-finite or absurdly large, or when simulated time
stalls (MuJoCo resets or stops advancing a diverged ``mjData``); diverged rollouts are flagged and
must never be scored as real trajectories. MuJoCo's warnings that end a simulation (bad qpos, qvel,
qacc or ctrl) reset its ``mjData``, which the time check sees; their counters cannot be read per
rollout (``mujoco.rollout`` reuses one ``mjData`` per thread and clears them between rollouts).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import rollout

from mjsuff.threads import thread_budget

FULL_STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS
#: Any |qpos| or |qvel| above this is treated as a divergence (metres, radians, per second).
STATE_LIMIT = 1e4


@dataclass(frozen=True)
class Rollouts:
    """Simulated trajectories.

    Attributes:
        qpos: ``(B, T, nq)`` joint positions after each step.
        qvel: ``(B, T, nv)`` joint velocities after each step.
        sensordata: ``(B, T, nsensordata)``.
        controls: ``(B, T, nu)`` the applied controls.
        valid: ``(B,)`` False for diverged rollouts.
    """

    qpos: np.ndarray
    qvel: np.ndarray
    sensordata: np.ndarray
    controls: np.ndarray
    valid: np.ndarray


class Simulator:
    """Runs batches of open-loop rollouts of one model from given start states.

    Args:
        model: The compiled model (instances may differ only in positions/sizes of geoms and
            sites, which the same simulator can take by being handed the new model).
        threads: Worker threads (default: the thread budget, ``mjsuff.threads``).
    """

    def __init__(self, model: mujoco.MjModel, threads: int | None = None) -> None:
        self.model = model
        self.threads = threads or thread_budget()
        self._datas = [mujoco.MjData(model) for _ in range(self.threads)]
        self.state_size = mujoco.mj_stateSize(model, FULL_STATE)
        #: Steps simulated and rollouts flagged as diverged so far (for run reports).
        self.steps_simulated = 0
        self.diverged = 0

    def full_state(self, qpos: np.ndarray, qvel: np.ndarray | None = None) -> np.ndarray:
        """Full-physics states ``(B, nstate)`` at time 0 from joint positions (and velocities)."""
        qpos = np.atleast_2d(qpos)
        qvel = np.zeros((qpos.shape[0], self.model.nv)) if qvel is None else np.atleast_2d(qvel)
        state = np.zeros((qpos.shape[0], self.state_size))
        state[:, 1 : 1 + self.model.nq] = qpos
        state[:, 1 + self.model.nq : 1 + self.model.nq + self.model.nv] = qvel
        return state

    def run(self, initial_state: np.ndarray, controls: np.ndarray) -> Rollouts:
        """Simulate ``controls`` ``(B, T, nu)`` from ``initial_state`` ``(B or 1, nstate)``."""
        b, t, _ = controls.shape
        initial = np.broadcast_to(initial_state, (b, self.state_size))
        state, sensordata = rollout.rollout(
            self.model, self._datas, np.ascontiguousarray(initial), np.ascontiguousarray(controls)
        )
        self.steps_simulated += b * t
        nq, nv = self.model.nq, self.model.nv
        qpos = state[:, :, 1 : 1 + nq]
        qvel = state[:, :, 1 + nq : 1 + nq + nv]
        finite = np.isfinite(state).all(axis=(1, 2))
        bounded = (np.abs(state[:, :, 1:]) < STATE_LIMIT).all(axis=(1, 2))
        expected_end = initial[:, 0] + t * self.model.opt.timestep
        advanced = np.isclose(state[:, -1, 0], expected_end, atol=0.5 * self.model.opt.timestep)
        valid = finite & bounded & advanced
        self.diverged += int((~valid).sum())
        return Rollouts(qpos, qvel, sensordata, controls, valid)
