"""MuJoCo scenes behind the Domain seam: trajectory likelihood, planned policies, library-based V*.

A policy is the planner's knots from every evaluation start (``(S, K, nu)``); its feature
expectations are the features of those simulated trajectories (the simulation is deterministic).

Likelihood (DESIGN, trajectory-level Bayesian IRL). Demo ``j`` from start ``s_j`` with features
``φ_j`` has ``P(φ_j | w) = exp(β w·φ_j) / Σ_{τ ∈ C_j} exp(β w·φ(τ))`` over a candidate set ``C_j``
fixed when the demo is first seen: the demo itself; the library's best trajectory from ``s_j`` for
each of a fixed spread of reward directions over the whole sphere (library optima: plans,
refinements, or random trajectories); uniform-random
trajectories from ``s_j``; and the demo's own controls under smooth perturbations of a few sizes,
simulated. The perturbations matter: the planner's control splines cannot express everything a
demonstrator does, so against planner trajectories alone the likelihood would favour whatever
directions the demo happens to beat the planner in most; against its own neighbours it favours the
directions under which the demo is locally optimal. A batch of weights costs one matrix product and
a log-sum-exp per demo.

``optimal_start_values`` answers ``V*_w(s)`` for many reward vectors at once from the per-start
trajectory library (plans, candidates, random trajectories and the demos themselves), then refines
where it can matter: weights are grouped by the library trajectory that is best for them, and each
group is re-planned (warm-started from that trajectory, with a short budget) for the group's mean
direction; everything simulated joins the library, and the answer is the library maximum again,
so it never drops below it. Ground truth plans ``w*`` with a larger budget.
"""

from __future__ import annotations

import copy
import zlib
from typing import TYPE_CHECKING

import numpy as np
from pydantic import BaseModel
from scipy.special import logsumexp

from mjsuff.domain import Demo, Domain
from mjsuff.scenes.library import TrajectoryLibrary
from mjsuff.scenes.planner import SamplingPlanner
from mjsuff.scenes.planning import PlanningSettings
from mjsuff.scenes.scene import Scene
from mjsuff.sphere import normalize, random_unit_vectors

if TYPE_CHECKING:
    from mjsuff.experiment.scenario import Scenario
    from mjsuff.experts.expert import Expert

#: Uniform-random trajectories per start that estimate the random policy's features.
RANDOM_TRAJECTORIES = 64
#: Reward directions (fixed, spread over the whole sphere) whose library optimum joins a demo's
#: candidate set, and how many of the start's random trajectories join it too.
CANDIDATE_DIRECTIONS = 64
CANDIDATE_RANDOM = 16
#: Perturbed copies of a demo's controls per size; sizes as shares of the control range.
PERTURBATIONS = 16
PERTURBATION_SIZES = (0.02, 0.05, 0.1, 0.2)


class SceneDomain(Domain):
    """A MuJoCo scene instance as a Domain.

    Args:
        scene: The randomized scene instance.
        rng: Randomness of the hidden weights, the random policy and planning.
        planning: Budgets (``mjsuff.scenes.planning``): π for a reward vector; one refinement
            in ``optimal_start_values``, the most weight groups refined per start and round, the
            rounds per call (groups are formed anew each round), and the cosine within which a
            direction already refined from a start is not refined again (its optimum is in the
            library already); random all-negative reward directions
            planned from every start when the instance is built, so the library holds each
            mode's optimum, and their budget; the ground-truth budget.
        expert: The kinesthetic demonstrator (``mjsuff.experts``); without one, ``demonstrate``
            raises.
        unchanged_tolerance: Two policies count as the same when, from every evaluation start,
            their trajectories' features differ by at most this (largest absolute difference,
            in feature units).
        match_tolerance: A policy matches a demo when its trajectory from the demo's start has
            features within this of the demo's (same measure).
        optimal_gap: A policy's trajectory from a start counts as optimal under ``w*`` when its
            value is within this share of ``V*(s) − V_rand(s)`` of the optimum.
    """

    def __init__(self, scene: Scene, rng: np.random.Generator,
                 planning: PlanningSettings | None = None, expert: Expert | None = None,
                 unchanged_tolerance: float = 0.05,
                 match_tolerance: float = 0.1, optimal_gap: float = 0.05) -> None:
        self.scene = scene
        self.expert = expert
        self.rng = rng
        self.num_features = scene.num_features
        self.true_weights = draw_true_weights(rng, scene.num_features)
        s = len(scene.starts)
        self.start_weights = np.full(s, 1.0 / s)
        self.pool = np.arange(s)
        self.library = TrajectoryLibrary(s, scene.num_features, scene.spline.shape)
        planning = planning or PlanningSettings()
        self.planning = planning
        self.planner = SamplingPlanner(scene, planning.planner or scene.planner_config, self.library)
        self.refiner = SamplingPlanner(scene, planning.refine or scene.refine_config, self.library)
        self._refined = [np.empty((0, scene.num_features)) for _ in range(s)]
        self.unchanged_tolerance = unchanged_tolerance
        self.match_tolerance = match_tolerance
        self.optimal_gap = optimal_gap
        knots = scene.spline.uniform(rng, RANDOM_TRAJECTORIES * s)
        _, feats = scene.simulate(np.repeat(scene.starts, RANDOM_TRAJECTORIES, axis=0), knots)
        feats = feats.reshape(s, RANDOM_TRAJECTORIES, -1)
        for i in range(s):
            self.library.add(i, feats[i], knots.reshape(s, RANDOM_TRAJECTORIES, *scene.spline.shape)[i])
        self._random_features = feats
        dead = np.flatnonzero(~np.isfinite(feats).all(axis=2).any(axis=1))
        if dead.size:
            raise RuntimeError(f"every random rollout from evaluation start {int(dead[0])} "
                               "diverged; the scene or its control range is broken")
        self._random_mu = np.nanmean(feats, axis=1)
        _, self._baseline_mu = scene.simulate(scene.starts, scene.baseline_knots())
        if planning.seed_directions:
            seeder = SamplingPlanner(scene, planning.seed_planner, self.library)
            directions = -np.abs(random_unit_vectors(rng, planning.seed_directions,
                                                     scene.num_features))
            starts = np.repeat(np.arange(s), planning.seed_directions)
            seeder.plan(starts, np.tile(directions, (s, 1)), rng)
        # Fixed, instance-independent directions: they must not draw from the instance's stream.
        self._directions = random_unit_vectors(np.random.default_rng(0), CANDIDATE_DIRECTIONS,
                                               scene.num_features)
        self._candidates: dict[bytes, np.ndarray] = {}
        self._features: dict[bytes, np.ndarray] = {}
        self._truth: np.ndarray | None = None
        # Ground truth gets its own randomness, so computing it changes nothing the learner sees.
        self._truth_seed = int(rng.integers(2**63))

    def simulation_stats(self) -> dict[str, int]:
        """MuJoCo steps simulated and rollouts flagged as diverged (never scored) so far."""
        sim = self.scene.simulator
        return {"simulated_steps": sim.steps_simulated, "diverged_rollouts": sim.diverged}

    def configure(self, scenario: Scenario) -> None:
        """Take the scenario's expert settings and trajectory tolerances (``[expert]``, ``[rules]``)."""
        from mjsuff.experts.generate import EXPERTS

        if self.expert is not None:
            self.expert = EXPERTS[scenario.domain.name][1](self.scene, scenario.expert)
        self.unchanged_tolerance = scenario.rules.unchanged_tolerance
        self.match_tolerance = scenario.rules.match_tolerance

    # -- robot side ---------------------------------------------------------------------------
    def plan(self, w: np.ndarray) -> np.ndarray:
        """Planned knots ``(S, K, nu)`` from every evaluation start for reward weights ``w``."""
        return self._plan(self.planner, w)

    def _plan(self, planner: SamplingPlanner, w: np.ndarray) -> np.ndarray:
        starts = np.arange(len(self.scene.starts))
        weights = np.broadcast_to(np.asarray(w, dtype=float), (len(starts), self.num_features))
        best = [self.library.best(s, weights[:1])[1][0] for s in starts]
        if min(best) < 0:
            raise RuntimeError(f"no valid trajectory from evaluation start {best.index(-1)} "
                               "to warm-start from (every rollout diverged)")
        warm = np.stack([self.library.arrays(s)[1][j] for s, j in zip(starts, best, strict=True)])
        return planner.plan(starts, weights, self.rng, warm_knots=warm).knots

    def start_feature_expectations(self, policy: np.ndarray) -> np.ndarray:
        key = self.policy_key(policy)
        if key not in self._features:
            _, features = self.scene.simulate(self.scene.starts, policy)
            self._features[key] = features
        return self._features[key]

    def optimal_start_values(self, weights: np.ndarray, refine: bool = True) -> np.ndarray:
        weights = np.atleast_2d(weights)
        n, s = len(weights), len(self.scene.starts)
        for _ in range(self.planning.refine_rounds if refine else 0):
            problems, groups = [], []
            for start in range(s):
                _, best = self.library.best(start, weights)
                index, counts = np.unique(best, return_counts=True)
                for j in index[np.argsort(-counts, kind="stable")][: self.planning.refine_groups]:
                    direction = normalize(weights[best == j].mean(axis=0))
                    done = self._refined[start]
                    if len(done) and (done @ direction).max() >= self.planning.revisit_cosine:
                        continue
                    problems.append((start, j))
                    groups.append(direction)
                    self._refined[start] = np.concatenate([done, direction[None]])
            if not problems:
                break
            starts = np.array([p[0] for p in problems])
            warm = np.stack([self.library.arrays(st)[1][j] for st, j in problems])
            self.refiner.plan(starts, np.array(groups), self.rng, warm_knots=warm)
        out = np.empty((n, s))
        for start in range(s):
            out[:, start] = self.library.best_value(start, weights)
        return out

    def true_optimal_start_values(self) -> np.ndarray:
        """``V*_{w*}(s)`` per evaluation start ``(S,)``, computed once.

        On a *copy* of the library, with randomness of its own (nothing of ``w*`` reaches the
        learner's library, warm starts or refinement record): ``w*`` planned from every start
        with ``truth_scale`` times the planner's population and refined, and, when there is an
        expert, its best demo from every start (it can beat the planner's splines). The
        library maximum under ``w*`` then.
        """
        if self._truth is None:
            rng = np.random.default_rng(self._truth_seed)
            library = copy.deepcopy(self.library)
            starts = np.arange(len(self.scene.starts))
            w = np.tile(self.true_weights, (len(starts), 1))
            warm = np.stack([library.arrays(s)[1][library.best(s, w[:1])[1][0]] for s in starts])
            plans = SamplingPlanner(self.scene, self.planner.config.scaled(self.planning.truth_scale),
                               library).plan(starts, w, rng, warm_knots=warm)
            SamplingPlanner(self.scene, self.refiner.config, library).plan(
                starts, w, rng, warm_knots=plans.knots)
            if self.expert is not None:
                best = type(self.expert)(self.scene, self.expert.settings.model_copy(
                    update={"rationality": None}))
                for s in starts:
                    demo = best.demonstrate(self.scene.starts[s], self.true_weights, rng)
                    library.add_features(int(s), demo.features)
            self._truth = np.array([library.best_value(int(s), w[:1])[0] for s in starts])
        return self._truth

    def random_start_feature_expectations(self) -> np.ndarray:
        return self._random_mu

    def baseline_start_feature_expectations(self) -> np.ndarray:
        return self._baseline_mu

    # -- baselines and ground truth -----------------------------------------------------------
    def same_policy(self, a: np.ndarray, b: np.ndarray) -> bool:
        """Unchanged: features within ``unchanged_tolerance`` from every evaluation start."""
        diff = self.start_feature_expectations(a) - self.start_feature_expectations(b)
        return bool(np.all(np.abs(diff) <= self.unchanged_tolerance))

    def agrees_with_demo(self, policy: np.ndarray, demo: Demo) -> bool:
        """Matches: the policy's features from the demo's start within ``match_tolerance``."""
        mine = self.start_feature_expectations(policy)[demo.start]
        return bool(np.all(np.abs(mine - demo.data["features"]) <= self.match_tolerance))

    def policy_optimality(self, policy: np.ndarray) -> float:
        """Share of evaluation starts whose trajectory is within ``optimal_gap`` of ``V*_{w*}(s)``
        (in units of ``V*(s) − V_rand(s)``)."""
        w = self.true_weights
        best = self.true_optimal_start_values()
        value = self.start_feature_expectations(policy) @ w
        scale = np.maximum(best - self._random_mu @ w, 1e-12)
        return float(np.mean(best - value <= self.optimal_gap * scale))

    # -- expert and likelihood ----------------------------------------------------------------
    def demonstrate(self, start: int, rng: np.random.Generator, poor: bool = False) -> Demo:
        """The expert's executed demo from evaluation start ``start``; ``data`` holds its arrays
        (``features``, ``qpos``, ``qvel``, ``controls``, ``intended``, ``executed``)."""
        if self.expert is None:
            raise RuntimeError("this SceneDomain has no expert; build it with make_scene_domain")
        demo = self.expert.demonstrate(self.scene.starts[start], self.true_weights, rng, poor=poor)
        data = {name: getattr(demo, name) for name in
                ("features", "qpos", "qvel", "controls", "intended", "executed")}
        return Demo(start=start, poor=poor, data=data)

    def candidate_features(self, demo: Demo) -> np.ndarray:
        """The features ``(M, k)`` of demo's candidate set ``C_j``, the demo first.

        Fixed the first time the demo is seen, when the demo also joins its start's library.
        """
        phi = np.asarray(demo.data["features"], dtype=float)
        key = np.int64(demo.start).tobytes() + phi.tobytes()
        if key not in self._candidates:
            if phi.shape != (self.num_features,) or not np.isfinite(phi).all():
                raise ValueError(f"demo from start {demo.start}: features must be "
                                 f"{self.num_features} finite numbers, got {phi}")
            s = demo.start
            features, _ = self.library.arrays(s)
            best = np.unique(self.library.best(s, self._directions)[1])
            randoms = self._random_features[s, :CANDIDATE_RANDOM]
            parts = [phi[None], features[best], randoms[np.isfinite(randoms).all(axis=1)]]
            if "controls" in demo.data:
                near = self._perturbed(s, np.asarray(demo.data["controls"], dtype=float),
                                       np.random.default_rng(zlib.crc32(key)))
                parts.append(near)
                self.library.add_features(s, near)
            self._candidates[key] = np.concatenate(parts)
            self.library.add_features(s, phi)
        return self._candidates[key]

    def alternatives_better(self, demo: Demo, w: np.ndarray) -> int:
        """Members of the demo's candidate set worth more than the demo under ``w`` (ties excluded)."""
        values = self.candidate_features(demo) @ np.asarray(w, dtype=float)
        return int(np.sum(values[1:] > values[0] + 1e-12))

    def _perturbed(self, start: int, controls: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Features of ``controls`` ``(T, nu)`` plus smooth random offsets (zero at t = 0, hat
        functions over the spline's knots), simulated from ``start``; diverged ones dropped."""
        spline = self.scene.spline
        knots = spline.num_knots + 1
        basis = np.clip(1.0 - np.abs(np.linspace(0, 1, len(controls))[:, None]
                                     - np.linspace(0, 1, knots)[None, :]) * (knots - 1), 0.0, None)
        sizes = np.repeat(PERTURBATION_SIZES, PERTURBATIONS)
        noise = rng.standard_normal((len(sizes), knots, spline.num_controls))
        noise[:, 0] = 0.0
        offsets = np.einsum("tk,bku->btu", basis, noise * sizes[:, None, None])
        low = np.minimum(spline.low, controls.min(axis=0))
        high = np.maximum(spline.high, controls.max(axis=0))
        batch = np.clip(controls + offsets * (spline.high - spline.low), low, high)
        _, features = self.scene.simulate_controls(
            np.repeat(self.scene.starts[start][None], len(batch), axis=0), batch)
        return features[np.isfinite(features).all(axis=1)]

    def log_likelihood(self, weights: np.ndarray, demos: list[Demo], beta: float) -> np.ndarray:
        """``Σ_j log P(φ_j | w)`` for weights ``(N, k)`` -> ``(N,)`` (see the module docstring)."""
        weights = np.atleast_2d(weights)
        total = np.zeros(len(weights))
        for demo in demos:
            values = beta * (weights @ self.candidate_features(demo).T)
            total += values[:, 0] - logsumexp(values, axis=1)
        return total


def draw_true_weights(rng: np.random.Generator, k: int) -> np.ndarray:
    """Hidden weights ``w*``: uniform on the all-negative part of the unit sphere (every feature a cost)."""
    return -np.abs(random_unit_vectors(rng, 1, k)[0])


def make_scene_domain(scene_type: type[Scene], params: BaseModel,
                      rng: np.random.Generator) -> SceneDomain:
    """Build a scene instance and wrap it with its expert, drawing both from ``rng``."""
    from mjsuff.experts.generate import EXPERTS  # the experts import the scenes

    scene = scene_type(params, rng)
    expert_type = next(e for s, e in EXPERTS.values() if s is scene_type)
    return SceneDomain(scene, rng, planning=getattr(params, "planning", None),
                       expert=expert_type(scene))
