"""A MuJoCo scene: an MJCF model, per-instance randomization, start states and trajectory features.

A scene turns simulated trajectories into reward features. Its subclasses keep the physics'
feature getters (``features``) apart from the task's reward, which is always ``w · φ`` with
weights chosen elsewhere.
"""

from __future__ import annotations

import abc
import functools
from pathlib import Path

import mujoco
import numpy as np

from mjsuff.package_data import data_dir
from mjsuff.scenes.planner_config import PlannerConfig
from mjsuff.scenes.simulate import Rollouts, Simulator
from mjsuff.scenes.spline import ControlSpline

#: The folder of the MJCF files: the package ``mjsuff.models`` (the repository's ``models/``).
MODELS = data_dir("mjsuff.models")


def model_path(name: str) -> Path:
    """The file of the shipped MJCF model ``NAME`` (e.g. ``lava_reacher.xml``); a one-line
    ``FileNotFoundError`` naming the shipped models if there is none."""
    path = MODELS / name
    if not path.is_file():
        shipped = sorted(p.name for p in MODELS.glob("*.xml"))
        if not shipped:
            raise FileNotFoundError(
                f"{MODELS}: mjsuff's MJCF models are missing (a broken install: reinstall mjsuff)"
            )
        raise FileNotFoundError(f"{name}: no such MJCF model in {MODELS} (models: {', '.join(shipped)})")
    return path


def load_model(name: str | Path) -> mujoco.MjModel:
    """Compile the shipped MJCF model ``NAME`` (see ``model_path``), or the model at path ``name``."""
    return mujoco.MjModel.from_xml_path(str(name if isinstance(name, Path) else model_path(name)))


class Scene(abc.ABC):
    """One randomized instance of a MuJoCo task.

    Attributes:
        model: This instance's compiled model (goal, hazards moved into place).
        spline: The control parameterization shared by planner, random policy and expert.
        starts: ``(S, nq)`` joint positions of the fixed evaluation starts (at rest), where
            policies are judged and never demonstrated.
        pool_starts: ``(P, nq)`` joint positions of the demonstration pool, drawn apart from the
            evaluation starts (a policy is judged where it was not shown).
        feature_names: The ``k`` feature names, in order.

    Planners and trajectory libraries index :attr:`all_starts`: the evaluation starts first
    (``0 … S−1``), then the pool (``S … S+P−1``).
    """

    model: mujoco.MjModel
    spline: ControlSpline
    starts: np.ndarray
    pool_starts: np.ndarray
    feature_names: tuple[str, ...]
    #: The world axes (of x, y, z) that the two coordinates of ``path`` lie along.
    path_axes: tuple[int, int] = (0, 1)
    #: The planner budget this scene needs (see benchmarks/scenes.py and tests/test_planner.py).
    planner_config: PlannerConfig = PlannerConfig()
    #: One warm-started V* refinement for a group of reward vectors (tests/test_planner.py).
    refine_config: PlannerConfig = PlannerConfig(population=32, elites=4, iterations=10, initial_std=0.1)
    #: The seed plans of prior draws from every start (the random policy; the library's seed).
    seed_config: PlannerConfig = PlannerConfig(population=32, elites=4, iterations=16)

    def __init__(self, threads: int | None = None) -> None:
        self.simulator = Simulator(self.model, threads)

    @property
    def num_features(self) -> int:
        return len(self.feature_names)

    @functools.cached_property
    def all_starts(self) -> np.ndarray:
        """Evaluation starts, then the demonstration pool: ``(S + P, nq)``."""
        return np.concatenate([self.starts, self.pool_starts])

    def start_states(self, qpos: np.ndarray) -> np.ndarray:
        """Full-physics states at rest for joint positions ``(B, nq)``."""
        return self.simulator.full_state(qpos)

    def simulate(self, start_qpos: np.ndarray, knots: np.ndarray) -> tuple[Rollouts, np.ndarray]:
        """Roll out knots ``(B, K, nu)`` from starts ``(B or 1, nq)``; -> rollouts, features (B, k).

        Features of diverged rollouts are NaN and ``rollouts.valid`` is False for them.
        """
        start_qpos = np.atleast_2d(start_qpos)
        anchor = self.anchor(start_qpos) if self.spline.anchored else None
        rollouts = self.simulator.run(self.start_states(start_qpos), self.spline.controls(knots, anchor))
        features = self.features(rollouts)
        features[~rollouts.valid] = np.nan
        return rollouts, features

    def simulate_controls(self, start_qpos: np.ndarray, controls: np.ndarray) -> tuple[Rollouts, np.ndarray]:
        """Roll out per-step controls ``(B, T, nu)`` (e.g. an expert's) from starts ``(B or 1, nq)``."""
        rollouts = self.simulator.run(
            self.start_states(np.atleast_2d(start_qpos)), np.asarray(controls, dtype=float)
        )
        features = self.features(rollouts)
        features[~rollouts.valid] = np.nan
        return rollouts, features

    def initial_knots(self, start_qpos: np.ndarray) -> np.ndarray:
        """Where a planner's search starts without a warm start: mid-range controls."""
        centre = (self.spline.low + self.spline.high) / 2
        return np.broadcast_to(centre, (len(start_qpos), *self.spline.shape)).copy()

    def primitive_knots(self, start_qpos: np.ndarray) -> np.ndarray:
        """A reward-agnostic family of knots ``(M, K, nu)`` from one start ``(nq,)``, simulated
        into every start's trajectory library when an instance is built (the basins a planner's
        search could miss); default: none."""
        return np.empty((0, *self.spline.shape))

    def anchor(self, start_qpos: np.ndarray) -> np.ndarray:
        """The control at t = 0 from starts ``(B, nq)`` (anchored splines only)."""
        raise NotImplementedError(f"{type(self).__name__} does not anchor its controls")

    def features(self, rollouts: Rollouts) -> np.ndarray:
        """Reward features ``(B, k)`` of simulated trajectories: ``φ(τ) = Σ_t φ_t``."""
        return self.step_features(rollouts).sum(axis=1)

    @abc.abstractmethod
    def step_features(self, rollouts: Rollouts, horizon: int | None = None) -> np.ndarray:
        """Each step's share ``φ_t`` ``(B, T, k)`` of the trajectories' features (from states and
        sensors), so that ``Σ_t φ_t = φ(τ)``.

        Causal: row ``t`` depends on steps ``0..t`` only, so the first ``T`` steps of a trajectory
        of ``horizon`` steps (default: the rollouts are whole, ``horizon = T``) give the first
        ``T`` rows of the whole trajectory's ``φ_t``; terms of the last step (where the craft
        ended up, say) appear only once the rollout is whole. The dm_control environments
        (``mjsuff.suite``) reward ``w·φ_t`` with this same code.
        """

    @abc.abstractmethod
    def sample_starts(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """``count`` start configurations ``(count, nq)`` from the start distribution."""

    @abc.abstractmethod
    def baseline_knots(self) -> np.ndarray:
        """Knots ``(S, K, nu)`` of the baseline policy (for PIOB) from each evaluation start."""

    @abc.abstractmethod
    def path(self, rollouts: Rollouts) -> np.ndarray:
        """The task-space path ``(B, T, 2)`` a trajectory traces (fingertip or craft, metres)."""
