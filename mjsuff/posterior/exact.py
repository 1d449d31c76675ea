"""Exact posterior on a fine point set of the sphere, to check the sampler against.

For ``k = 3`` the points are a Fibonacci grid of the 2-sphere (deterministic, nearly equal-area);
for other ``k`` they are uniform random points of the sphere from a given generator (a Monte
Carlo quadrature: with ``G`` points its error falls as ``1/√(effective points)``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjsuff.posterior.sampler import LogLikelihood
from mjsuff.sphere import fibonacci_sphere, random_unit_vectors


@dataclass(frozen=True)
class GridPosterior:
    """A posterior tabulated on nearly equal-area sphere points.

    Attributes:
        points: ``(G, k)`` grid points.
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
    log_likelihood: LogLikelihood,
    num_points: int = 40_000,
    batch: int = 5_000,
    k: int = 3,
    rng: np.random.Generator | None = None,
) -> GridPosterior:
    """Evaluate ``log_likelihood`` on ``num_points`` sphere points (module docstring; ``rng``
    is required when ``k != 3``) and normalize."""
    if k == 3:
        points = fibonacci_sphere(num_points)
    elif rng is None:
        raise ValueError(f"grid_posterior: k = {k} needs rng for its random sphere points")
    else:
        points = random_unit_vectors(rng, num_points, k)
    ll = np.concatenate([log_likelihood(points[i : i + batch]) for i in range(0, num_points, batch)])
    p = np.exp(ll - ll.max())
    return GridPosterior(points, p / p.sum())
