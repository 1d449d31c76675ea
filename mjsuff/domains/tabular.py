"""Finite MDPs with linear state rewards, solved for many reward vectors at once.

The solver exploits linearity: for a fixed deterministic policy ``π`` the successor features
``Ψ^π = (I − γ P_π)⁻¹ Φ`` give ``V^π_w = Ψ^π w`` and ``Q^π_w(s, a) = G^π(s, a)·w`` with
``G^π = Φ + γ P Ψ^π``. A policy is optimal for ``w`` exactly when no action improves on it
(``max_a Q^π_w(s, a) ≤ Q^π_w(s, π(s))``), so a cache of optimal policies answers ``Q*_w`` for a
batch of reward vectors with one matrix product over every cached policy; only reward vectors that
no cached policy is optimal for are solved (exact policy iteration, batched).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjsuff.domain import BoundIndex, Demo, Domain

_OPTIMALITY_TOL = 1e-9


def greedy_actions(q: np.ndarray) -> np.ndarray:
    """The lowest-index action within tolerance of the best, per state: ``(..., A)`` -> ``(...)``.

    Plain ``argmax`` would break exact ties by floating-point noise; this breaks them the same way
    for the expert and the robot.
    """
    best = q.max(axis=-1, keepdims=True)
    return (q >= best - _OPTIMALITY_TOL * (1.0 + np.abs(best))).argmax(axis=-1)


@dataclass(frozen=True)
class TabularMDP:
    """A finite MDP with state rewards ``R_w(s) = w·Φ(s)`` (paper §3.1).

    Attributes:
        transitions: ``P[s, a, s']``, shape ``(S, A, S)``; rows of terminal states are all zero
            (the episode ends after the terminal reward).
        features: ``Φ``, shape ``(S, k)``.
        gamma: Discount factor in ``[0, 1)``.
        terminal: Boolean mask of terminal states, shape ``(S,)``.
    """

    transitions: np.ndarray
    features: np.ndarray
    gamma: float
    terminal: np.ndarray

    def __post_init__(self) -> None:
        s, _, s2 = self.transitions.shape
        if s != s2:
            raise ValueError(f"transitions must have shape (S, A, S), got {self.transitions.shape}")
        if self.features.shape[0] != s:
            raise ValueError(f"features must have {s} rows, got {self.features.shape[0]}")
        if not 0.0 <= self.gamma < 1.0:
            raise ValueError(f"gamma must be in [0, 1), got {self.gamma}")
        sums = self.transitions.sum(axis=2)
        expected = np.where(self.terminal[:, None], 0.0, 1.0)
        if not np.allclose(sums, expected):
            raise ValueError("transition rows must sum to 1 (0 for terminal states)")

    @property
    def num_states(self) -> int:
        return self.transitions.shape[0]

    @property
    def num_actions(self) -> int:
        return self.transitions.shape[1]

    @property
    def num_features(self) -> int:
        return self.features.shape[1]

    def successor_features(self, policy: np.ndarray) -> np.ndarray:
        """``Ψ^π = (I − γ P_π)⁻¹ Φ`` for a deterministic policy (one action per state) -> ``(S, k)``."""
        p_pi = self.transitions[np.arange(self.num_states), policy]
        return self._solve_successor(p_pi)

    def stochastic_successor_features(self, action_probs: np.ndarray) -> np.ndarray:
        """``Ψ`` for a stochastic policy ``π(a | s)`` of shape ``(S, A)`` -> ``(S, k)``."""
        p_pi = np.einsum("sa,sat->st", action_probs, self.transitions)
        return self._solve_successor(p_pi)

    def _solve_successor(self, p_pi: np.ndarray) -> np.ndarray:
        lhs = np.eye(self.num_states) - self.gamma * p_pi
        return np.linalg.solve(lhs, self.features)

    def q_features(self, successor: np.ndarray) -> np.ndarray:
        """``G^π(s, a) = Φ(s) + γ Σ_s' P(s, a, s') Ψ^π(s')`` -> ``(S, A, k)``."""
        return self.features[:, None, :] + self.gamma * (self.transitions @ successor)

    def value_iteration(self, weights: np.ndarray, tol: float = 1e-10) -> np.ndarray:
        """Batched value iteration: ``Q*`` for weights ``(N, k)`` -> ``(N, S, A)``."""
        rewards = weights @ self.features.T  # (N, S)
        values = rewards.copy()
        scale = np.abs(rewards).max() + 1.0
        # Contraction: stop when the update is below tol * (1 - γ) relative to the reward scale.
        for _ in range(100_000):
            q = rewards[:, :, None] + self.gamma * np.einsum("sat,nt->nsa", self.transitions, values)
            new_values = q.max(axis=2)
            if np.abs(new_values - values).max() <= tol * scale * (1.0 - self.gamma):
                return q
            values = new_values
        raise RuntimeError("value iteration did not converge")


class OptimalPolicyCache:
    """Exact ``Q*_w`` for batches of reward vectors, reusing every optimal policy found so far.

    With the successor features ``Ψ_m`` of the cached policies, ``V(s) = max_m Ψ_m(s)·w`` is a
    lower bound on ``V*_w(s)`` (every policy's value is) and one matrix product for the whole
    batch. It *is* ``V*_w`` exactly when it satisfies the Bellman optimality equation
    (``max_a [R + γPV](s, a) ≤ V(s)`` everywhere: then ``V ≥ T^n V → V*``); only the reward
    vectors for which it does not are solved, by batched policy iteration started from the greedy
    policy of ``V`` (one improvement step, already paid for), and their policies are cached.
    """

    def __init__(self, mdp: TabularMDP) -> None:
        self.mdp = mdp
        self._keys: set[bytes] = set()
        # Per state, the distinct successor-feature rows Ψ_m(s) of the cached policies (many
        # policies agree at a state), flattened as (k, total) with each state's segment start.
        self._rows: list[dict[bytes, np.ndarray]] = [{} for _ in range(mdp.num_states)]
        self._flat = np.empty((mdp.num_features, 0))
        self._segments = np.zeros(mdp.num_states, dtype=np.intp)
        self._reward_features = mdp.features
        # P as (S·A, S) for batched Bellman backups.
        self._p_flat = mdp.transitions.reshape(-1, mdp.num_states)

    def __len__(self) -> int:
        return len(self._keys)

    def _add(self, policies: np.ndarray, successors: np.ndarray) -> None:
        """Cache ``policies`` ``(r, S)`` with successor features ``successors`` ``(r, S, k)``."""
        k = self.mdp.num_features
        # One key per (policy, state) row: its bytes rounded to 1e-12, so rows that differ by
        # solver noise count as one.
        rounded = np.ascontiguousarray(np.round(successors, 12))
        row_keys = rounded.view(np.dtype((np.void, 8 * k)))[..., 0].tolist()
        grew = False
        for policy, psi, keys in zip(policies, successors, row_keys, strict=True):
            key = policy.astype(np.int8).tobytes()
            if key in self._keys:
                continue
            self._keys.add(key)
            for state_rows, row_key, row in zip(self._rows, keys, psi, strict=True):
                state_rows.setdefault(row_key, row)
            grew = True
        if grew:
            sizes = [len(r) for r in self._rows]
            self._segments = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.intp)
            rows = [row for state_rows in self._rows for row in state_rows.values()]
            self._flat = np.ascontiguousarray(np.array(rows).T)

    def _backup(self, weights: np.ndarray, values: np.ndarray) -> np.ndarray:
        """``Q = R + γ P V`` for rows of ``weights`` ``(r, k)`` and ``values`` ``(r, S)``."""
        s, a = self.mdp.num_states, self.mdp.num_actions
        q = (values @ self._p_flat.T).reshape(-1, s, a)
        return (weights @ self._reward_features.T)[:, :, None] + self.mdp.gamma * q

    def _policy_iteration(
        self, weights: np.ndarray, policies: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Exact policy iteration for each row of ``weights`` ``(r, k)``, batched.

        Starts from ``policies`` ``(r, S)``; returns optimal policies ``(r, S)``, ``Q*``
        ``(r, S, A)`` and the policies' successor features ``(r, S, k)``. An action replaces the
        current one only if it improves by more than the tolerance, so ties never cycle.
        """
        mdp = self.mdp
        s_idx = np.arange(mdp.num_states)
        eye = np.eye(mdp.num_states)
        features = np.broadcast_to(mdp.features, (weights.shape[0], *mdp.features.shape))
        policies = policies.copy()
        rows = np.arange(weights.shape[0])[:, None]
        for _ in range(1000):
            p_pi = mdp.transitions[s_idx, policies]  # (r, S, S)
            successors = np.linalg.solve(eye - mdp.gamma * p_pi, features)  # (r, S, k)
            values = np.einsum("rsk,rk->rs", successors, weights)
            q = self._backup(weights, values)
            current = q[rows, s_idx, policies]
            best = q.argmax(axis=2)
            improve = q[rows, s_idx, best] > current + _OPTIMALITY_TOL * (1.0 + np.abs(current))
            if not improve.any():
                return policies, q, successors
            policies = np.where(improve, best, policies)
        raise RuntimeError("policy iteration did not converge")

    def _cached_values(self, weights: np.ndarray) -> np.ndarray:
        """``max_m Ψ_m(s)·w`` over the cached policies -> ``(N, S)`` (a lower bound on ``V*``)."""
        return np.maximum.reduceat(weights @ self._flat, self._segments, axis=1)

    def solve(self, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Optimal Q-values ``(N, S, A)`` and values ``(N, S)`` for weights ``(N, k)``."""
        weights = np.atleast_2d(np.asarray(weights, dtype=float))
        n = weights.shape[0]
        s, a = self.mdp.num_states, self.mdp.num_actions
        if self._keys:
            values = self._cached_values(weights)
            q = self._backup(weights, values)
            limit = values + _OPTIMALITY_TOL * (1.0 + np.abs(values))
            pending = np.flatnonzero((q > limit[:, :, None]).reshape(n, -1).any(axis=1))
            start = greedy_actions(q[pending]) if pending.size else None
        else:
            values, q = np.empty((n, s)), np.empty((n, s, a))
            pending = np.arange(n)
            # No cached policy yet: start from the myopic policy (best expected next reward).
            start = greedy_actions(
                np.einsum("sat,rt->rsa", self.mdp.transitions, weights @ self.mdp.features.T)
            )
        if pending.size:
            w = weights[pending]
            assert start is not None  # set wherever pending is non-empty
            policies, q_new, successors = self._policy_iteration(w, start)
            q[pending] = q_new
            values[pending] = np.einsum("rsk,rk->rs", successors, w)
            self._add(policies, successors)
        return q, values

    def optimal_values(self, weights: np.ndarray, batch: int = 256) -> np.ndarray:
        """``V*_w(s)`` for weights ``(N, k)`` -> ``(N, S)``, ``batch`` rows at a time (memory)."""
        weights = np.atleast_2d(np.asarray(weights, dtype=float))
        return (
            np.concatenate([self.solve(weights[i : i + batch])[1] for i in range(0, weights.shape[0], batch)])
            if len(weights)
            else (np.empty((0, self.mdp.num_states)))
        )


class TabularDomain(Domain):
    """A tabular MDP with state-action demonstrations and a Boltzmann likelihood over ``Q*`` (Eq. 1).

    Evaluation starts are all states, weighted by ``start_weights``; demonstrations may be asked
    from every non-terminal state. The expert gives an optimal action under ``w*`` (the lowest-index
    one among ties); a poor demo is a uniformly random non-optimal action.
    """

    def __init__(
        self,
        mdp: TabularMDP,
        true_weights: np.ndarray,
        start_weights: np.ndarray,
        baseline_policy: np.ndarray,
        layout: np.ndarray | None = None,
    ) -> None:
        """``layout`` ``(S, 2)``: each state's (row, column) cell when the MDP is a grid (drawn by
        the recordings); None places the states in one row."""
        if true_weights.shape != (mdp.num_features,):
            raise ValueError(f"true_weights must have shape ({mdp.num_features},)")
        self.mdp = mdp
        self.num_features = mdp.num_features
        self.true_weights = true_weights / np.linalg.norm(true_weights)
        self.start_weights = start_weights / start_weights.sum()
        self.pool = np.flatnonzero(~mdp.terminal)
        self.baseline_policy = baseline_policy
        n = mdp.num_states
        self.layout = (
            np.stack([np.zeros(n), np.arange(n)], axis=1)
            if layout is None
            else np.asarray(layout, dtype=float)
        )
        self.cache = OptimalPolicyCache(mdp)
        self._true_q = self.cache.solve(self.true_weights[None])[0][0]
        uniform = np.full((mdp.num_states, mdp.num_actions), 1.0 / mdp.num_actions)
        self._random_mu = mdp.stochastic_successor_features(uniform)
        self._baseline_mu = mdp.successor_features(baseline_policy)

    # -- expert -------------------------------------------------------------------------------
    def optimal_actions(self, state: int) -> np.ndarray:
        q = self._true_q[state]
        return np.flatnonzero(q >= q.max() - _OPTIMALITY_TOL * (1.0 + abs(q.max())))

    def demonstrate(self, start: int, rng: np.random.Generator, poor: bool = False) -> Demo:
        state = int(self.pool[start])
        best = self.optimal_actions(state)
        if poor:
            others = np.setdiff1d(np.arange(self.mdp.num_actions), best)
            if others.size:
                return Demo(start=start, action=int(rng.choice(others)), poor=True)
        return Demo(start=start, action=int(best[0]), poor=False)

    # -- learner ------------------------------------------------------------------------------
    def demo_log_likelihoods(self, weights: np.ndarray, demos: list[Demo], beta: float) -> np.ndarray:
        weights = np.atleast_2d(weights)
        if not demos:
            return np.zeros((weights.shape[0], 0))
        q, _ = self.cache.solve(weights)
        states = self.pool[[d.start for d in demos]]
        actions = np.array([d.action for d in demos])
        q_demo = beta * q[:, states, :]  # (N, D, A)
        # Log-sum-exp over actions with the actions leading: numpy reduces a short last axis an
        # order of magnitude slower than a leading one (same values, same summation order).
        by_action = np.ascontiguousarray(q_demo.transpose(2, 0, 1))  # (A, N, D)
        peak = by_action.max(axis=0)
        log_z = peak + np.log(np.exp(by_action - peak).sum(axis=0))
        chosen = q_demo[:, np.arange(len(demos)), actions]
        return chosen - log_z

    def choice_counts(self, demos: list[Demo]) -> np.ndarray:
        """Every action at the demo's state."""
        return np.full(len(demos), self.mdp.num_actions)

    def alternatives_better(self, demo: Demo, w: np.ndarray) -> int:
        """Actions whose ``Q_w`` at the demo's state exceeds the demo action's (ties excluded)."""
        q, _ = self.cache.solve(np.asarray(w, dtype=float)[None])
        values = q[0, self.pool[demo.start]]
        chosen = values[demo.action]
        return int(np.sum(values > chosen + 1e-9 * max(1.0, abs(chosen))))

    def plan(self, w: np.ndarray) -> np.ndarray:
        q, _ = self.cache.solve(np.asarray(w)[None])
        return greedy_actions(q[0])

    def start_feature_expectations(self, policy: np.ndarray) -> np.ndarray:
        return self.mdp.successor_features(policy)

    def optimal_start_values(
        self, weights: np.ndarray, robot: np.ndarray | None = None, bound_index: BoundIndex | None = None
    ) -> np.ndarray:
        return self.cache.optimal_values(weights)

    def pool_regrets(self, weights: np.ndarray, policy: np.ndarray) -> np.ndarray:
        weights = np.atleast_2d(weights)
        mu = self.start_feature_expectations(policy)
        return self.cache.optimal_values(weights)[:, self.pool] - weights @ mu[self.pool].T

    def random_start_feature_expectations(self) -> np.ndarray:
        return self._random_mu

    def baseline_start_feature_expectations(self) -> np.ndarray:
        return self._baseline_mu

    def same_policy(self, a: np.ndarray, b: np.ndarray) -> bool:
        return bool(np.array_equal(a[self.pool], b[self.pool]))

    def agrees_with_demo(self, policy: np.ndarray, demo: Demo) -> bool:
        return int(policy[self.pool[demo.start]]) == demo.action

    def policy_optimality(self, policy: np.ndarray, best: np.ndarray | None = None) -> float:
        states = self.pool
        q = self._true_q[states]
        chosen = q[np.arange(states.size), policy[states]]
        best = q.max(axis=1)
        return float(np.mean(chosen >= best - _OPTIMALITY_TOL * (1.0 + np.abs(best))))
