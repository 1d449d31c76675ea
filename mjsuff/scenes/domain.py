"""MuJoCo scenes behind the Domain seam: trajectory likelihood, planned policies, library-based V*.

A policy is the planner's knots from every evaluation start (``(S, K, nu)``); its feature
expectations are the features of those simulated trajectories (the simulation is deterministic).
Demonstrations come from a separate pool of starts (``Scene.pool_starts``): a policy is judged
where it was never shown. Planners and the trajectory library index the evaluation starts first,
then the pool (``Scene.all_starts``).

Prior (the learner's, and the one ``w*`` is drawn from): uniform on the all-negative orthant of
the sphere. Every scene feature is a cost by construction (distance, lava, motion; landing error,
impact, fuel, tilt), so a learner that knows its features knows the signs; ``V*`` then only has
to be right on that orthant, and the library is seeded there.

Random policy (the nEVD denominator's ``V_rand``): random goal-directed paths of the
demonstrator's own family (``Expert.random_params``: any detour, any pace, ending at the goal;
``RANDOM_PATHS`` per evaluation start, executed by the expert when the instance is built);
``μ_rand`` is their mean features per evaluation start. Like the paper's Lavaworld random policy
(random paths that end at the goal), these are purposeful motions, so ``V* − V_rand`` is on the
scale of the mistakes a wrong reward causes. (Uniform-random splines would be aimless: their gap is
so large that any purposeful policy scores a tiny nEVD.) The library is seeded with the expert's
primitives (its path family fitted to the robot's knots) and the scene's own
(``Scene.primitive_knots``: the reacher's straight joint-space moves toward goal postures) from
every start, and with plans of ``seed_directions`` prior draws (a wide search), so it holds each
mode's optimum before the first demo; with ``planning.seed_zeroed``, also with a plan of each
named feature's zone-free direction (that weight 0, every other equal), the route a reward that
ignores the feature takes.

Likelihood (DESIGN, trajectory-level Bayesian IRL): a Boltzmann choice of each demo among its
candidate set (``mjsuff.scenes.candidates``), in ``mjsuff.scenes.likelihood``: a batch of weights
costs one matrix product and a log-sum-exp per demo.

``optimal_start_values`` is the library's best, refined where the bound is decided
(``mjsuff.scenes.vstar``); plans (π for a reward) are polished by the local quadratic model for
their reward (``mjsuff.scenes.search``); ground truth is planned harder, on a copy of the library
(``mjsuff.scenes.truth``), and the replicate raises it to the best of everything it simulated
(and, with ``planning.truth_passes``, searches again from there until it settles).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, cast

import numpy as np

from mjsuff.domain import BoundIndex, Demo, Domain, FinalTruth
from mjsuff.scenes.candidates import CandidateSets
from mjsuff.scenes.library import TrajectoryLibrary
from mjsuff.scenes.likelihood import demo_log_likelihoods
from mjsuff.scenes.params import Candidates, SceneParams
from mjsuff.scenes.planner import SamplingPlanner
from mjsuff.scenes.planning import PlanningSettings
from mjsuff.scenes.scene import Scene
from mjsuff.scenes.search import library_warm, polish_library
from mjsuff.scenes.truth import converge_truth, search_truth
from mjsuff.scenes.vstar import LibraryVStar
from mjsuff.sphere import near_any, normalize, random_negative_unit_vectors

if TYPE_CHECKING:
    from mjsuff.experts.expert import Expert

#: Uniform-random trajectories per start: alternatives in the demos' candidate sets.
RANDOM_TRAJECTORIES = 16
#: Random goal-directed paths of the demonstrator's family per evaluation start (the random policy).
RANDOM_PATHS = 16
#: Most rounds of ``RANDOM_PATHS`` draws until that many paths could be executed.
RANDOM_PATH_ROUNDS = 8


def draw_true_weights(rng: np.random.Generator, k: int) -> np.ndarray:
    """Hidden weights ``w*``: a draw from the prior (uniform on the all-negative orthant)."""
    return sample_orthant(rng, 1, k)[0]


def sample_orthant(rng: np.random.Generator, count: int, k: int) -> np.ndarray:
    """``count`` draws ``(count, k)`` uniform on the all-negative orthant of the unit sphere."""
    return random_negative_unit_vectors(rng, count, k)


class SceneDomain(Domain):
    """A MuJoCo scene instance as a Domain.

    Args:
        scene: The randomized scene instance.
        true_weights: Its hidden weights ``w*`` ``(k,)`` (``draw_instance`` draws both).
        rng: Randomness of the random policy and planning.
        planning: Budgets (``mjsuff.scenes.planning``): π for a reward vector; one refinement
            in ``optimal_start_values``, the most weight groups refined per start and round, the
            rounds per call, the share of nEVD's upper tail that is refined, and the cosine within
            which a direction already refined from a start is not refined again; the prior
            directions planned from every start when the instance is built (the random policy,
            and the library's seed) and their budget; the ground-truth budget.
        expert: The kinesthetic demonstrator (``mjsuff.experts``); without one, ``demonstrate``
            raises.
        unchanged_tolerance: Two policies count as the same when, from every evaluation start,
            their trajectories' features differ by at most this (largest absolute difference,
            in feature units).
        match_tolerance: A policy matches a demo when its trajectory from the demo's start has
            features within this of the demo's (same measure).
        candidates: What a demo is compared with in the likelihood (module docs): ``"library"``
            or ``"family"``.
        optimal_gap: A policy's trajectory from a start counts as optimal under ``w*`` when its
            value is within this share of ``V*(s) − V_rand(s)`` of the optimum.
    """

    def __init__(
        self,
        scene: Scene,
        true_weights: np.ndarray,
        rng: np.random.Generator,
        planning: PlanningSettings | None = None,
        expert: Expert | None = None,
        unchanged_tolerance: float = 0.05,
        match_tolerance: float = 0.1,
        optimal_gap: float = 0.05,
        candidates: Candidates = "library",
    ) -> None:
        if expert is None:
            raise ValueError(
                "a SceneDomain needs its expert: the random policy is random paths "
                "of the demonstrator's family (build it with make_scene_domain)"
            )
        planning = planning or PlanningSettings()
        if planning.seed_directions < 1:
            raise ValueError(
                "planning.seed_directions: the random policy plans prior draws; at least 1 is needed"
            )
        planning.check_seed_zeroed(scene.feature_names)
        self.scene = scene
        self.expert = expert
        self.rng = rng
        k = self.num_features = scene.num_features
        self.true_weights = np.asarray(true_weights, dtype=float)
        s, p = len(scene.starts), len(scene.pool_starts)
        self.start_weights = np.full(s, 1.0 / s)
        self.pool = np.arange(s, s + p)
        self.library = TrajectoryLibrary(s + p, k, scene.spline.shape)
        self.planning = planning
        self.planner = SamplingPlanner(scene, planning.planner or scene.planner_config, self.library)
        self.refiner = SamplingPlanner(scene, planning.refine or scene.refine_config, self.library)
        self.unchanged_tolerance = unchanged_tolerance
        self.match_tolerance = match_tolerance
        self.optimal_gap = optimal_gap
        self.candidates = candidates
        # The library before the first demo, in this order (each step draws from ``rng`` in turn).
        self._random_features = self._add_uniform_trajectories(rng)
        self.candidate_sets = CandidateSets(scene, self.library, expert, candidates, self._random_features)
        self._add_primitives(expert)
        self._random_mu = self._random_policy(expert, rng)
        decisive = self.planner  # the plan_samples stage's planner: π's unless planning.decisive
        if planning.decisive:
            decisive = SamplingPlanner(scene, planning.decisive, self.library)
        second = planning.decisive_second
        self.vstar = LibraryVStar(
            scene,
            self.library,
            decisive,
            self.refiner,
            planning,
            self.start_weights,
            self._random_mu,
            rng,
            SamplingPlanner(scene, second, self.library) if second is not None else None,
        )
        self._add_seed_plans(rng)
        _, self._baseline_mu = scene.simulate(scene.starts, scene.baseline_knots())
        self._features: dict[bytes, np.ndarray] = {}
        self._planned_for: dict[bytes, np.ndarray] = {}
        self._plan_directions = np.empty((0, k))  # the rewards π was planned for, normalized
        self.replans = 0  # of them, planned with the refiner's budget (``replan_cosine``)
        self._pool_plans: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self._truth: np.ndarray | None = None
        self._truth_library: TrajectoryLibrary | None = None
        self._truth_copied: list[int] = []
        self._final_truth: FinalTruth | None = None
        # Ground truth gets its own randomness, so computing it changes nothing the learner sees.
        self._truth_rng = np.random.default_rng(int(rng.integers(2**63)))

    def _add_uniform_trajectories(self, rng: np.random.Generator) -> np.ndarray:
        """``RANDOM_TRAJECTORIES`` uniform splines from every start into the library; their
        features ``(S + P, RANDOM_TRAJECTORIES, k)``."""
        scene, count = self.scene, len(self.scene.all_starts)
        knots = scene.spline.uniform(rng, RANDOM_TRAJECTORIES * count)
        _, feats = scene.simulate(np.repeat(scene.all_starts, RANDOM_TRAJECTORIES, axis=0), knots)
        feats = feats.reshape(count, RANDOM_TRAJECTORIES, self.num_features)
        knots = knots.reshape(count, RANDOM_TRAJECTORIES, *scene.spline.shape)
        for i in range(count):
            self.library.add(i, feats[i], knots[i])
        return feats

    def _add_primitives(self, expert: Expert) -> None:
        """The scene's own reward-agnostic primitives and the demonstrator's path family (where
        it is in the robot's class) from every start into the library."""
        scene = self.scene
        for i, start in enumerate(scene.all_starts):
            knots = scene.primitive_knots(start)
            if len(knots):
                _, feats = scene.simulate(start[None], knots)
                self.library.add(i, feats, knots)
        for i, start in enumerate(scene.all_starts):
            done = expert.executed_primitives(start)
            if done.knots is not None and len(done.knots):
                self.library.add(i, done.features, done.knots)

    def _random_policy(self, expert: Expert, rng: np.random.Generator) -> np.ndarray:
        """The random policy's feature expectations ``(S, k)``: random goal-directed paths of the
        demonstrator's family from each evaluation start (added to the library as well)."""
        scene = self.scene
        random_mu = np.empty((len(scene.starts), self.num_features))
        for i, start in enumerate(scene.starts):
            found: list[np.ndarray] = []
            for _ in range(RANDOM_PATH_ROUNDS):  # paths the expert cannot track are drawn again
                done, _ = expert.execute(start, expert.random_params(start, rng, RANDOM_PATHS))
                if not len(done.params):
                    continue
                if done.knots is not None:
                    self.library.add(i, done.features, done.knots)
                else:
                    self.library.add_features(i, done.features)
                found.extend(done.features[np.isfinite(done.features).all(axis=1)])
                if len(found) >= RANDOM_PATHS:
                    break
            if not found:
                raise RuntimeError(
                    f"no random path from evaluation start {i} could be executed "
                    f"in {RANDOM_PATH_ROUNDS * RANDOM_PATHS} tries"
                )
            random_mu[i] = np.mean(found[:RANDOM_PATHS], axis=0)
        return random_mu

    def _add_seed_plans(self, rng: np.random.Generator) -> None:
        """Prior draws planned from every start, warm-started from the library, so that it holds
        each mode's optimum before the first demo; with ``planning.seed_zeroed``, one more
        direction per named feature: the orthant's centre (every weight equal) with that one's
        zeroed, a reward that trades every other feature evenly and ignores it."""
        scene, count = self.scene, len(self.scene.all_starts)
        directions = sample_orthant(rng, self.planning.seed_directions, self.num_features)
        zeroed = self.planning.seed_zeroed
        if zeroed:
            ignoring = np.full((len(zeroed), self.num_features), -1.0)
            for row, name in zip(ignoring, zeroed, strict=True):
                row[scene.feature_names.index(name)] = 0.0
            directions = np.concatenate([directions, normalize(ignoring)])
        problems = np.repeat(np.arange(count), len(directions))
        tiled = np.tile(directions, (count, 1))
        warm = library_warm(self.library, problems, tiled)
        planner = SamplingPlanner(scene, self.planning.seed_planner or scene.seed_config, self.library)
        seeds = planner.plan(problems, tiled, rng, warm_knots=warm)
        if not np.isfinite(seeds.features).all():
            raise RuntimeError(
                "a seed plan diverged in every rollout; the scene or its control range is broken"
            )

    def simulation_stats(self) -> dict[str, int]:
        """MuJoCo steps simulated and rollouts flagged as diverged (never scored) so far."""
        sim = self.scene.simulator
        return {"simulated_steps": sim.steps_simulated, "diverged_rollouts": sim.diverged}

    # -- prior ---------------------------------------------------------------------------------
    uniform_prior = False

    def log_prior(self, weights: np.ndarray) -> np.ndarray:
        """0 on the all-negative orthant, −inf elsewhere (module docs)."""
        return np.where((np.atleast_2d(weights) <= 0.0).all(axis=1), 0.0, -np.inf)

    def sample_prior(self, rng: np.random.Generator, count: int) -> np.ndarray:
        return sample_orthant(rng, count, self.num_features)

    # -- robot side ---------------------------------------------------------------------------
    def plan(self, w: np.ndarray) -> np.ndarray:
        """Planned knots ``(S, K, nu)`` from every evaluation start for reward weights ``w``.

        With ``planning.replan_cosine`` set, a ``w`` within that cosine of any reward planned for
        earlier on this domain (every earlier MAP, full or held-out, whichever budget planned it)
        is planned with the refiner's budget: its warm start, the library's best under ``w``,
        already holds the earlier plan. Pool plans (:meth:`pool_features`) keep π's budget.
        """
        w = np.asarray(w, dtype=float)
        knots = self._plan(self._planner_for(w), w, np.arange(len(self.scene.starts)))
        self._planned_for[self.policy_key(knots)] = w.copy()
        return knots

    def _planner_for(self, w: np.ndarray) -> SamplingPlanner:
        """π's planner for ``w``, or the refiner when ``w`` is near a reward π was planned for
        (``replan_cosine``); ``w``'s direction is recorded either way."""
        near = self.planning.replan_cosine
        direction = normalize(w)
        earlier = self._plan_directions
        self._plan_directions = np.concatenate([earlier, direction[None]])
        if near is not None and near_any(earlier, direction, near):
            self.replans += 1
            return self.refiner
        return self.planner

    def _plan(self, planner: SamplingPlanner, w: np.ndarray, starts: np.ndarray) -> np.ndarray:
        """Knots planned for ``w`` from library starts ``starts``, warm-started from the library."""
        weights = np.broadcast_to(np.asarray(w, dtype=float), (len(starts), self.num_features))
        warm = library_warm(self.library, starts, weights)
        plans = planner.plan(starts, weights, self.rng, warm_knots=warm).knots
        if not self.planning.polish_rounds:
            return plans
        self._polish(self.library, starts, weights, self.planning.polish_rounds)
        return library_warm(self.library, starts, weights)  # the plan, or better

    def _polish(
        self, library: TrajectoryLibrary, starts: np.ndarray, weights: np.ndarray, rounds: int
    ) -> None:
        """``rounds`` rounds of the local quadratic model for problems ``(starts[j], weights[j])``."""
        polish_library(self.scene, library, starts, weights, rounds, self.planning.polish_neighbours)

    def start_feature_expectations(self, policy: np.ndarray) -> np.ndarray:
        key = self.policy_key(policy)
        if key not in self._features:
            _, features = self.scene.simulate(self.scene.starts, policy)
            self._features[key] = features
        return self._features[key]

    def pool_features(
        self, policy: np.ndarray, entries: Sequence[int] | np.ndarray | None = None
    ) -> np.ndarray:
        """Features ``(P, k)`` of the policy's trajectories from the demonstration pool: π's
        planner (π's budget, whatever budget planned the policy from the evaluation starts) for
        the reward the policy was planned for, from each pool start. Only the pool
        entries in ``entries`` (default: all) are planned, each once per policy (cached); rows of
        entries not yet planned are NaN."""
        key = self.policy_key(policy)
        if key not in self._planned_for:
            raise ValueError("pool_features: the policy was not planned by this domain")
        if key not in self._pool_plans:
            self._pool_plans[key] = (
                np.full((len(self.pool), self.num_features), np.nan),
                np.zeros(len(self.pool), dtype=bool),
            )
        features, planned = self._pool_plans[key]
        wanted = np.arange(len(self.pool)) if entries is None else np.asarray(entries, dtype=int)
        todo = np.unique(wanted[~planned[wanted]])
        if len(todo):
            knots = self._plan(self.planner, self._planned_for[key], self.pool[todo])
            _, features[todo] = self.scene.simulate(self.scene.pool_starts[todo], knots)
            planned[todo] = True
        return features

    def optimal_start_values(
        self,
        weights: np.ndarray,
        robot: np.ndarray | None = None,
        bound_index: BoundIndex | None = None,
        refine: bool = True,
    ) -> np.ndarray:
        """``V*_w(s)`` ``(N, S)`` at the evaluation starts: the library's best, refined where the
        bound is decided (``mjsuff.scenes.vstar``)."""
        return self.vstar.start_values(weights, robot, bound_index, refine)

    def pool_regrets(self, weights: np.ndarray, policy: np.ndarray) -> np.ndarray:
        """Per-sample EVD ``(N, P)`` of ``policy`` (planned by :meth:`plan`) at each pool start
        (Eq. 13's input): the library's best there minus the sample's value of the trajectory
        π's planner makes for the policy's reward from that start (:meth:`pool_features`)."""
        weights = np.atleast_2d(weights)
        mu = self.pool_features(policy)  # first: planning from the pool joins the library
        return self.vstar.library_values(weights, self.pool) - weights @ mu.T

    def true_optimal_start_values(self) -> np.ndarray:
        """``V*_{w*}(s)`` per evaluation start ``(S,)`` before the replicate runs, computed once
        (``mjsuff.scenes.truth``); the replicate raises it when it ends
        (:meth:`final_true_start_values`)."""
        if self._truth is None:
            library = copy.deepcopy(self.library)
            self._truth = search_truth(
                self.scene,
                library,
                self.true_weights,
                self.planner.config,
                self.planning,
                self.expert,
                self._truth_rng,
            )
            if self.planning.truth_passes:  # its plans are where the searches at the end begin
                self._truth_library = library
                self._truth_copied = [self.library.size(s) for s in range(len(self.scene.starts))]
        return self._truth

    def final_true_start_values(self) -> FinalTruth:
        """Ground truth when the replicate ends: the first truth raised to the best of
        everything simulated under ``w*``, then searched again from there until it settles,
        at most ``planning.truth_passes`` times (``mjsuff.scenes.truth.converge_truth``).
        Computed once, at the first call."""
        if self._final_truth is not None:
            return self._final_truth
        truth = self.true_optimal_start_values()
        if self._truth_library is None:  # no searches again
            best = self.best_simulated_start_values(self.true_weights)
            self._final_truth = FinalTruth(np.maximum(truth, best))
            return self._final_truth
        values, passes, gain = converge_truth(
            self.scene,
            self._truth_library,
            self.library,
            self._truth_copied,
            truth,
            self.true_weights,
            self._random_mu @ self.true_weights,
            self.planner.config,
            self.planning,
            self._truth_rng,
        )
        self._final_truth = FinalTruth(values, passes, gain)
        self._truth_library = None  # a copy of the whole library: free it
        return self._final_truth

    def best_simulated_start_values(self, w: np.ndarray) -> np.ndarray:
        """The best value under ``w`` of everything simulated from each evaluation start so far
        ``(S,)`` (the learner's library: plans, refinements, seeds, candidates)."""
        w = np.atleast_2d(np.asarray(w, dtype=float))
        return self.vstar.library_values(w, range(len(self.scene.starts)))[0]

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
        """Matches: the policy's trajectory from the demo's (pool) start has features within
        ``match_tolerance`` of the demo's."""
        mine = self.pool_features(policy, [demo.start])[demo.start]
        return bool(np.all(np.abs(mine - demo.data["features"]) <= self.match_tolerance))

    def policy_optimality(self, policy: np.ndarray, best: np.ndarray | None = None) -> float:
        """Share of evaluation starts whose trajectory is within ``optimal_gap`` of ``V*_{w*}(s)``
        (in units of ``V*(s) − V_rand(s)``); ``best`` replaces the initial truth."""
        w = self.true_weights
        best = self.true_optimal_start_values() if best is None else best
        value = self.start_feature_expectations(policy) @ w
        scale = np.maximum(best - self._random_mu @ w, 1e-12)
        return float(np.mean(best - value <= self.optimal_gap * scale))

    # -- expert and likelihood ----------------------------------------------------------------
    def demonstrate(self, start: int, rng: np.random.Generator, poor: bool = False) -> Demo:
        """The expert's executed demo from pool entry ``start``; ``data`` holds its arrays
        (``features``, ``qpos``, ``qvel``, ``controls``, ``intended``, ``executed``)."""
        if self.expert is None:
            raise RuntimeError("this SceneDomain has no expert; build it with make_scene_domain")
        demo = self.expert.demonstrate(self.scene.pool_starts[start], self.true_weights, rng, poor=poor)
        data = {
            name: getattr(demo, name)
            for name in ("features", "qpos", "qvel", "controls", "intended", "executed")
        }
        return Demo(start=start, poor=poor, data=data)

    def candidate_features(self, demo: Demo) -> np.ndarray:
        """The features ``(M, k)`` of the demo's candidate set ``C_j``, the demo first
        (``mjsuff.scenes.candidates``); fixed the first time the demo is seen, when the demo also
        joins its start's library."""
        return self.candidate_sets.features(demo)

    def alternatives_better(self, demo: Demo, w: np.ndarray) -> int:
        """Members of the demo's candidate set worth more than the demo under ``w`` (ties excluded)."""
        values = self.candidate_features(demo) @ np.asarray(w, dtype=float)
        return int(np.sum(values[1:] > values[0] + 1e-12))

    def demo_log_likelihoods(self, weights: np.ndarray, demos: list[Demo], beta: float) -> np.ndarray:
        """``log P(φ_j | w)`` of each demo for weights ``(N, k)`` -> ``(N, D)``
        (``mjsuff.scenes.likelihood``)."""
        return demo_log_likelihoods(weights, [self.candidate_features(demo) for demo in demos], beta)

    def choice_counts(self, demos: list[Demo]) -> np.ndarray:
        """The size of each demo's candidate set ``C_j``, the demo included."""
        return np.array([len(self.candidate_features(demo)) for demo in demos])


def draw_instance(
    scene_type: type[Scene], params: SceneParams, rng: np.random.Generator, threads: int | None = None
) -> tuple[Scene, np.ndarray]:
    """A scene instance and its hidden weights ``w*``, drawn from ``rng`` in that order: every
    builder of a run's instance (``make_scene_domain``, ``mjsuff demos``, the suite) draws it here."""
    make = cast(Callable[..., Scene], scene_type)  # every scene takes (params, rng, threads)
    scene = make(params, rng, threads)
    return scene, draw_true_weights(rng, scene.num_features)


def make_scene_domain(
    scene_type: type[Scene], expert_type: type[Expert], params: SceneParams, rng: np.random.Generator
) -> SceneDomain:
    """A scene domain instance from ``rng``: the scene, ``w*``, and the expert with its settings."""
    scene, true_weights = draw_instance(scene_type, params, rng)
    return SceneDomain(
        scene,
        true_weights,
        rng,
        planning=params.planning,
        expert=expert_type(scene, params.expert),
        unchanged_tolerance=params.unchanged_tolerance,
        match_tolerance=params.match_tolerance,
        candidates=params.candidates,
    )
