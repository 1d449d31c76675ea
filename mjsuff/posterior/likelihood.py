"""The demonstrations' likelihood: a Boltzmann-rational demonstrator who sometimes lapses.

Each demo ``d_j`` chooses among its alternatives ``C_j`` (the actions at its state for tabular
domains, Eq. 1; its candidate trajectories for the scenes). With probability ``1 − ε`` the choice
is Boltzmann-rational, ``P_β(d_j | w)`` (Eq. 1); with probability ``ε``, the *lapse rate*, it is a
uniform pick among the ``|C_j|`` alternatives whatever the reward:

    log P(D | w) = Σ_j log[(1 − ε) · P_β(d_j | w) + ε / |C_j|].

``ε = 0`` is the paper's likelihood, Eq. 1, term for term. With ``ε > 0`` no single demo can cost a
reward more than ``log(ε / |C_j|)``, so a poor demo (one the demonstrator's own reward ranks low)
no longer rules out the true reward; the price is a flatter posterior when every demo is good.

Assumptions: lapses are independent of each other and of ``w``; ``|C_j|`` is the set the domain's
Boltzmann term normalizes over, so a lapse picks the demo with probability ``1 / |C_j|``.
"""

from __future__ import annotations

import math

import numpy as np


def lapse_log_likelihood(per_demo: np.ndarray, choices: np.ndarray, lapse: float) -> np.ndarray:
    """``Σ_j log[(1 − ε) P_β(d_j | w) + ε / |C_j|]`` per weight vector -> ``(N,)``.

    Args:
        per_demo: Boltzmann log-likelihoods ``log P_β(d_j | w)``, shape ``(N, D)`` (N weight
            vectors, D demos).
        choices: ``|C_j|``, the number of alternatives each demo chose among, shape ``(D,)``.
        lapse: The lapse rate ``ε`` in ``[0, 1)``.

    Raises:
        ValueError: If ``lapse`` is outside ``[0, 1)``, ``choices`` is not ``(D,)`` or holds a
            count below 1.
    """
    per_demo = np.asarray(per_demo, dtype=float)
    choices = np.asarray(choices, dtype=float)
    if not 0.0 <= lapse < 1.0:
        raise ValueError(f"lapse rate must be in [0, 1), got {lapse}")
    if per_demo.ndim != 2 or choices.shape != per_demo.shape[1:]:
        shapes = f"{per_demo.shape} and {choices.shape}"
        raise ValueError(f"per_demo must be (N, D) and choices (D,), got {shapes}")
    if np.any(choices < 1):
        raise ValueError(f"every demo chooses among at least 1 alternative, got {choices.tolist()}")
    total = np.zeros(per_demo.shape[0])
    if lapse == 0.0:
        terms = per_demo
    else:
        terms = np.logaddexp(math.log(1.0 - lapse) + per_demo, math.log(lapse) - np.log(choices))
    for column in terms.T:  # demo by demo, in order (numpy's pairwise sum would round otherwise)
        total += column
    return total
