"""Baseline policies of the PIOB rule for the tabular domains (``domain.params.baseline``).

* ``"random"`` — a uniformly random deterministic policy, one action per state (this package's
  original baseline; the default).
* ``"nonpessimal"`` — the paper's code (``mdp_utils.get_nonpessimal_policy``): per state, a
  uniformly random action among those whose ``Q`` under the **true** reward is not the minimum
  (every action when all are equal, e.g. in a terminal state). It is a deterministic policy drawn
  once per world, like the paper's. The paper compares Q-values with exact equality; here an
  action within a relative 1e-9 of the minimum counts as minimal, so floating-point noise cannot
  split exact ties (for example two moves into the same wall).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from mjsuff.domains.tabular import OptimalPolicyCache, TabularMDP

BaselineKind = Literal["random", "nonpessimal"]

_TIE_TOL = 1e-9


def nonpessimal_actions(q: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Per state, a uniform choice among the actions whose ``Q`` is not minimal: ``(S, A)`` ->
    ``(S,)``; every action is allowed where all are (within tolerance) equal."""
    low = q.min(axis=1, keepdims=True)
    allowed = q > low + _TIE_TOL * (1.0 + np.abs(low))
    allowed[~allowed.any(axis=1)] = True
    counts = allowed.sum(axis=1)
    # The j-th allowed action of each state, j uniform in [0, count): one uniform draw per state.
    pick = np.minimum((rng.random(q.shape[0]) * counts).astype(np.int64), counts - 1)
    ranks = np.cumsum(allowed, axis=1) - 1
    return np.argmax(allowed & (ranks == pick[:, None]), axis=1)


def draw_baseline(
    kind: BaselineKind, mdp: TabularMDP, true_weights: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """A baseline policy (one action per state) of the given kind, drawn from ``rng``.

    ``"random"`` makes exactly the draw the domains always made (``rng.integers(A, size=S)``), so
    instances of the default variant are unchanged.
    """
    if kind == "random":
        return rng.integers(mdp.num_actions, size=mdp.num_states)
    if kind == "nonpessimal":
        w = np.asarray(true_weights, dtype=float)
        q = OptimalPolicyCache(mdp).solve((w / np.linalg.norm(w))[None])[0][0]
        return nonpessimal_actions(q, rng)
    raise ValueError(f"unknown baseline {kind!r}; expected 'random' or 'nonpessimal'")
