"""``V*_w(s)`` for many reward vectors at once, from a trajectory library, refined where the bound
is decided.

The library's best value under ``w`` (every trajectory simulated from a start: plans,
refinements, candidates, random and seed trajectories, demos) is a lower bound on ``V*_w(s)`` that
costs one matrix product. Given the robot's policy, effort goes where the bound is decided:

1. the samples in the upper ``tail_share`` of nEVD are grouped by the library trajectory that is
   best for them, and each group is re-planned from it (warm-started, the refiner's budget) for the
   group's mean direction, for ``refine_rounds`` rounds;
2. the ``plan_samples`` samples that can move the bound (the one at the order statistic the bound
   takes and those next below it; the ones above it stay above it however much they rise) are each
   planned by themselves with π's budget (or ``planning.decisive``'s) from every evaluation start,
   and a second time from the same warm start when ``planning.decisive_second`` is set;
3. for every tail sample, the local quadratic model proposes where its own optimum is, in
   ``polish_rounds`` rounds, and up to ``polish_extra_rounds`` more while a round still raises
   some tail sample's ``V*`` by more than ``polish_extra_gain`` of its ``V* − V_rand``.

Everything simulated joins the library, and the answer is the library maximum again, so it never
drops. A (sample, start) within ``revisit_cosine`` of a direction already refined or planned there
is not searched again.
"""

from __future__ import annotations

import numpy as np

from mjsuff.bounds.regret import normalized_evd
from mjsuff.domain import BoundIndex
from mjsuff.scenes.library import TrajectoryLibrary
from mjsuff.scenes.planner import SamplingPlanner
from mjsuff.scenes.planning import PlanningSettings
from mjsuff.scenes.scene import Scene
from mjsuff.scenes.search import library_warm, polish_library
from mjsuff.sphere import near_any, normalize


class LibraryVStar:
    """V* of a scene instance's evaluation starts from its trajectory library (module docs).

    Args:
        scene: The instance.
        library: Its trajectory library (evaluation starts first, then the pool); searches add to it.
        planner: The ``plan_samples`` stage's planner (π's, unless ``planning.decisive``).
        refiner: The short warm-started planner of the refinement rounds.
        planning: The budgets (``refine_rounds``, ``refine_groups``, ``tail_share``,
            ``plan_samples``, ``polish_rounds``, ``polish_extra_rounds``, ``polish_extra_gain``,
            ``polish_neighbours``, ``revisit_cosine``).
        start_weights: The evaluation starts' weights ``(S,)`` in a policy's value.
        random_mu: The random policy's feature expectations ``(S, k)`` (nEVD's denominator).
        rng: Randomness of the searches.
        second: The planner of a second search of each ``plan_samples`` problem from the same
            warm start (``planning.decisive_second``); None: none.
    """

    def __init__(
        self,
        scene: Scene,
        library: TrajectoryLibrary,
        planner: SamplingPlanner,
        refiner: SamplingPlanner,
        planning: PlanningSettings,
        start_weights: np.ndarray,
        random_mu: np.ndarray,
        rng: np.random.Generator,
        second: SamplingPlanner | None = None,
    ) -> None:
        self.scene, self.library, self.planner, self.refiner = scene, library, planner, refiner
        self.second = second
        self.planning, self.start_weights, self.random_mu, self.rng = planning, start_weights, random_mu, rng
        #: Per library start, the directions ``(m, k)`` refined or planned from it so far.
        self.refined = [np.empty((0, scene.num_features)) for _ in range(len(scene.all_starts))]
        #: Extra polish rounds run so far (``polish_extra_rounds``).
        self.extra_polish_rounds = 0

    def start_values(
        self,
        weights: np.ndarray,
        robot: np.ndarray | None = None,
        bound_index: BoundIndex | None = None,
        refine: bool = True,
    ) -> np.ndarray:
        """``V*_w(s)`` ``(N, S)`` at the evaluation starts: the library's best, refined.

        Args:
            robot: The robot policy's feature expectations ``(S, k)``: refinement goes to the
                samples in the upper ``tail_share`` of nEVD against it. None: to every sample.
            bound_index: Which order statistic of nEVD the bound takes: ``plan_samples`` plans
                the samples from it downwards. None: the largest (the top samples).
            refine: False returns the library's best alone.
        """
        weights = np.atleast_2d(weights)
        s = len(self.scene.starts)
        for _ in range(self.planning.refine_rounds if refine else 0):
            if not self.refine_round(weights[self.tail(weights, robot)], range(s)):
                break
        if refine and self.planning.plan_samples:
            self.plan_decisive(weights, robot, bound_index)
        if refine:
            self.polish(weights, robot)
        return self.library_values(weights, range(s))

    def polish(self, weights: np.ndarray, robot: np.ndarray | None) -> None:
        """``polish_rounds`` rounds of the local quadratic model for the nEVD tail's samples from
        every evaluation start, then up to ``polish_extra_rounds`` more while the round before
        raised some (sample, start)'s ``V*`` by more than ``polish_extra_gain`` of its
        ``V* − V_rand`` (the tail is ranked again before each round)."""
        p, s = self.planning, len(self.scene.starts)
        gain = np.inf  # the round before's largest raise, in units of V* − V_rand
        for r in range(p.polish_rounds + p.polish_extra_rounds):
            if r >= p.polish_rounds:
                if gain <= p.polish_extra_gain:
                    break
                self.extra_polish_rounds += 1
            focus = weights[self.tail(weights, robot)]
            before = self.library_values(focus, range(s)) if p.polish_extra_rounds else None
            polish_library(
                self.scene,
                self.library,
                np.repeat(np.arange(s), len(focus)),
                np.tile(focus, (s, 1)),
                1,
                p.polish_neighbours,
            )
            if before is not None:
                after = self.library_values(focus, range(s))
                gain = np.max((after - before) / np.maximum(after - focus @ self.random_mu.T, 1e-12))

    def library_values(self, weights: np.ndarray, starts) -> np.ndarray:
        """The library's best value ``(N, len(starts))`` under each of ``weights`` ``(N, k)``."""
        return np.stack([self.library.best_value(int(s), weights) for s in starts], axis=1)

    def tail(self, weights: np.ndarray, robot: np.ndarray | None, count: int | None = None) -> np.ndarray:
        """Indices of the ``count`` samples (default: the upper ``tail_share``) with the largest
        nEVD against the robot's feature expectations ``robot`` by the library's values now (all
        samples without a robot)."""
        n = len(weights)
        if robot is None or n == 1:
            return np.arange(n)
        if count is None:
            count = max(1, int(np.ceil(self.planning.tail_share * n)))
        return np.argsort(-self.nevd(weights, robot), kind="stable")[:count]

    def nevd(self, weights: np.ndarray, robot: np.ndarray) -> np.ndarray:
        """Per-sample nEVD ``(N,)`` of the robot's feature expectations by the library's values now."""
        sw = self.start_weights
        v_opt = self.library_values(weights, range(len(self.scene.starts))) @ sw
        return normalized_evd(v_opt, weights @ (sw @ robot), weights @ (sw @ self.random_mu))

    def plan_decisive(
        self, weights: np.ndarray, robot: np.ndarray | None, bound_index: BoundIndex | None
    ) -> None:
        """Plan the ``plan_samples`` samples that can move the bound (:meth:`plan_samples`).

        A planned sample's ``V*`` can only rise, and so its nEVD. The bound is the ``j``-th order
        statistic of nEVD: samples ranked above it stay above it however much they rise, so they
        cannot move it; the ones that can are the one at it and those below it, whose ``V*`` may
        be underestimated by more than their distance to it. So the planned samples are the one
        at the order statistic and those next below it, by the library's values now (issue #17:
        at the same cost, the decisive samples' ``V*`` misses a 10×-budget plan by a max of
        3.85% instead of 14.46% when the top samples are planned). Without a robot to rank by,
        every sample (as every sample is refined then).
        """
        n, count = len(weights), self.planning.plan_samples
        if robot is None or n == 1:
            self.plan_samples(weights)
            return
        nevd = self.nevd(weights, robot)
        rank = n - 1 - (bound_index(nevd) if bound_index is not None else n - 1)
        self.plan_samples(weights[np.argsort(-nevd, kind="stable")[rank : rank + count]])

    def plan_samples(self, weights: np.ndarray) -> None:
        """Plan each of ``weights`` from every evaluation start with the stage's planner (and the
        second search's, when set), warm-started from the library, into the library; a (sample,
        start) within ``revisit_cosine`` of a direction already refined or planned there is
        skipped."""
        problems, directions = [], []
        for start in range(len(self.scene.starts)):
            for direction in normalize(weights):
                if self.claim(start, direction):
                    problems.append(start)
                    directions.append(direction)
        if problems:
            starts, directions_ = np.array(problems), np.array(directions)
            warm = library_warm(self.library, starts, directions_)
            self.planner.plan(starts, directions_, self.rng, warm_knots=warm)
            if self.second is not None:
                self.second.plan(starts, directions_, self.rng, warm_knots=warm)

    def claim(self, start: int, direction: np.ndarray) -> bool:
        """Record ``direction`` as refined or planned from ``start``; False, recording nothing,
        when one within ``revisit_cosine`` of it already is."""
        done = self.refined[start]
        if near_any(done, direction, self.planning.revisit_cosine):
            return False
        self.refined[start] = np.concatenate([done, direction[None]])
        return True

    def refine_round(self, weights: np.ndarray, starts) -> bool:
        """One refinement round for ``weights`` from ``starts``; False when nothing was new."""
        problems, groups = [], []
        for start in starts:
            _, best = self.library.best(start, weights)
            index, counts = np.unique(best, return_counts=True)
            for j in index[np.argsort(-counts, kind="stable")][: self.planning.refine_groups]:
                direction = normalize(weights[best == j].mean(axis=0))
                if self.claim(start, direction):
                    problems.append((start, j))
                    groups.append(direction)
        if not problems:
            return False
        starts_ = np.array([p[0] for p in problems])
        warm = np.stack([self.library.arrays(st)[1][j] for st, j in problems])
        self.refiner.plan(starts_, np.array(groups), self.rng, warm_knots=warm)
        return True
