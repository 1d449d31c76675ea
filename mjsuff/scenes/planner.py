"""Trajectory optimization by the cross-entropy method over spline knots, batched.

For each problem (a start and a reward vector ``w``) the planner keeps a Gaussian over knot
parameters; every iteration samples a population, simulates all problems' populations in one
``mujoco.rollout`` call, scores each trajectory by ``w · φ``, and refits the Gaussian to the
elites. The best trajectory seen is kept (elitism), warm starts seed the mean, and every
simulated trajectory goes into the trajectory library so later reward vectors can reuse it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from mjsuff.scenes.library import TrajectoryLibrary
from mjsuff.scenes.scene import Scene


class PlannerConfig(BaseModel):
    """CEM budget: ``population × iterations`` rollouts per problem."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)

    population: int = Field(64, ge=4, description="trajectories sampled per iteration")
    elites: int = Field(6, ge=1, description="best trajectories the Gaussian is refit to")
    iterations: int = Field(32, ge=1, description="CEM iterations")
    initial_std: float = Field(0.35, gt=0.0, description="initial s.d., as a share of the control range")
    min_std: float = Field(0.01, gt=0.0, description="s.d. floor, as a share of the control range")
    smoothing: float = Field(0.0, ge=0.0, lt=1.0, description="weight of the old mean/s.d. in a refit")

    def scaled(self, factor: float) -> PlannerConfig:
        """The same planner with ``factor`` times the population (and elites)."""
        return self.model_copy(update={"population": int(self.population * factor),
                                       "elites": int(self.elites * factor)})


@dataclass(frozen=True)
class Plans:
    """Best trajectories found: knots ``(B, K, nu)``, features ``(B, k)``, values ``(B,)``."""

    knots: np.ndarray
    features: np.ndarray
    values: np.ndarray


class CEMPlanner:
    """Batched CEM over a scene's spline knots."""

    def __init__(self, scene: Scene, config: PlannerConfig,
                 library: TrajectoryLibrary | None = None) -> None:
        self.scene = scene
        self.config = config
        self.library = library

    def plan(self, starts: np.ndarray, weights: np.ndarray, rng: np.random.Generator,
             warm_knots: np.ndarray | None = None) -> Plans:
        """Best trajectories for problems ``(start index, w)``: ``starts`` ``(B,)`` index the
        scene's evaluation starts, ``weights`` is ``(B, k)``, ``warm_knots`` ``(B, K, nu)``."""
        cfg, spline = self.config, self.scene.spline
        b = len(starts)
        span = spline.high - spline.low
        mean = (self.scene.initial_knots(self.scene.starts[starts])
                if warm_knots is None else np.array(warm_knots, dtype=float))
        std = np.broadcast_to(cfg.initial_std * span, (b, *spline.shape)).copy()
        best_knots = mean.copy()
        best_features = np.full((b, self.scene.num_features), np.nan)
        best_values = np.full(b, -np.inf)
        p = cfg.population
        start_qpos = self.scene.starts[starts]
        for it in range(cfg.iterations):
            noise = rng.standard_normal((b, p, *spline.shape))
            samples = spline.clip(mean[:, None] + std[:, None] * noise)
            samples[:, 0] = best_knots if it else mean  # elitism / the warm start itself
            flat = samples.reshape(b * p, *spline.shape)
            _, features = self.scene.simulate(np.repeat(start_qpos, p, axis=0), flat)
            features = features.reshape(b, p, -1)
            values = np.einsum("bpk,bk->bp", features, weights)
            values = np.where(np.isfinite(values), values, -np.inf)
            if self.library is not None:
                for j, s in enumerate(starts):
                    self.library.add(int(s), features[j], samples[j])
            top = np.argsort(-values, axis=1)[:, : cfg.elites]
            elite = np.take_along_axis(samples, top[:, :, None, None], axis=1)
            mean = cfg.smoothing * mean + (1 - cfg.smoothing) * elite.mean(axis=1)
            std = cfg.smoothing * std + (1 - cfg.smoothing) * elite.std(axis=1)
            std = np.maximum(std, cfg.min_std * span)
            improved = values[np.arange(b), top[:, 0]] > best_values
            rows = np.flatnonzero(improved)
            best_values[rows] = values[rows, top[rows, 0]]
            best_knots[rows] = samples[rows, top[rows, 0]]
            best_features[rows] = features[rows, top[rows, 0]]
        return Plans(best_knots, best_features, best_values)
