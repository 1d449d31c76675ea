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
#: How many cached policies with the nearest representative weights are tried next.
_NEAREST = 8
#: Solved weight vectors remembered for the nearest-policy guess.
_MAX_REPRESENTATIVES = 4096


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
    """Exact ``Q*_w`` for batches of reward vectors, reusing every optimal policy found so far."""

    def __init__(self, mdp: TabularMDP) -> None:
        self.mdp = mdp
        s, a, k = mdp.num_states, mdp.num_actions, mdp.num_features
        self._keys: dict[bytes, int] = {}
        self._successors: list[np.ndarray] = []
        self._size = 0
        # Growable stacks (capacity doubles): Q-features and policies of the cached policies.
        self._g_stack = np.empty((16, s * a, k))
        self._pi_stack = np.empty((16, s), dtype=np.int64)
        # Solved weight vectors and the cached policy each was solved by (nearest-policy guesses).
        self._rep_w = np.empty((0, k))
        self._rep_policy = np.empty(0, dtype=np.int64)
        self._recent: list[np.ndarray] = []

    def __len__(self) -> int:
        return self._size

    def _add(self, policies: np.ndarray, weights: np.ndarray, successors: np.ndarray
             ) -> np.ndarray:
        """Cache ``policies`` ``(r, S)`` (each optimal for its row of ``weights``, with successor
        features ``successors`` ``(r, S, k)``) -> their cache indices."""
        keys = [p.astype(np.int8).tobytes() for p in policies]
        fresh: dict[bytes, int] = {}
        for row, key in enumerate(keys):
            if key not in self._keys and key not in fresh:
                fresh[key] = row
        if fresh:
            rows = np.fromiter(fresh.values(), dtype=np.int64)
            need = self._size + rows.size
            while need > self._g_stack.shape[0]:
                self._g_stack = np.concatenate([self._g_stack, np.empty_like(self._g_stack)])
                self._pi_stack = np.concatenate([self._pi_stack, np.empty_like(self._pi_stack)])
            mdp = self.mdp
            new_successors = successors[rows]
            g = mdp.features[None, :, None, :] + mdp.gamma * np.einsum(
                "sat,mtk->msak", mdp.transitions, new_successors)
            span = slice(self._size, need)
            self._g_stack[span] = g.reshape(rows.size, -1, mdp.num_features)
            self._pi_stack[span] = policies[rows]
            self._successors.extend(new_successors)
            for offset, key in enumerate(fresh):
                self._keys[key] = self._size + offset
            self._size = need
        index = np.array([self._keys[key] for key in keys], dtype=np.int64)
        room = _MAX_REPRESENTATIVES - self._rep_w.shape[0]
        if room > 0:
            self._rep_w = np.concatenate([self._rep_w, weights[:room]])
            self._rep_policy = np.concatenate([self._rep_policy, index[:room]])
        return index

    def _policy_iteration(self, weights: np.ndarray, policies: np.ndarray
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
        rewards = weights @ mdp.features.T  # (r, S)
        policies = policies.copy()
        rows = np.arange(weights.shape[0])[:, None]
        for _ in range(1000):
            p_pi = mdp.transitions[s_idx, policies]  # (r, S, S)
            successors = np.linalg.solve(eye - mdp.gamma * p_pi, features)  # (r, S, k)
            values = np.einsum("rsk,rk->rs", successors, weights)
            q = rewards[:, :, None] + mdp.gamma * np.einsum("sat,rt->rsa", mdp.transitions, values)
            current = q[rows, s_idx, policies]
            best = q.argmax(axis=2)
            improve = q[rows, s_idx, best] > current + _OPTIMALITY_TOL * (1.0 + np.abs(current))
            if not improve.any():
                return policies, q, successors
            policies = np.where(improve, best, policies)
        raise RuntimeError("policy iteration did not converge")

    def _resolve(self, pending: np.ndarray, candidates: np.ndarray, weights: np.ndarray,
                 q_out: np.ndarray, which: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Try ``candidates`` (``(len(pending), B)`` cached indices) for the ``pending`` rows.

        Writes the rows some candidate is optimal for into ``q_out``/``which``; returns the rows
        still pending and, for each, a policy-iteration start: the greedy improvement of its best
        candidate (one policy-iteration step, already paid for).
        """
        s, a = self.mdp.num_states, self.mdp.num_actions
        unique, slot = np.unique(candidates, return_inverse=True)
        slot = slot.reshape(candidates.shape)
        # One matrix product for every distinct candidate, then each row picks its own.
        q_all = (weights[pending] @ self._g_stack[unique].reshape(-1, self.mdp.num_features).T)
        q_all = q_all.reshape(pending.size, unique.size, s, a)
        q = q_all[np.arange(pending.size)[:, None], slot]  # (n, B, S, A)
        on_policy = np.take_along_axis(q, self._pi_stack[candidates][..., None], axis=3)[..., 0]
        limit = on_policy + _OPTIMALITY_TOL * (1.0 + np.abs(on_policy))  # (n, B, S)
        ok = (q <= limit[..., None]).reshape(*candidates.shape, -1).all(axis=2)  # (n, B)
        found = ok.any(axis=1)
        rows = np.flatnonzero(found)
        if rows.size:
            first = ok[rows].argmax(axis=1)
            q_out[pending[rows]] = q[rows, first]
            which[pending[rows]] = candidates[rows, first]
        rest = np.flatnonzero(~found)
        best = on_policy[rest].sum(axis=2).argmax(axis=1)
        return pending[rest], greedy_actions(q[rest, best])

    def solve(self, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Optimal Q-values ``(N, S, A)`` and the index of an optimal cached policy per weight.

        Each weight is first tried against the policies that solved the same row in the last few
        calls of the same size (MCMC proposals stay near their chain) and those found for the
        nearest solved weights; the rest are solved exactly by batched policy iteration,
        warm-started from the nearest cached policy, and cached.
        """
        weights = np.atleast_2d(np.asarray(weights, dtype=float))
        n = weights.shape[0]
        s, a = self.mdp.num_states, self.mdp.num_actions
        q_out = np.empty((n, s, a))
        which = np.full(n, -1, dtype=np.int64)
        pending = np.arange(n)
        start = None
        if self._size:
            similarity = weights @ self._rep_w.T
            if similarity.shape[1] > _NEAREST:
                nearest = np.argpartition(-similarity, _NEAREST - 1, axis=1)[:, :_NEAREST]
                first = np.take_along_axis(similarity, nearest, axis=1).argmax(axis=1)
                rows = np.arange(n)
                closest = nearest[rows, first]
                nearest[rows, first] = nearest[:, 0]
                nearest[:, 0] = closest
            else:
                nearest = np.argsort(-similarity, axis=1)
            near = self._rep_policy[nearest]
            recent = [h[:, None] for h in self._recent if h.shape[0] == n]
            guesses = np.concatenate([*recent, near], axis=1)
            pending, start = self._resolve(pending, guesses, weights, q_out, which)
        if pending.size:
            w = weights[pending]
            if start is None:
                # No cached guess yet: start from the myopic policy (best expected next reward).
                start = greedy_actions(
                    np.einsum("sat,rt->rsa", self.mdp.transitions, w @ self.mdp.features.T))
            policies, q, successors = self._policy_iteration(w, start)
            q_out[pending] = q
            which[pending] = self._add(policies, w, successors)
        self._recent = [which, *self._recent[: _HINT_DEPTH - 1]]
        return q_out, which

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
        self.layout = (np.stack([np.zeros(n), np.arange(n)], axis=1) if layout is None
                       else np.asarray(layout, dtype=float))
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
