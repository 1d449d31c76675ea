"""CMA-ES for many independent box-bounded problems at once (Hansen, *The CMA Evolution Strategy:
A Tutorial*, 2016: its default parameters, with active covariance updates from the worse half).

Every problem has its own mean, step size σ, covariance ``C`` and evolution paths; ``ask`` samples
all problems' populations as one array and ``tell`` updates them all, so a planner can simulate
every problem's population in a single ``mujoco.rollout`` call. Values are maximized.

Bounds: the search itself is unbounded, and a point is evaluated where it folds into the unit
cube by reflection at the faces (``reflect``). The update learns from the unbounded steps, so
it is not biased by the bounds. Rejecting and redrawing points outside the cube (or clipping them
and learning from the clipped steps) biases every step away from a face, and with the optimum
in a corner (a throttle off, a set-point at its limit) the step size runs away; see
tests/test_cma.py.
"""

from __future__ import annotations

import numpy as np


def reflect(y: np.ndarray) -> np.ndarray:
    """Fold points of the unbounded search space into ``[0, 1]`` by reflection at the faces."""
    t = np.mod(y, 2.0)
    return np.where(t > 1.0, 2.0 - t, t)


class BatchedCMAES:
    """``B`` CMA-ES searches over ``[0, 1]^n`` (maximizing), advanced together.

    Args:
        mean: ``(B, n)`` initial means, in the unit cube.
        sigma: Initial step size (in unit-cube coordinates, > 0).
        population: Samples λ per problem and generation (≥ 4).
    """

    def __init__(self, mean: np.ndarray, sigma: float, population: int) -> None:
        mean = np.atleast_2d(np.asarray(mean, dtype=float))
        if population < 4:
            raise ValueError(f"CMA-ES needs a population of at least 4, got {population}")
        if not sigma > 0:
            raise ValueError(f"CMA-ES step size must be > 0, got {sigma}")
        b, n = mean.shape
        if np.any((mean < 0.0) | (mean > 1.0)):
            raise ValueError("CMA-ES initial means must lie in the unit cube")
        self.mean = mean.copy()
        self.sigma = np.full(b, float(sigma))
        self.population = lam = population
        mu = lam // 2
        prime = np.log((lam + 1) / 2) - np.log(np.arange(1, lam + 1))
        positive, negative = prime[:mu], prime[mu:]
        self.mu_eff = positive.sum() ** 2 / np.sum(positive**2)
        mu_eff_neg = negative.sum() ** 2 / np.sum(negative**2)
        me = self.mu_eff
        self.c_c = (4 + me / n) / (n + 4 + 2 * me / n)
        self.c_s = (me + 2) / (n + me + 5)
        self.c_1 = 2 / ((n + 1.3) ** 2 + me)
        self.c_mu = min(1 - self.c_1, 2 * (me - 2 + 1 / me) / ((n + 2) ** 2 + me))
        self.d_s = 1 + 2 * max(0.0, np.sqrt((me - 1) / (n + 1)) - 1) + self.c_s
        self.chi_n = np.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n**2))
        scale_neg = min(
            1 + self.c_1 / self.c_mu,
            1 + 2 * mu_eff_neg / (me + 2),
            (1 - self.c_1 - self.c_mu) / (n * self.c_mu),
        )
        #: Recombination weights, best first: positive ones sum to 1, negative ones (active CMA)
        #: take covariance away from the worse half's directions.
        self.weights = np.concatenate(
            [positive / positive.sum(), scale_neg * negative / np.abs(negative).sum()]
        )
        self.mu = mu
        self.cov = np.broadcast_to(np.eye(n), (b, n, n)).copy()
        self.p_c = np.zeros((b, n))
        self.p_s = np.zeros((b, n))
        self.generation = 0
        self._eig_vectors = self.cov.copy()
        self._eig_sqrt = np.ones((b, n))

    @property
    def dimension(self) -> int:
        return self.mean.shape[1]

    def ask(self, rng: np.random.Generator) -> np.ndarray:
        """A population ``(B, λ, n)`` per problem in the unbounded search space; evaluate it at
        ``reflect(samples)`` and hand the unreflected samples to ``tell``."""
        b, n = self.mean.shape
        z = rng.standard_normal((b, self.population, n))
        steps = np.einsum("bij,bpj->bpi", self._eig_vectors, z * self._eig_sqrt[:, None, :])
        return self.mean[:, None] + self.sigma[:, None, None] * steps

    def _inv_sqrt(self, v: np.ndarray) -> np.ndarray:
        """``C^(-1/2) v`` for vectors ``(B, P, n)``, from the eigendecomposition ``C = V D² Vᵀ``."""
        coords = np.einsum("bji,bpj->bpi", self._eig_vectors, v) / self._eig_sqrt[:, None, :]
        return np.einsum("bij,bpj->bpi", self._eig_vectors, coords)

    def tell(self, samples: np.ndarray, values: np.ndarray) -> None:
        """Update every problem from its population ``(B, λ, n)`` (as ``ask`` gave it) and their
        values ``(B, λ)`` (larger is better; −inf for samples that could not be evaluated)."""
        n = self.dimension
        order = np.argsort(-values, axis=1, kind="stable")
        y = (np.take_along_axis(samples, order[:, :, None], axis=1) - self.mean[:, None]) / self.sigma[
            :, None, None
        ]
        w_pos = self.weights[: self.mu]
        y_w = np.einsum("m,bmi->bi", w_pos, y[:, : self.mu])
        self.mean = self.mean + self.sigma[:, None] * y_w

        self.p_s = (1 - self.c_s) * self.p_s + np.sqrt(
            self.c_s * (2 - self.c_s) * self.mu_eff
        ) * self._inv_sqrt(y_w[:, None])[:, 0]
        self.generation += 1
        norm_s = np.linalg.norm(self.p_s, axis=1)
        h_sig = (
            norm_s / np.sqrt(1 - (1 - self.c_s) ** (2 * self.generation)) / self.chi_n < 1.4 + 2 / (n + 1)
        ).astype(float)
        self.p_c = (1 - self.c_c) * self.p_c + (h_sig * np.sqrt(self.c_c * (2 - self.c_c) * self.mu_eff))[
            :, None
        ] * y_w
        # Negative weights act on directions normalized by their Mahalanobis length (tutorial
        # eq. 46), which keeps C positive definite.
        w = np.broadcast_to(self.weights, values.shape).copy()
        mahalanobis = np.sum(self._inv_sqrt(y) ** 2, axis=2)
        neg = slice(self.mu, None)
        w[:, neg] *= n / np.maximum(mahalanobis[:, neg], 1e-20)
        rank_one = np.einsum("bi,bj->bij", self.p_c, self.p_c)
        rank_mu = np.einsum("bm,bmi,bmj->bij", w, y, y)
        delta = (1 - h_sig) * self.c_c * (2 - self.c_c)
        decay = 1 + self.c_1 * delta - self.c_1 - self.c_mu * self.weights.sum()
        self.cov = decay[:, None, None] * self.cov + self.c_1 * rank_one + self.c_mu * rank_mu
        self.cov = (self.cov + np.swapaxes(self.cov, 1, 2)) / 2
        self.sigma = self.sigma * np.exp((self.c_s / self.d_s) * (norm_s / self.chi_n - 1))
        # Beyond the size of the cube a step size only scrambles the reflection; keep it within.
        self.sigma = np.minimum(self.sigma, 1.0)
        eigenvalues, self._eig_vectors = np.linalg.eigh(self.cov)
        self._eig_sqrt = np.sqrt(np.maximum(eigenvalues, 1e-20))
