"""Finite MDPs with linear state rewards, solved for many reward vectors at once.

The solver exploits linearity: for a fixed deterministic policy ``π`` the successor features
``Ψ^π = (I − γ P_π)⁻¹ Φ`` give ``V^π_w = Ψ^π w`` and ``Q^π_w(s, a) = G^π(s, a)·w`` with
``G^π = Φ + γ P Ψ^π``. A policy is optimal for ``w`` exactly when no action improves on it
(``max_a Q^π_w(s, a) ≤ Q^π_w(s, π(s))``), so a cache of optimal policies answers ``Q*_w`` for a
batch of reward vectors with one matrix product per cached policy; only reward vectors that no
cached policy is optimal for are solved (batched value iteration, then exact policy iteration).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjsuff.domain import Demo, Domain

_OPTIMALITY_TOL = 1e-9
#: How many previous calls' solutions are tried first for the same rows (MCMC chains).
_HINT_DEPTH = 4


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
        s, a, s2 = self.transitions.shape
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
    """Exact ``Q*_w`` for batches of reward vectors, reusing every optimal policy found so far."""

    def __init__(self, mdp: TabularMDP) -> None:
        self.mdp = mdp
        s, a, k = mdp.num_states, mdp.num_actions, mdp.num_features
        self._keys: dict[bytes, int] = {}
        self._policies: list[np.ndarray] = []
        self._successors: list[np.ndarray] = []
        self._q_features: list[np.ndarray] = []  # each (S*A, k)
        self._g_stack = np.empty((0, s * a, k))
        self._pi_stack = np.empty((0, s), dtype=np.int64)
        self._hits = np.zeros(0, dtype=np.int64)
        self._recent: list[np.ndarray] = []

    def __len__(self) -> int:
        return len(self._policies)

    def _add(self, policy: np.ndarray) -> int:
        key = policy.astype(np.int8).tobytes()
        if key in self._keys:
            return self._keys[key]
        successor = self.mdp.successor_features(policy)
        g = self.mdp.q_features(successor)
        self._keys[key] = len(self._policies)
        self._policies.append(policy.astype(np.int64))
        self._successors.append(successor)
        self._q_features.append(g.reshape(-1, self.mdp.num_features))
        self._hits = np.append(self._hits, 0)
        return len(self._policies) - 1

    def _stack(self) -> None:
        if self._g_stack.shape[0] != len(self._policies):
            self._g_stack = np.stack(self._q_features)
            self._pi_stack = np.stack(self._policies)

    def _policy_iteration(self, w: np.ndarray, policy: np.ndarray) -> np.ndarray:
        """Exact policy iteration from ``policy`` for one reward vector ``w``."""
        s_idx = np.arange(self.mdp.num_states)
        for _ in range(1000):
            q = self.mdp.q_features(self.mdp.successor_features(policy)) @ w  # (S, A)
            current = q[s_idx, policy]
            best = q.argmax(axis=1)
            improve = q[s_idx, best] > current + _OPTIMALITY_TOL * (1.0 + np.abs(current))
            if not improve.any():
                return policy
            policy = np.where(improve, best, policy)
        raise RuntimeError("policy iteration did not converge")

    def _resolve(self, pending: np.ndarray, candidates: np.ndarray, weights: np.ndarray,
                 q_out: np.ndarray, which: np.ndarray) -> np.ndarray:
        """Try ``candidates`` (``(len(pending), B)`` cached indices); returns what stays pending."""
        s, a = self.mdp.num_states, self.mdp.num_actions
        w = weights[pending]
        q = np.einsum("nbxk,nk->nbx", self._g_stack[candidates], w)
        q = q.reshape(*candidates.shape, s, a)  # (n, B, S, A)
        on_policy = np.take_along_axis(q, self._pi_stack[candidates][..., None], axis=3)[..., 0]
        limit = on_policy + _OPTIMALITY_TOL * (1.0 + np.abs(on_policy))  # (n, B, S)
        ok = (q <= limit[..., None]).reshape(*candidates.shape, -1).all(axis=2)  # (n, B)
        found = ok.any(axis=1)
        if not found.any():
            return pending
        rows = np.flatnonzero(found)
        first = ok[rows].argmax(axis=1)
        q_out[pending[rows]] = q[rows, first]
        m = candidates[rows, first]
        which[pending[rows]] = m
        np.add.at(self._hits, m, 1)
        return pending[~found]

    def solve(self, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Optimal Q-values ``(N, S, A)`` and the index of an optimal cached policy per weight.

        Each weight is first tried against the policies that solved the same row in the last few
        calls of the same size (MCMC proposals stay near their chain), then against the cache by popularity; the
        rest are solved (batched value iteration, then exact policy iteration) and cached.
        """
        weights = np.atleast_2d(weights)
        n = weights.shape[0]
        s, a = self.mdp.num_states, self.mdp.num_actions
        q_out = np.empty((n, s, a))
        which = np.full(n, -1, dtype=np.int64)
        pending = np.arange(n)
        recent = [h for h in self._recent if h.shape[0] == n]
        hint = np.stack(recent, axis=1) if recent else None
        for _ in range(3):
            self._stack()
            if len(self._policies):
                if hint is not None:
                    pending = self._resolve(pending, hint[pending], weights, q_out, which)
                order = np.argsort(-self._hits, kind="stable")
                for lo in range(0, order.size, 32):
                    if pending.size == 0:
                        break
                    block = order[lo : lo + 32]
                    candidates = np.broadcast_to(block, (pending.size, block.size))
                    pending = self._resolve(pending, candidates, weights, q_out, which)
            if pending.size == 0:
                self._recent = [which, *self._recent[: _HINT_DEPTH - 1]]
                return q_out, which
            q_vi = self.mdp.value_iteration(weights[pending], tol=1e-8)
            for row, greedy in zip(pending, q_vi.argmax(axis=2), strict=True):
                self._add(self._policy_iteration(weights[row], greedy))
            hint = None
        raise RuntimeError("optimal policy cache failed to resolve all reward vectors")

    def optimal_values(self, weights: np.ndarray) -> np.ndarray:
        """``V*_w(s)`` for weights ``(N, k)`` -> ``(N, S)``."""
        weights = np.atleast_2d(weights)
        _, which = self.solve(weights)
        out = np.empty((weights.shape[0], self.mdp.num_states))
        for m in np.unique(which):
            rows = which == m
            out[rows] = weights[rows] @ self._successors[m].T
        return out


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
    ) -> None:
        if true_weights.shape != (mdp.num_features,):
            raise ValueError(f"true_weights must have shape ({mdp.num_features},)")
        self.mdp = mdp
        self.num_features = mdp.num_features
        self.true_weights = true_weights / np.linalg.norm(true_weights)
        self.start_weights = start_weights / start_weights.sum()
        self.pool = np.flatnonzero(~mdp.terminal)
        self.baseline_policy = baseline_policy
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
    def log_likelihood(self, weights: np.ndarray, demos: list[Demo], beta: float) -> np.ndarray:
        weights = np.atleast_2d(weights)
        if not demos:
            return np.zeros(weights.shape[0])
        q, _ = self.cache.solve(weights)
        states = self.pool[[d.start for d in demos]]
        actions = np.array([d.action for d in demos])
        q_demo = beta * q[:, states, :]  # (N, D, A)
        peak = q_demo.max(axis=2, keepdims=True)
        log_z = peak[..., 0] + np.log(np.exp(q_demo - peak).sum(axis=2))
        chosen = q_demo[:, np.arange(len(demos)), actions]
        return (chosen - log_z).sum(axis=1)

    def plan(self, w: np.ndarray) -> np.ndarray:
        q, _ = self.cache.solve(np.asarray(w)[None])
        return q[0].argmax(axis=1)

    def start_feature_expectations(self, policy: np.ndarray) -> np.ndarray:
        return self.mdp.successor_features(policy)

    def optimal_start_values(self, weights: np.ndarray) -> np.ndarray:
        return self.cache.optimal_values(weights)

    def random_start_feature_expectations(self) -> np.ndarray:
        return self._random_mu

    def baseline_start_feature_expectations(self) -> np.ndarray:
        return self._baseline_mu

    def same_policy(self, a: np.ndarray, b: np.ndarray) -> bool:
        return bool(np.array_equal(a[self.pool], b[self.pool]))

    def agrees_with_demo(self, policy: np.ndarray, demo: Demo) -> bool:
        return int(policy[self.pool[demo.start]]) == demo.action

    def policy_optimality(self, policy: np.ndarray) -> float:
        states = self.pool
        q = self._true_q[states]
        chosen = q[np.arange(states.size), policy[states]]
        best = q.max(axis=1)
        return float(np.mean(chosen >= best - _OPTIMALITY_TOL * (1.0 + np.abs(best))))
