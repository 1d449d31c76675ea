"""The scenes' trajectory likelihood: a Boltzmann choice of each demo among its candidate set.

``log P(φ_j | w) = β w·φ_j − log Σ_{φ ∈ C_j} exp(β w·φ)`` (DESIGN, trajectory-level Bayesian IRL;
the paper's Eq. 1 with trajectories for actions), ``φ_j`` the demo's features and ``C_j`` its
candidate set (``mjsuff.scenes.candidates``), the demo first. For a batch of weights a demo costs
one matrix product and one log-sum-exp per row; the demos are independent, so large batches
share them among threads (NumPy and BLAS release the GIL), each demo's column computed exactly
as it would be alone.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from mjsuff.threads import thread_budget

#: Below this many (weight, candidate) products a batch is not worth a thread's hand-off.
PARALLEL_PRODUCTS = 200_000

_pool: tuple[int, ThreadPoolExecutor] | None = None


def row_log_sum_exp(values: np.ndarray) -> np.ndarray:
    """``log Σ_m exp(values[n, m])`` per row of a finite ``(N, M)`` array -> ``(N,)``.

    SciPy's algorithm (``scipy.special.logsumexp``, 1.17: the maxima taken out of the sum, which
    goes through ``log1p``), written for finite 2-D rows without its array-API dispatch and
    copies: the same operations in the same order, so the same rounding, at a third of the time.
    """
    row_max = values.max(axis=1, keepdims=True)
    at_max = values == row_max
    terms = np.exp(values - row_max)
    terms[at_max] = 0.0
    rest = terms.sum(axis=1, keepdims=True)
    ties = at_max.sum(axis=1, keepdims=True, dtype=float)
    rest = np.where(rest == 0, rest, rest / ties)
    return (np.log1p(rest) + np.log(ties) + row_max)[:, 0]


def demo_log_likelihoods(
    weights: np.ndarray, candidate_sets: Sequence[np.ndarray], beta: float
) -> np.ndarray:
    """``log P(φ_j | w)`` of each demo for weights ``(N, k)`` -> ``(N, D)``.

    Args:
        weights: Reward weights, one per row.
        candidate_sets: Per demo its candidate set's features ``(M_j, k)``, the demo first.
        beta: The demonstrator's rationality β (per unit of ``w·φ``).
    """
    weights = np.atleast_2d(weights)
    per_demo = np.zeros((len(weights), len(candidate_sets)))

    def column(j: int) -> None:
        values = beta * (weights @ candidate_sets[j].T)
        per_demo[:, j] = values[:, 0] - row_log_sum_exp(values)

    products = len(weights) * sum(len(c) for c in candidate_sets)
    pool = _shared_pool() if len(candidate_sets) > 1 and products >= PARALLEL_PRODUCTS else None
    if pool is None:
        for j in range(len(candidate_sets)):
            column(j)
    else:
        list(pool.map(column, range(len(candidate_sets))))
    return per_demo


def _shared_pool() -> ThreadPoolExecutor | None:
    """This process's threads for the likelihood (``thread_budget()`` of them; none with one);
    made again in a forked child, which does not inherit the parent's threads."""
    global _pool
    threads = thread_budget()
    if threads < 2:
        return None
    if _pool is None or _pool[0] != os.getpid():
        _pool = (os.getpid(), ThreadPoolExecutor(max_workers=threads, thread_name_prefix="mjsuff-likelihood"))
    return _pool[1]
