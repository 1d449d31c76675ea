"""Per-start trajectory libraries: every simulated trajectory's features, kept for reuse.

Rollouts are reward-agnostic: once a trajectory's features are known it can be scored under any
number of reward vectors with one matrix product. The library's best trajectory under ``w`` is a
lower bound on ``V*_w`` from that start. Demonstrations join as *feature-only* entries: they are
feasible trajectories (so they raise the lower bound) but have no spline knots to warm-start from.
"""

from __future__ import annotations

import numpy as np

#: Most entries of one weights × features product in ``best`` (2^25 doubles: 256 MiB); larger
#: batches of weights are scored in slices (a library grows by every rollout simulated).
MAX_PRODUCT = 2**25


class TrajectoryLibrary:
    """Features ``(n, k)`` and knots ``(n, K, nu)`` of valid trajectories, one growing set per start."""

    def __init__(self, num_starts: int, num_features: int, knot_shape: tuple[int, int]) -> None:
        self.num_features = num_features
        self.knot_shape = knot_shape
        self._features: list[list[np.ndarray]] = [[] for _ in range(num_starts)]
        self._knots: list[list[np.ndarray]] = [[] for _ in range(num_starts)]
        self._packed: list[tuple[np.ndarray, np.ndarray] | None] = [None] * num_starts
        self._extra: list[np.ndarray] = [np.empty((0, num_features)) for _ in range(num_starts)]

    def __len__(self) -> int:
        return sum(self.size(s) for s in range(len(self._features)))

    def size(self, start: int) -> int:
        return sum(len(f) for f in self._features[start])

    def add(self, start: int, features: np.ndarray, knots: np.ndarray) -> None:
        """Keep the finite (non-diverged) rows of ``features`` ``(B, k)`` and their knots."""
        ok = np.isfinite(features).all(axis=1)
        if ok.any():
            self._features[start].append(features[ok])
            self._knots[start].append(knots[ok])
            self._packed[start] = None

    def add_features(self, start: int, features: np.ndarray) -> None:
        """Keep feature-only entries ``(B, k)`` (e.g. demonstrations, which have no knots)."""
        features = np.atleast_2d(np.asarray(features, dtype=float))
        ok = np.isfinite(features).all(axis=1)
        self._extra[start] = np.concatenate([self._extra[start], features[ok]])

    def arrays(self, start: int) -> tuple[np.ndarray, np.ndarray]:
        """All features ``(n, k)`` and knots ``(n, K, nu)`` from ``start``."""
        packed = self._packed[start]
        if packed is None:
            if not self._features[start]:
                return np.empty((0, self.num_features)), np.empty((0, *self.knot_shape))
            features = np.concatenate(self._features[start])
            knots = np.concatenate(self._knots[start])
            self._features[start], self._knots[start] = [features], [knots]
            packed = self._packed[start] = (features, knots)
        return packed

    def best_value(self, start: int, weights: np.ndarray) -> np.ndarray:
        """Best value ``(N,)`` over every entry from ``start``, feature-only ones included."""
        value = self.best(start, weights)[0]
        if len(self._extra[start]):
            value = np.maximum(value, (weights @ self._extra[start].T).max(axis=1))
        return value

    def best(self, start: int, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Best value ``(N,)`` and index ``(N,)`` among the entries with knots, for weights ``(N, k)``."""
        features, _ = self.arrays(start)
        if not len(features):
            n = len(weights)
            return np.full(n, -np.inf), np.full(n, -1)
        rows = max(1, MAX_PRODUCT // len(features))  # weights per product, bounding its memory
        value, index = np.empty(len(weights)), np.empty(len(weights), dtype=int)
        for lo in range(0, len(weights), rows):
            values = weights[lo : lo + rows] @ features.T
            index[lo : lo + rows] = values.argmax(axis=1)
            value[lo : lo + rows] = values[np.arange(len(values)), index[lo : lo + rows]]
        return value, index
