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

from mjsuff.scenes.library import TrajectoryLibrary
from mjsuff.scenes.planner_config import PlannerConfig
from mjsuff.scenes.scene import Scene


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
        r = cfg.restarts
        if r > 1:
            # Independent runs side by side: restart 0 from the warm start / default, the others
            # from random knots; each problem keeps its best.
            n = len(starts)
            first = (self.scene.initial_knots(self.scene.starts[starts])
                     if warm_knots is None else np.asarray(warm_knots, dtype=float))
            others = spline.uniform(rng, n * (r - 1)).reshape(r - 1, n, *spline.shape)
            single = CEMPlanner(self.scene, cfg.model_copy(update={"restarts": 1}), self.library)
            plans = single.plan(np.tile(starts, r), np.tile(weights, (r, 1)), rng,
                                np.concatenate([first[None], others]).reshape(r * n, *spline.shape))
            values = plans.values.reshape(r, n)
            pick = values.argmax(axis=0)
            cols = np.arange(n)
            return Plans(plans.knots.reshape(r, n, *spline.shape)[pick, cols],
                         plans.features.reshape(r, n, -1)[pick, cols], values[pick, cols])
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
