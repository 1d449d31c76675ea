"""Convergence diagnostics for several MCMC chains."""

from __future__ import annotations

import numpy as np


def split_rhat(chains: np.ndarray) -> float:
    """Largest split-R̂ (Gelman et al., BDA3 §11.4) over coordinates.

    Args:
        chains: ``(chains, draws, k)`` samples; each chain is split in half.

    Returns:
        ``max_k R̂_k``; values near 1 mean the chains agree. NaN when a coordinate is constant.
    """
    n = chains.shape[1]
    half = n // 2
    if half < 2:
        return float("nan")
    split = np.concatenate([chains[:, :half], chains[:, half : 2 * half]], axis=0)
    means = split.mean(axis=1)  # (m, k)
    within = split.var(axis=1, ddof=1).mean(axis=0)  # (k,)
    between = half * means.var(axis=0, ddof=1)  # (k,)
    var_plus = (half - 1) / half * within + between / half
    with np.errstate(divide="ignore", invalid="ignore"):
        rhat = np.sqrt(var_plus / within)
    rhat = rhat[np.isfinite(rhat)]
    return float(rhat.max()) if rhat.size else float("nan")
