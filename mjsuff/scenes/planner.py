"""Trajectory optimization over spline knots, batched: CEM to find the basin, CMA-ES to refine.

For each problem (a start and a reward vector ``w``) the planner first runs the cross-entropy
method: it keeps a diagonal Gaussian over knot parameters, samples a population every iteration,
simulates all problems' populations in one ``mujoco.rollout`` call, scores each trajectory by
``w · φ`` and refits the Gaussian to the elites. Its wide early populations choose between the
basins of a multi-modal objective (the lander's powered descent vs. tilted free fall). Then,
optionally, CMA-ES (``mjsuff.scenes.cma``) starts from the best trajectory found: its full
covariance follows narrow, correlated ridges (a soft touchdown needs the throttle knots tuned
together) that a diagonal Gaussian crosses slowly. The best trajectory seen in either phase is
kept (elitism), warm starts seed the CEM mean, and every simulated trajectory goes into the
trajectory library so later reward vectors can reuse it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjsuff.scenes.cma import BatchedCMAES, reflect
from mjsuff.scenes.library import TrajectoryLibrary
from mjsuff.scenes.planner_config import PlannerConfig
from mjsuff.scenes.scene import Scene


@dataclass(frozen=True)
class Plans:
    """Best trajectories found: knots ``(B, K, nu)``, features ``(B, k)``, values ``(B,)``."""

    knots: np.ndarray
    features: np.ndarray
    values: np.ndarray


class SamplingPlanner:
    """Batched sampling-based trajectory optimization over a scene's spline knots."""

    def __init__(self, scene: Scene, config: PlannerConfig, library: TrajectoryLibrary | None = None) -> None:
        self.scene = scene
        self.config = config
        self.library = library

    def plan(
        self,
        starts: np.ndarray,
        weights: np.ndarray,
        rng: np.random.Generator,
        warm_knots: np.ndarray | None = None,
    ) -> Plans:
        """Best trajectories for problems ``(start index, w)``: ``starts`` ``(B,)`` index the
        scene's ``all_starts``, ``weights`` is ``(B, k)``, ``warm_knots`` ``(B, K, nu)``."""
        starts = np.asarray(starts)
        mean = (
            self.scene.initial_knots(self.scene.all_starts[starts])
            if warm_knots is None
            else np.array(warm_knots, dtype=float)
        )
        best = _Best(mean.copy(), len(starts), self.scene.num_features)
        self._cem(starts, weights, rng, mean, best)
        if self.config.cma_iterations:
            self._cma(starts, weights, rng, best)
        return Plans(best.knots, best.features, best.values)

    def _evaluate(
        self, starts: np.ndarray, weights: np.ndarray, samples: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Simulate knots ``(B, P, K, nu)``; -> features ``(B, P, k)``, values ``(B, P)``
        (−inf for diverged rollouts). Every valid trajectory joins the library."""
        b, p = samples.shape[:2]
        _, features = self.scene.simulate(
            np.repeat(self.scene.all_starts[starts], p, axis=0), samples.reshape(b * p, *samples.shape[2:])
        )
        features = features.reshape(b, p, -1)
        values = np.einsum("bpk,bk->bp", features, weights)
        values = np.where(np.isfinite(values), values, -np.inf)
        if self.library is not None:
            for j, s in enumerate(starts):
                self.library.add(int(s), features[j], samples[j])
        return features, values

    def _cem(
        self, starts: np.ndarray, weights: np.ndarray, rng: np.random.Generator, mean: np.ndarray, best: _Best
    ) -> None:
        cfg, spline = self.config, self.scene.spline
        b, p = len(starts), cfg.population
        span = spline.high - spline.low
        std = np.broadcast_to(cfg.initial_std * span, (b, *spline.shape)).copy()
        for it in range(cfg.iterations):
            noise = rng.standard_normal((b, p, *spline.shape))
            samples = spline.clip(mean[:, None] + std[:, None] * noise)
            samples[:, 0] = best.knots if it else mean  # elitism / the warm start itself
            features, values = self._evaluate(starts, weights, samples)
            best.update(samples, features, values)
            top = np.argsort(-values, axis=1, kind="stable")[:, : cfg.elites]
            elite = np.take_along_axis(samples, top[:, :, None, None], axis=1)
            mean = cfg.smoothing * mean + (1 - cfg.smoothing) * elite.mean(axis=1)
            std = cfg.smoothing * std + (1 - cfg.smoothing) * elite.std(axis=1)
            std = np.maximum(std, cfg.min_std * span)

    def _cma(self, starts: np.ndarray, weights: np.ndarray, rng: np.random.Generator, best: _Best) -> None:
        cfg, spline = self.config, self.scene.spline
        b, shape = len(starts), spline.shape
        low, span = spline.low, spline.high - spline.low
        unit = np.clip((best.knots - low) / span, 0.0, 1.0).reshape(b, -1)
        search = BatchedCMAES(unit, cfg.cma_sigma, cfg.cma_population)
        for generation in range(cfg.cma_iterations):
            x = search.ask(rng)
            if generation == 0:
                x[:, 0] = unit  # the starting point itself (the warm start, without a CEM phase)
            samples = reflect(x).reshape(b, cfg.cma_population, *shape) * span + low
            features, values = self._evaluate(starts, weights, samples)
            best.update(samples, features, values)
            search.tell(x, values)


class _Best:
    """The best trajectory seen so far per problem."""

    def __init__(self, knots: np.ndarray, count: int, num_features: int) -> None:
        self.knots = knots
        self.features = np.full((count, num_features), np.nan)
        self.values = np.full(count, -np.inf)

    def update(self, samples: np.ndarray, features: np.ndarray, values: np.ndarray) -> None:
        arg = values.argmax(axis=1)
        rows = np.flatnonzero(values[np.arange(len(arg)), arg] > self.values)
        self.values[rows] = values[rows, arg[rows]]
        self.knots[rows] = samples[rows, arg[rows]]
        self.features[rows] = features[rows, arg[rows]]
