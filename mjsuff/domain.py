"""The Domain seam: the one place where tabular and MuJoCo code differ.

A *domain instance* is one randomized task with hidden true weights ``w*`` (``‖w*‖₂ = 1``). Rewards
are linear in ``k`` features, ``R_w = w·φ``, so the value of any policy under any number of reward
vectors is a matrix product with that policy's feature expectations (``V^π_w = w·μ_π``). Everything
above this interface (posterior sampling, bounds, stopping rules, the experiment loop) is shared.

Values are kept *per evaluation start*: ``μ`` has shape ``(S, k)`` and ``V*`` has shape ``(N, S)``
for ``S`` evaluation starts; the start distribution ``start_weights`` (shape ``(S,)``) averages them.
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mjsuff.posterior.likelihood import lapse_log_likelihood

Policy = Any
"""A domain's robot policy: opaque above the seam (an action per state for tabular domains)."""
BoundIndex = Callable[[np.ndarray], int]
"""Given per-sample nEVD values ``(N,)``, the 0-based index (in ascending order) of the order
statistic the α-VaR bound takes (``mjsuff.bounds.var_bound.var_bound_index`` for their effective
size)."""


@dataclass(frozen=True)
class Demo:
    """One demonstration.

    Attributes:
        start: Index into the domain's demonstration pool (``Domain.pool``).
        action: For state-action demos (tabular), the demonstrated action; ``-1`` otherwise.
        poor: True when the demonstrator deliberately gave a poor demo (noise ablation).
        data: Domain-specific arrays (trajectory states, controls, features, ...).
    """

    start: int
    action: int = -1
    poor: bool = False
    data: dict[str, np.ndarray] = field(default_factory=dict)


#: A search of the truth at the replicate's end that raises no evaluation start by more than this
#: share of its ``V* − V_rand`` leaves it settled (polishing digits, not another basin: a
#: hundredth of the smallest ε a scenario uses, 0.1, even were every start raised by it).
TRUTH_SETTLED = 1e-3


@dataclass(frozen=True, eq=False)
class FinalTruth:
    """Ground truth ``V*_{w*}(s)`` per evaluation start when a replicate ends.

    Attributes:
        values: ``(S,)``; the replicate keeps the larger of these and the truth it began with.
        passes: Searches run again when the replicate ended (0: none).
        last_gain: The last search's largest raise at a start, as a share of that start's
            value before the search minus ``V_rand`` (settled when at most ``TRUTH_SETTLED``).
    """

    values: np.ndarray
    passes: int = 0
    last_gain: float = 0.0


class Domain(abc.ABC):
    """A randomized task instance with linear rewards, seen through feature expectations."""

    #: Number of reward features ``k``.
    num_features: int
    #: Hidden true weights ``w*`` (shape ``(k,)``, unit norm). Used only by the expert and for scoring.
    true_weights: np.ndarray
    #: Probability of each evaluation start (shape ``(S,)``, sums to one).
    start_weights: np.ndarray
    #: The demonstration pool: one index per start a demonstration can be asked from (shape
    #: ``(P,)``; ``Demo.start`` indexes this array). Tabular domains: the evaluation states the
    #: demos start from; the scenes: starts of their own, never evaluated.
    pool: np.ndarray

    @abc.abstractmethod
    def demonstrate(self, start: int, rng: np.random.Generator, poor: bool = False) -> Demo:
        """The expert's demonstration from pool entry ``start`` (a poor one when ``poor``)."""

    @abc.abstractmethod
    def demo_log_likelihoods(self, weights: np.ndarray, demos: list[Demo], beta: float) -> np.ndarray:
        """Boltzmann log-likelihood ``log P_β(d_j | w)`` of each demo (Eq. 1) for a batch ``(N, k)``
        of weights -> ``(N, D)``."""

    @abc.abstractmethod
    def choice_counts(self, demos: list[Demo]) -> np.ndarray:
        """``|C_j|``: how many alternatives (the demo's own included) each demo's Boltzmann term
        normalizes over -> ``(D,)``."""

    def log_likelihood(
        self, weights: np.ndarray, demos: list[Demo], beta: float, lapse: float = 0.0
    ) -> np.ndarray:
        """``log P(D | w)`` for a batch ``(N, k)`` of weights -> ``(N,)``: Boltzmann (Eq. 1) with
        lapse rate ``lapse`` (``mjsuff.posterior.likelihood``; 0 is the paper's likelihood)."""
        per_demo = self.demo_log_likelihoods(np.atleast_2d(weights), demos, beta)
        return lapse_log_likelihood(per_demo, self.choice_counts(demos), lapse)

    @abc.abstractmethod
    def alternatives_better(self, demo: Demo, w: np.ndarray) -> int:
        """How many of the likelihood's alternatives to ``demo`` (other actions, or the demo's
        candidate trajectories) are worth more than the demo under weights ``w`` ``(k,)``."""

    @abc.abstractmethod
    def plan(self, w: np.ndarray) -> Policy:
        """The robot's (optimal) policy for reward weights ``w``."""

    @abc.abstractmethod
    def start_feature_expectations(self, policy: Policy) -> np.ndarray:
        """Discounted feature expectations of ``policy`` from each evaluation start -> ``(S, k)``."""

    @abc.abstractmethod
    def optimal_start_values(
        self, weights: np.ndarray, robot: np.ndarray | None = None, bound_index: BoundIndex | None = None
    ) -> np.ndarray:
        """Optimal values ``V*_w(s)`` for a batch ``(N, k)`` of weights -> ``(N, S)``.

        Must never underestimate the optimum (an underestimate makes the bound optimistic).
        ``robot`` (the robot policy's feature expectations ``(S, k)``) and ``bound_index`` (which
        order statistic of the per-sample nEVD the bound takes, given those values) let an
        approximate domain spend its effort where the nEVD bound is decided; exact domains
        ignore them.
        """

    @abc.abstractmethod
    def pool_regrets(self, weights: np.ndarray, policy: Policy) -> np.ndarray:
        """EVD ``(N, P)`` of the robot's ``policy`` (as planned) at each pool start, per sample
        of ``weights`` ``(N, k)``: ``V*_w(p) − V^π_w(p)`` (active selection, paper Eq. 13)."""

    @abc.abstractmethod
    def random_start_feature_expectations(self) -> np.ndarray:
        """Feature expectations of the random policy (nEVD's ``V_rand``) from each evaluation
        start -> ``(S, k)``: uniform-random for tabular domains; the domain says what it is."""

    @abc.abstractmethod
    def baseline_start_feature_expectations(self) -> np.ndarray:
        """Feature expectations of the baseline policy used by PIOB -> ``(S, k)``."""

    @abc.abstractmethod
    def same_policy(self, a: Policy, b: Policy) -> bool:
        """True when two robot policies count as unchanged (the patience baseline)."""

    @abc.abstractmethod
    def agrees_with_demo(self, policy: Policy, demo: Demo) -> bool:
        """True when ``policy`` matches a held-out demo (the validation-set baseline)."""

    @abc.abstractmethod
    def policy_optimality(self, policy: Policy, best: np.ndarray | None = None) -> float:
        """Ground truth: fraction of decisions of ``policy`` that are optimal under ``w*``;
        ``best`` ``(S,)`` replaces ``true_optimal_start_values`` (raised by the replicate)."""

    #: True when the prior is uniform on the whole sphere (``log_prior`` is 0 everywhere).
    uniform_prior: bool = True

    def log_prior(self, weights: np.ndarray) -> np.ndarray:
        """Log prior density (up to a constant) of weights ``(N, k)`` -> ``(N,)``: uniform on the
        sphere by default (0 everywhere); −inf outside a domain's support."""
        return np.zeros(np.atleast_2d(weights).shape[0])

    def sample_prior(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """``count`` draws ``(count, k)`` from the prior (default: uniform on the sphere)."""
        x = rng.standard_normal((count, self.num_features))
        return x / np.linalg.norm(x, axis=1, keepdims=True)

    def best_simulated_start_values(self, w: np.ndarray) -> np.ndarray:
        """The best value under ``w`` ``(k,)`` of any trajectory the instance has simulated from
        each evaluation start ``(S,)``; −inf where nothing is kept (exact domains)."""
        return np.full(len(self.start_weights), -np.inf)

    def final_true_start_values(self) -> FinalTruth:
        """What raises ground truth when the replicate ends (call it then: a domain may compute
        it once): ``best_simulated_start_values`` under ``w*`` (scenes may search again from
        there, ``planning.truth_passes``). Exact domains: −inf, their truth is never raised."""
        return FinalTruth(self.best_simulated_start_values(self.true_weights))

    def simulation_stats(self) -> dict[str, int]:
        """Counts of the simulation behind this instance so far, for the run's report (the
        scenes: ``simulated_steps``, ``diverged_rollouts``). Nothing for exact domains."""
        return {}

    def true_optimal_start_values(self) -> np.ndarray:
        """Ground truth ``V*_{w*}(s)`` per evaluation start ``(S,)``; domains whose ``V*`` is an
        approximation compute it here with a larger budget."""
        return self.optimal_start_values(self.true_weights[None])[0]

    def policy_key(self, policy: Policy) -> bytes:
        """A hashable identity for caching per-policy results."""
        return np.ascontiguousarray(policy).tobytes()

    def feature_expectations(self, policy: Policy) -> np.ndarray:
        """Feature expectations ``μ_π`` under the start distribution -> ``(k,)``."""
        return self.start_weights @ self.start_feature_expectations(policy)

    def optimal_values(self, weights: np.ndarray) -> np.ndarray:
        """``V*_w`` under the start distribution for a batch ``(N, k)`` -> ``(N,)``."""
        return self.optimal_start_values(weights) @ self.start_weights
