"""Convergence diagnostics of several MCMC chains (Vehtari et al. 2021), from ``arviz-stats``.

* rank-normalized split-R̂: the larger of the bulk and folded R̂ (``method="rank"``), near 1 when
  every chain explores the same distribution;
* bulk-ESS and tail-ESS: effective sample sizes of the rank-normalized draws and of the 5% / 95%
  quantile indicators;
* quantile ESS: the effective size of the indicator ``X ≤ q̂_p`` — the sample size an order
  statistic near the ``p``-quantile behaves as if it had (used for the α-VaR bound's index).

Draw arrays are laid out ``(chains, draws, …)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from arviz_stats.base import array_stats


@dataclass(frozen=True)
class ChainDiagnostics:
    """Worst-coordinate diagnostics of ``(chains, draws, k)`` samples.

    Attributes:
        rhat: Largest rank-normalized split-R̂ over the ``k`` coordinates.
        ess_bulk: Smallest bulk-ESS over the coordinates.
        ess_tail: Smallest tail-ESS over the coordinates.
    """

    rhat: float
    ess_bulk: float
    ess_tail: float

    @property
    def ess(self) -> float:
        """``min(ess_bulk, ess_tail)``."""
        return min(self.ess_bulk, self.ess_tail)


def _worst(values: np.ndarray, largest: bool) -> float:
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    if not values.size:
        return float("nan")
    return float(values.max() if largest else values.min())


def _by_coordinate(chains: np.ndarray) -> np.ndarray:
    chains = np.asarray(chains, dtype=float)
    if chains.ndim != 3:
        raise ValueError(f"expected (chains, draws, k) samples, got shape {chains.shape}")
    return np.moveaxis(chains, -1, 0)  # (k, chains, draws)


def rank_rhat(chains: np.ndarray) -> float:
    """Largest rank-normalized split-R̂ over coordinates of ``(chains, draws, k)`` samples.

    NaN when no coordinate has a defined R̂ (e.g. every draw is the same).
    """
    return _worst(array_stats.rhat(_by_coordinate(chains), method="rank"), largest=True)


def chain_diagnostics(chains: np.ndarray) -> ChainDiagnostics:
    """R̂ and the bulk- and tail-ESS of ``(chains, draws, k)`` samples, worst coordinate each."""
    return ChainDiagnostics(rank_rhat(chains), *effective_sizes(chains))


def effective_sizes(chains: np.ndarray) -> tuple[float, float]:
    """Smallest bulk-ESS and smallest tail-ESS over coordinates of ``(chains, draws, k)`` samples."""
    x = _by_coordinate(chains)
    return (
        _worst(array_stats.ess(x, method="bulk"), largest=False),
        _worst(array_stats.ess(x, method="tail", prob=(0.05, 0.95)), largest=False),
    )


def quantile_ess(draws: np.ndarray, prob: float) -> float:
    """Effective sample size of the ``prob``-quantile of ``(chains, draws)`` scalar draws.

    It is the ESS of the indicator ``X ≤ q̂_prob``. NaN when that indicator is constant over
    every draw (an atom at the quantile: its ESS is undefined).
    """
    draws = np.asarray(draws, dtype=float)
    if draws.ndim != 2:
        raise ValueError(f"expected (chains, draws) values, got shape {draws.shape}")
    q = np.quantile(draws, prob)
    below = draws <= q
    if below.all() or not below.any():
        return float("nan")
    return float(array_stats.ess(draws, method="quantile", prob=prob))
