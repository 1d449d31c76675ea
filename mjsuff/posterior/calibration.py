"""Calibrating the likelihood's rationality β from demos whose reward is known.

The paper (§6.2) leaves β to a calibration stage before demonstration collection. Here it is the
maximum-likelihood β of demos under their known weights: ``β̂ = argmax_β Σ_j log P(d_j | w*, β)``
with the same likelihood the posterior uses (Eq. 1, or the trajectory-level form of the MuJoCo
scenes). The log-likelihood is concave in β (its second derivative is minus the variance of the
demo's candidates' values under the Boltzmann choice), so a bounded 1-D search on ``log β`` finds
the maximum. When every demo is the best of its alternatives the likelihood rises without bound
and no finite β fits; the fit says so instead of returning the search's upper end.

The lapse rate ε (``mjsuff.posterior.likelihood``) is fitted the same way when asked, by profile
likelihood: β̂(ε) for each ε of a grid, and the ε whose fit is best. The grid stops at 0.5: a
demonstrator who lapses more often than not is not one to learn from.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from scipy.optimize import minimize_scalar

from mjsuff.errors import MjsuffError

#: Search range for β.
BETA_RANGE = (0.01, 1000.0)
#: The lapse rates the profile likelihood compares (step 0.025).
LAPSE_GRID = tuple(round(0.025 * i, 3) for i in range(21))
#: Log-likelihood difference below which the upper end of the range counts as the maximum.
PLATEAU = 1e-6


class CalibrationError(MjsuffError, ValueError):
    """The log-likelihood cannot be fitted (not finite over the search range)."""


@dataclass(frozen=True)
class BetaFit:
    """A maximum-likelihood β.

    Attributes:
        beta: The fitted β; the search's upper end when ``unbounded``.
        log_likelihood: The log-likelihood at ``beta``.
        at_lower: The maximum is at the lower end of the search: the demos are no better than
            their alternatives under the known weights (a best β ≤ ``low``), so the demos carry
            next to no evidence about the reward; ``standard_error`` is then ``inf``.
        unbounded: The likelihood at the upper end of the search is within ``PLATEAU`` of the
            maximum found: it still rises there, or has flattened onto its supremum (every demo is
            the best of its alternatives, or tied with the best, under the known weights), so
            any large β fits.
        standard_error: ``1 / sqrt(−ℓ''(β̂))`` from the observed information; ``inf`` when
            unbounded or when the curvature vanishes.
    """

    beta: float
    log_likelihood: float
    unbounded: bool
    standard_error: float
    at_lower: bool = False


def fit_beta(
    log_likelihood: Callable[[float], float], beta_range: tuple[float, float] = BETA_RANGE
) -> BetaFit:
    """The β maximizing ``log_likelihood(β)`` within ``beta_range`` (both > 0).

    Raises:
        ValueError: If the range is not ``0 < low < high``.
        CalibrationError: If the log-likelihood is not finite somewhere it is evaluated.
    """
    low, high = beta_range
    if not 0.0 < low < high:
        raise ValueError(f"beta_range: expected 0 < low < high, got {beta_range}")

    def value(beta: float) -> float:
        v = float(log_likelihood(beta))
        if not math.isfinite(v):
            raise CalibrationError(f"log-likelihood at β = {beta:.4g} is {v}")
        return v

    def loss(log_beta: float) -> float:
        return -value(math.exp(log_beta))

    result = minimize_scalar(
        loss, bounds=(math.log(low), math.log(high)), method="bounded", options={"xatol": 1e-6}
    )
    beta, best = math.exp(float(result.x)), -float(result.fun)
    # Unbounded when the upper end is as good as the best point found: the likelihood still
    # climbs there, or has flattened onto its supremum (demos tied with their best alternative).
    top = value(high)
    if top >= best - PLATEAU:
        return BetaFit(high, top, True, math.inf)
    bottom = value(low)
    if bottom >= best - PLATEAU:
        return BetaFit(low, bottom, False, math.inf, at_lower=True)
    h = 1e-3 * beta
    curvature = (value(beta + h) - 2.0 * best + value(beta - h)) / h**2
    se = 1.0 / math.sqrt(-curvature) if curvature < 0 else math.inf
    return BetaFit(beta, best, False, se)


@dataclass(frozen=True)
class LapseFit:
    """A maximum-likelihood lapse rate and the β that goes with it.

    Attributes:
        lapse: The fitted lapse rate ε̂ (a point of the grid searched).
        fit: β̂ at ε̂.
        profile: ``(ε, log-likelihood at β̂(ε))`` for every ε searched.
    """

    lapse: float
    fit: BetaFit
    profile: tuple[tuple[float, float], ...]


def fit_lapse(
    log_likelihood: Callable[[float, float], float],
    lapses: tuple[float, ...] = LAPSE_GRID,
    beta_range: tuple[float, float] = BETA_RANGE,
) -> LapseFit:
    """The ``(ε, β)`` maximizing ``log_likelihood(β, ε)``: ``fit_beta`` at each ε of ``lapses``
    (each in ``[0, 1)``), and the best (the smallest ε among equals).

    Raises:
        ValueError: If ``lapses`` is empty or holds a rate outside ``[0, 1)``.
        CalibrationError: As ``fit_beta``.
    """
    if not lapses or not all(0.0 <= e < 1.0 for e in lapses):
        raise ValueError(f"lapses: expected rates in [0, 1), got {lapses}")
    fits = [(e, fit_beta(at_lapse(log_likelihood, e), beta_range)) for e in sorted(lapses)]
    best_lapse, best = max(fits, key=lambda ef: (ef[1].log_likelihood, -ef[0]))
    return LapseFit(best_lapse, best, tuple((e, f.log_likelihood) for e, f in fits))


def at_lapse(log_likelihood: Callable[[float, float], float], lapse: float) -> Callable[[float], float]:
    """``log_likelihood(β, ε)`` as a function of β alone, at ε = ``lapse``."""
    return lambda beta: log_likelihood(beta, lapse)
