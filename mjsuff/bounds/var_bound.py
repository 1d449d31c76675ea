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
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from scipy.stats import binom, norm

QuantileMethod = Literal["normal", "binomial"]


def var_bound_index(n: int, alpha: float, delta: float, method: QuantileMethod = "normal") -> int:
    """0-based index of the order statistic that bounds the α-VaR with confidence ``1 − δ``."""
    if n < 1:
        raise ValueError(f"need at least one sample, got n={n}")
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    if not 0.0 < delta < 1.0:
        raise ValueError(f"delta must be in (0, 1), got {delta}")
    if method == "normal":
        j = math.ceil(n * alpha + norm.ppf(1.0 - delta) * math.sqrt(n * alpha * (1 - alpha)) - 0.5)
    elif method == "binomial":
        j = int(binom.ppf(1.0 - delta, n, alpha))
    else:
        raise ValueError(f"method must be 'normal' or 'binomial', got {method!r}")
    return min(max(j, 0), n - 1)


def upper_var_bound(values: np.ndarray, alpha: float, delta: float,
                    method: QuantileMethod = "normal") -> float:
    """``(1−δ)``-confidence upper bound on the α-VaR of ``values`` (used for nEVD, Eq. 6)."""
    values = np.asarray(values, dtype=float).ravel()
    if not np.all(np.isfinite(values)):
        raise ValueError("VaR bound needs finite samples")
    j = var_bound_index(values.size, alpha, delta, method)
    return float(np.partition(values, j)[j])


def lower_var_bound(values: np.ndarray, alpha: float, delta: float,
                    method: QuantileMethod = "normal") -> float:
    """``(1−δ)``-confidence lower bound on the ``(1−α)``-quantile (used for PIOB, Eq. 12)."""
    return -upper_var_bound(-np.asarray(values, dtype=float), alpha, delta, method)
