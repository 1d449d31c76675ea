"""High-confidence bounds on the α-Value-at-Risk from posterior samples (paper §3.4, Alg. 1).

Sorting ``n`` samples gives order statistics ``Z_0 ≤ … ≤ Z_{n−1}``. The number of samples below
the α-quantile is Binomial(n, α), so ``Z_j`` upper-bounds the α-VaR with confidence
``F(j; n, α)`` (Eqs. 8–9). Two ways to pick ``j`` for confidence ``1 − δ``:

* ``"normal"`` — Algorithm 1's normal approximation with continuity correction,
  ``j = ⌈nα + Φ⁻¹(1−δ)·√(nα(1−α)) − ½⌉`` (the paper's and mjsuff's default);
* ``"binomial"`` — the exact ``j = F⁻¹(1 − δ; n, α)``, the smallest ``j`` with ``F(j) ≥ 1 − δ``.

Both are clipped to ``n − 1``. The lower bound used by PIOB (Eq. 12) is the mirror image: a
``(1−δ)``-confidence lower bound on the ``(1−α)``-quantile of ``X`` is minus the upper bound on
the α-quantile of ``−X``.

**Dependent draws.** Eqs. 8–9 assume ``n`` independent samples. MCMC draws are correlated, so the
count of draws below the α-quantile varies more than Binomial(n, α): about as much as
``(n / n_eff)·Binomial(n_eff, α)``, where ``n_eff`` is the effective sample size of the indicator
``X ≤ q_α`` (the quantile ESS, ``mjsuff.posterior.diagnostics.quantile_ess``). Given ``ess``, the
index keeps its confidence for the draws it gets:

* ``"normal"``: ``j = ⌈nα + Φ⁻¹(1−δ)·n·√(α(1−α)/n_eff) − ½⌉``;
* ``"binomial"``: ``j = ⌈(n/m)·F⁻¹(1 − δ; m, α)⌉`` with ``m = ⌊n_eff⌋``.

With ``n_eff = n`` both are the independent-sample indices above; ``n_eff`` is capped at ``n``.
When ``n_eff`` is too small for any order statistic to keep the confidence, the index clips to
``n − 1`` and ``bound_is_valid`` says so.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from scipy.stats import binom, norm

QuantileMethod = Literal["normal", "binomial"]


def _raw_index(n: int, alpha: float, delta: float, method: QuantileMethod, ess: float | None) -> int:
    if n < 1:
        raise ValueError(f"need at least one sample, got n={n}")
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    if not 0.0 < delta < 1.0:
        raise ValueError(f"delta must be in (0, 1), got {delta}")
    if ess is not None and not ess > 0.0:
        raise ValueError(f"effective sample size must be positive, got {ess}")
    n_eff = n if ess is None else min(float(ess), float(n))
    if method == "normal":
        spread = norm.ppf(1.0 - delta) * n * math.sqrt(alpha * (1 - alpha) / n_eff)
        return math.ceil(n * alpha + spread - 0.5)
    if method == "binomial":
        m = max(int(n_eff), 1)
        return math.ceil(n / m * binom.ppf(1.0 - delta, m, alpha) - 1e-9)
    raise ValueError(f"method must be 'normal' or 'binomial', got {method!r}")


def var_bound_index(
    n: int, alpha: float, delta: float, method: QuantileMethod = "normal", ess: float | None = None
) -> int:
    """0-based index of the order statistic of ``n`` draws that bounds the α-VaR with confidence
    ``1 − δ``; ``ess`` is the draws' effective sample size (None: independent draws)."""
    return min(max(_raw_index(n, alpha, delta, method, ess), 0), n - 1)


def bound_is_valid(
    n: int, alpha: float, delta: float, method: QuantileMethod = "normal", ess: float | None = None
) -> bool:
    """True when ``n`` draws of effective size ``ess`` have an order statistic with the promised
    confidence (the index needs no clipping)."""
    return _raw_index(n, alpha, delta, method, ess) <= n - 1


def least_effective_size(n: int, alpha: float, delta: float, method: QuantileMethod = "normal") -> int | None:
    """The smallest effective size for which ``n`` draws keep the confidence (``bound_is_valid``),
    or None when even independent draws are too few."""
    if not bound_is_valid(n, alpha, delta, method, n):
        return None
    lo, hi = 1, n  # bound_is_valid is monotone in the effective size
    while lo < hi:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if bound_is_valid(n, alpha, delta, method, mid) else (mid + 1, hi)
    return lo


def upper_var_bound(
    values: np.ndarray,
    alpha: float,
    delta: float,
    method: QuantileMethod = "normal",
    ess: float | None = None,
) -> float:
    """``(1−δ)``-confidence upper bound on the α-VaR of ``values`` (used for nEVD, Eq. 6)."""
    values = np.asarray(values, dtype=float).ravel()
    if not np.all(np.isfinite(values)):
        raise ValueError("VaR bound needs finite samples")
    j = var_bound_index(values.size, alpha, delta, method, ess)
    return float(np.partition(values, j)[j])


def lower_var_bound(
    values: np.ndarray,
    alpha: float,
    delta: float,
    method: QuantileMethod = "normal",
    ess: float | None = None,
) -> float:
    """``(1−δ)``-confidence lower bound on the ``(1−α)``-quantile (used for PIOB, Eq. 12)."""
    return -upper_var_bound(-np.asarray(values, dtype=float), alpha, delta, method, ess)
