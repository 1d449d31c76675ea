"""Does the bound keep its confidence? Coverage of the α-VaR bounds against a reference posterior.

For a fixed task, demos and policy ``π``, the posterior's α-quantile of ``nEVD(π)`` is a number.
The nEVD bound (Eq. 6) promises to be at least that number with probability ``1 − δ`` over the
sampler's randomness, and the PIOB bound (Eq. 12) to be at most the posterior's ``(1 − α)``-
quantile of ``PIOB(π)``. Coverage is the share of sampler seeds for which the promise held.

The reference quantiles come from a posterior computed without MCMC:

* ``importance_reference``: self-normalized importance sampling from the uniform prior (the
  posterior is ``∝ L(w)``, so the weights are the likelihoods); its effective size is reported;
* ``grid_reference``: the exact posterior on a fine Fibonacci grid of the 2-sphere (``k = 3``).

``check`` is one sufficiency check as ``mjsuff run`` does it: the scenario's sampler, then both
bounds with the order-statistic index for the draws' effective size
(``Posterior.effective_size``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mjsuff.bounds.regret import normalized_evd, percent_improvement, policy_values
from mjsuff.bounds.var_bound import QuantileMethod
from mjsuff.domain import Domain, Policy
from mjsuff.experiment.replicate import posterior_bounds
from mjsuff.posterior.exact import grid_posterior
from mjsuff.posterior.sampler import LogLikelihood, SamplerConfig, sample_posterior
from mjsuff.sphere import random_unit_vectors

OptimalValues = Callable[[np.ndarray], np.ndarray]
"""Maps weights ``(N, k)`` to ``V*`` per evaluation start ``(N, S)``."""


@dataclass(frozen=True)
class Statistics:
    """``nEVD(π)`` and ``PIOB(π)`` of a fixed policy, for any batch of reward weights."""

    domain: Domain
    policy: Policy
    optimal_values: OptimalValues

    def __call__(self, weights: np.ndarray, batch: int = 4096) -> tuple[np.ndarray, np.ndarray]:
        """(nEVD, PIOB) per row of ``weights`` ``(N, k)``, ``batch`` rows at a time."""
        d, sw = self.domain, self.domain.start_weights
        mu = d.start_feature_expectations(self.policy)
        mu_rand, mu_base = d.random_start_feature_expectations(), d.baseline_start_feature_expectations()
        nevd, piob = [], []
        for i in range(0, len(weights), batch):
            w = weights[i : i + batch]
            v_opt = self.optimal_values(w) @ sw
            v_robot = policy_values(w, mu, sw)
            nevd.append(normalized_evd(v_opt, v_robot, policy_values(w, mu_rand, sw)))
            piob.append(percent_improvement(v_robot, policy_values(w, mu_base, sw)))
        return np.concatenate(nevd), np.concatenate(piob)


@dataclass(frozen=True)
class Reference:
    """A posterior given as weighted points, and its effective size (``1/Σp²``)."""

    points: np.ndarray
    probabilities: np.ndarray

    @property
    def effective_size(self) -> float:
        return float(1.0 / np.sum(self.probabilities**2))

    def quantile(self, values: np.ndarray, prob: float) -> float:
        """The posterior's ``prob``-quantile of per-point ``values``: the smallest value whose
        cumulative probability reaches ``prob``."""
        order = np.argsort(values, kind="stable")
        cumulative = np.cumsum(self.probabilities[order])
        index = min(int(np.searchsorted(cumulative, prob)), len(values) - 1)
        return float(values[order][index])

    def map_point(self) -> np.ndarray:
        return self.points[int(np.argmax(self.probabilities))]


def importance_reference(
    log_likelihood: LogLikelihood, num_features: int, size: int, rng: np.random.Generator, batch: int = 5000
) -> Reference:
    """The posterior as ``size`` uniform prior draws weighted by their likelihood."""
    points = random_unit_vectors(rng, size, num_features)
    ll = np.concatenate([log_likelihood(points[i : i + batch]) for i in range(0, size, batch)])
    p = np.exp(ll - ll.max())
    return Reference(points, p / p.sum())


def grid_reference(
    log_likelihood: LogLikelihood,
    num_points: int = 40_000,
    k: int = 3,
    rng: np.random.Generator | None = None,
) -> Reference:
    """The posterior tabulated on sphere points (``grid_posterior``: a Fibonacci grid for
    ``k = 3``, uniform points from ``rng`` otherwise)."""
    grid = grid_posterior(log_likelihood, num_points, k=k, rng=rng)
    return Reference(grid.points, grid.probabilities)


@dataclass(frozen=True)
class CheckResult:
    """One sampler run's bounds and diagnostics."""

    nevd_bound: float
    piob_bound: float
    rhat: float
    ess: float
    bound_ess: float
    converged: bool
    seconds: float


def check(
    log_likelihood: LogLikelihood,
    num_features: int,
    statistics: Statistics,
    config: SamplerConfig,
    rng: np.random.Generator,
    alpha: float = 0.95,
    delta: float = 0.05,
    method: QuantileMethod = "normal",
    initial: Callable[[np.random.Generator], np.ndarray] | None = None,
) -> CheckResult:
    """Sample the posterior and bound ``statistics``' α-VaR as ``mjsuff run`` does; ``initial``
    draws the chains' starting points (a prior's draws, where the prior is not the whole
    sphere)."""
    start = time.perf_counter()
    post = sample_posterior(
        log_likelihood, num_features, config, rng, initial=None if initial is None else initial(rng)
    )
    nevd, piob = statistics(post.samples)
    nevd_bound, piob_bound, nevd_ess = posterior_bounds(post, nevd, piob, alpha, delta, method)
    return CheckResult(
        nevd_bound,
        piob_bound,
        post.rhat,
        min(post.ess_bulk, post.ess_tail),
        nevd_ess,
        post.converged,
        time.perf_counter() - start,
    )
