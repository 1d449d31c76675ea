"""Per-sample regret and improvement of the robot's policy (paper Eqs. 5, 7, 11, 13).

All values come from feature expectations: ``V^π_w = w·μ_π`` (``μ`` per evaluation start).
"""

from __future__ import annotations

import numpy as np

_TINY = 1e-12


def normalized_evd(v_opt: np.ndarray, v_robot: np.ndarray, v_rand: np.ndarray) -> np.ndarray:
    """nEVD ``(V* − V^robot)/(V* − V^rand)`` (Eq. 5), 0 where the denominator vanishes."""
    num = v_opt - v_robot
    den = v_opt - v_rand
    safe = np.abs(den) > _TINY * (1.0 + np.abs(v_opt))
    return np.where(safe, num / np.where(safe, den, 1.0), 0.0)


def percent_improvement(v_robot: np.ndarray, v_base: np.ndarray) -> np.ndarray:
    """PIOB ``(V^robot − V^base)/|V^base|`` (Eq. 11); ±inf where ``V^base`` is exactly zero."""
    with np.errstate(divide="ignore", invalid="ignore"):
        out = (v_robot - v_base) / np.abs(v_base)
    return np.where(np.isnan(out), 0.0, out)


def policy_values(weights: np.ndarray, start_mu: np.ndarray, start_weights: np.ndarray) -> np.ndarray:
    """``V^π_w`` for weights ``(N, k)`` from per-start feature expectations ``(S, k)`` -> ``(N,)``."""
    return weights @ (start_weights @ start_mu)
