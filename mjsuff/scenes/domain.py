"""MuJoCo scenes behind the Domain seam: planned policies, trajectory features, library-based V*.

A policy is the planner's knots from every evaluation start (``(S, K, nu)``); its feature
expectations are the features of those simulated trajectories (the simulation is deterministic).
``optimal_start_values`` answers ``V*_w(s)`` for many reward vectors at once from the per-start
trajectory library, then refines where it can matter: weights are grouped by the library
trajectory that is best for them, and each group is re-planned (warm-started from that
trajectory, with a short budget) for the group's mean direction; everything simulated joins the
library, and the answer is the library maximum again, so it never drops below it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pydantic import BaseModel

from mjsuff.domain import Demo, Domain
from mjsuff.scenes.library import TrajectoryLibrary
from mjsuff.scenes.planner import CEMPlanner, PlannerConfig
from mjsuff.scenes.scene import Scene
from mjsuff.sphere import normalize, random_unit_vectors

if TYPE_CHECKING:
    from mjsuff.experts.expert import Expert

#: Uniform-random trajectories per start that estimate the random policy's features.
RANDOM_TRAJECTORIES = 64


class SceneDomain(Domain):
    """A MuJoCo scene instance as a Domain (the trajectory likelihood arrives with issue #5).

    Args:
        scene: The randomized scene instance.
        rng: Randomness of the hidden weights, the random policy and planning.
        planner: Budget of ``plan`` (π for a reward vector).
        refine: Budget of one refinement in ``optimal_start_values``.
        max_groups: Most weight groups refined per start and round.
        rounds: Refinement rounds per call (groups are formed anew each round).
        seed_directions: Reward directions (spread over the all-negative orthant) planned from
            every start when the instance is built, so the library holds each mode's optimum.
        seed_planner: Budget of those seed plans.
        expert: The kinesthetic demonstrator (``mjsuff.experts``); without one, ``demonstrate``
            raises.
    """

    def __init__(self, scene: Scene, rng: np.random.Generator,
                 planner: PlannerConfig | None = None, refine: PlannerConfig | None = None,
                 max_groups: int = 16, rounds: int = 2, seed_directions: int = 8,
                 seed_planner: PlannerConfig | None = None, expert: Expert | None = None) -> None:
        self.scene = scene
        self.expert = expert
        self.rng = rng
        self.num_features = scene.num_features
        self.true_weights = draw_true_weights(rng, scene.num_features)
        s = len(scene.starts)
        self.start_weights = np.full(s, 1.0 / s)
        self.pool = np.arange(s)
        self.library = TrajectoryLibrary(s, scene.num_features, scene.spline.shape)
        self.planner = CEMPlanner(scene, planner or scene.planner_config, self.library)
        self.refiner = CEMPlanner(scene, refine or PlannerConfig(
            population=32, elites=4, iterations=10, initial_std=0.1), self.library)
        self.max_groups = max_groups
        self.rounds = rounds
        knots = scene.spline.uniform(rng, RANDOM_TRAJECTORIES * s)
        _, feats = scene.simulate(np.repeat(scene.starts, RANDOM_TRAJECTORIES, axis=0), knots)
        feats = feats.reshape(s, RANDOM_TRAJECTORIES, -1)
        for i in range(s):
            self.library.add(i, feats[i], knots.reshape(s, RANDOM_TRAJECTORIES, *scene.spline.shape)[i])
        self._random_mu = np.nanmean(feats, axis=1)
        _, self._baseline_mu = scene.simulate(scene.starts, scene.baseline_knots())
        if seed_directions:
            seeder = CEMPlanner(scene, seed_planner or PlannerConfig(population=32, elites=4,
                                                                     iterations=16), self.library)
            directions = -np.abs(random_unit_vectors(rng, seed_directions, scene.num_features))
            starts = np.repeat(np.arange(s), seed_directions)
            seeder.plan(starts, np.tile(directions, (s, 1)), rng)

    # -- robot side ---------------------------------------------------------------------------
    def plan(self, w: np.ndarray) -> np.ndarray:
        """Planned knots ``(S, K, nu)`` from every evaluation start for reward weights ``w``."""
        starts = np.arange(len(self.scene.starts))
        weights = np.broadcast_to(np.asarray(w, dtype=float), (len(starts), self.num_features))
        warm = np.stack([self.library.arrays(s)[1][self.library.best(s, weights[:1])[1][0]]
                         for s in starts])
        return self.planner.plan(starts, weights, self.rng, warm_knots=warm).knots

    def start_feature_expectations(self, policy: np.ndarray) -> np.ndarray:
        _, features = self.scene.simulate(self.scene.starts, policy)
        return features

    def optimal_start_values(self, weights: np.ndarray, refine: bool = True) -> np.ndarray:
        weights = np.atleast_2d(weights)
        n, s = len(weights), len(self.scene.starts)
        for _ in range(self.rounds if refine else 0):
            problems, groups = [], []
            for start in range(s):
                _, best = self.library.best(start, weights)
                index, counts = np.unique(best, return_counts=True)
                for j in index[np.argsort(-counts)][: self.max_groups]:
                    members = best == j
                    problems.append((start, j))
                    groups.append(normalize(weights[members].mean(axis=0)))
            starts = np.array([p[0] for p in problems])
            warm = np.stack([self.library.arrays(st)[1][j] for st, j in problems])
            self.refiner.plan(starts, np.array(groups), self.rng, warm_knots=warm)
        out = np.empty((n, s))
        for start in range(s):
            out[:, start] = self.library.best(start, weights)[0]
        return out

    def random_start_feature_expectations(self) -> np.ndarray:
        return self._random_mu

    def baseline_start_feature_expectations(self) -> np.ndarray:
        return self._baseline_mu

    def same_policy(self, a: np.ndarray, b: np.ndarray) -> bool:
        raise NotImplementedError("trajectory tolerances for the baselines arrive with issue #5")

    def agrees_with_demo(self, policy: np.ndarray, demo: Demo) -> bool:
        raise NotImplementedError("trajectory tolerances for the baselines arrive with issue #5")

    def policy_optimality(self, policy: np.ndarray) -> float:
        raise NotImplementedError("per-start optimality arrives with issue #5")

    # -- expert (issue #4) and likelihood (issue #5) -------------------------------------------
    def demonstrate(self, start: int, rng: np.random.Generator, poor: bool = False) -> Demo:
        """The expert's executed demo from evaluation start ``start``; ``data`` holds its arrays
        (``features``, ``qpos``, ``qvel``, ``controls``, ``intended``, ``executed``)."""
        if self.expert is None:
            raise RuntimeError("this SceneDomain has no expert; build it with make_scene_domain")
        demo = self.expert.demonstrate(self.scene.starts[start], self.true_weights, rng, poor=poor)
        data = {name: getattr(demo, name) for name in
                ("features", "qpos", "qvel", "controls", "intended", "executed")}
        return Demo(start=start, poor=poor, data=data)

    def log_likelihood(self, weights: np.ndarray, demos: list[Demo], beta: float) -> np.ndarray:
        raise NotImplementedError("the trajectory-level likelihood arrives with issue #5")


def draw_true_weights(rng: np.random.Generator, k: int) -> np.ndarray:
    """Hidden weights ``w*``: uniform on the all-negative part of the unit sphere (every feature a cost)."""
    return -np.abs(random_unit_vectors(rng, 1, k)[0])


def make_scene_domain(scene_type: type[Scene], params: BaseModel,
                      rng: np.random.Generator) -> SceneDomain:
    """Build a scene instance and wrap it with its expert, drawing both from ``rng``."""
    from mjsuff.experts.generate import EXPERTS  # the experts import the scenes

    scene = scene_type(params, rng)
    expert_type = next(e for s, e in EXPERTS.values() if s is scene_type)
    return SceneDomain(scene, rng, expert=expert_type(scene))
