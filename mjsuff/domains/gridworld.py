"""Gridworld (paper §4.1): a grid of one-hot terrain features with one absorbing goal cell.

Each non-goal cell carries one of ``num_features − 1`` terrain features, the goal cell the last
feature. Moves (up, down, left, right) are deterministic; bumping into the border stays put. True
weights are a uniform draw from the unit sphere, sorted so the goal feature has the largest weight
(as in the paper's code). The start distribution is uniform over all cells.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from mjsuff.domains.tabular import TabularDomain, TabularMDP
from mjsuff.sphere import random_unit_vectors

#: (row, column) displacement of the four actions: up, down, left, right.
MOVES = ((-1, 0), (1, 0), (0, -1), (0, 1))


class GridworldParams(BaseModel):
    """Instance parameters of a gridworld."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)

    rows: int = Field(5, ge=2, le=12, description="grid rows (dense solver: at most 144 cells)")
    cols: int = Field(5, ge=2, le=12, description="grid columns")
    num_features: int = Field(4, ge=2, le=10, description="k: terrain features + 1 goal feature")
    gamma: float = Field(0.95, ge=0.0, lt=1.0, description="discount factor")


def grid_transitions(rows: int, cols: int, terminal: np.ndarray) -> np.ndarray:
    """Deterministic 4-action grid moves -> ``P`` of shape ``(S, 4, S)``."""
    n = rows * cols
    p = np.zeros((n, len(MOVES), n))
    for s in range(n):
        if terminal[s]:
            continue
        r, c = divmod(s, cols)
        for a, (dr, dc) in enumerate(MOVES):
            rr, cc = r + dr, c + dc
            if not (0 <= rr < rows and 0 <= cc < cols):
                rr, cc = r, c
            p[s, a, rr * cols + cc] = 1.0
    return p


def make_gridworld(params: GridworldParams, rng: np.random.Generator) -> TabularDomain:
    """A random gridworld instance: terrain, goal cell, and hidden ``w*`` drawn from ``rng``."""
    n = params.rows * params.cols
    k = params.num_features
    goal = int(rng.integers(n))
    terrain = rng.integers(k - 1, size=n)
    terrain[goal] = k - 1
    features = np.eye(k)[terrain]
    terminal = np.zeros(n, dtype=bool)
    terminal[goal] = True
    mdp = TabularMDP(grid_transitions(params.rows, params.cols, terminal), features, params.gamma,
                     terminal)
    true_weights = np.sort(random_unit_vectors(rng, 1, k)[0])
    baseline = rng.integers(len(MOVES), size=n)
    layout = np.stack(np.divmod(np.arange(n), params.cols), axis=1)
    return TabularDomain(mdp, true_weights, np.full(n, 1.0 / n), baseline, layout)
