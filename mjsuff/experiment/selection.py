"""Active selection: the start the next demonstration comes from (paper Eq. 13); the passive
order is ``mjsuff.demo_schedule``."""

from __future__ import annotations

import numpy as np

from mjsuff.bounds.var_bound import QuantileMethod, var_bound_index


def active_choice(
    per_start_evd: np.ndarray,
    asked: set[int],
    alpha: float,
    delta: float,
    method: QuantileMethod = "normal",
    ess: float | None = None,
) -> int:
    """The pool start whose (1−δ)-confidence α-VaR of per-start EVD is largest (Eq. 13).

    Args:
        per_start_evd: ``(N, P)`` unnormalized EVD ``V*_i(s) − V^robot_i(s)`` per sample and start.
        asked: Pool starts already demonstrated (never asked again).
        ess: Effective size of the samples (None: independent), as for the nEVD bound.
    """
    n, p = per_start_evd.shape
    j = var_bound_index(n, alpha, delta, method, ess)
    bounds = np.partition(per_start_evd, j, axis=0)[j]
    open_ = np.ones(p, dtype=bool)
    open_[list(asked)] = False
    if not open_.any():
        raise ValueError("every start in the pool has been asked already")
    bounds = np.where(open_, bounds, -np.inf)
    return int(np.argmax(bounds))
