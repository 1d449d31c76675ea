"""Exact posterior on a fine grid of the 2-sphere (``k = 3``), to check the sampler against."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjsuff.posterior.sampler import LogLikelihood
from mjsuff.sphere import fibonacci_sphere


@dataclass(frozen=True)
class GridPosterior:
    """A posterior tabulated on nearly equal-area sphere points.

    Attributes:
        points: ``(G, 3)`` grid points.
        probabilities: ``(G,)`` normalized posterior mass of each point (uniform prior).
    """

    points: np.ndarray
    probabilities: np.ndarray

    @property
    def mean(self) -> np.ndarray:
        return self.probabilities @ self.points

    @property
    def covariance(self) -> np.ndarray:
        centred = self.points - self.mean
        return (centred * self.probabilities[:, None]).T @ centred


def grid_posterior(
    log_likelihood: LogLikelihood, num_points: int = 40_000, batch: int = 5_000
) -> GridPosterior:
    """Evaluate ``log_likelihood`` on ``num_points`` Fibonacci-sphere points and normalize."""
    points = fibonacci_sphere(num_points)
    ll = np.concatenate([log_likelihood(points[i : i + batch]) for i in range(0, num_points, batch)])
    p = np.exp(ll - ll.max())
    return GridPosterior(points, p / p.sum())
