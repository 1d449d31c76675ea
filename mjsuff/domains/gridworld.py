"""Gridworld (paper §4.1): a grid of one-hot terrain features with one absorbing (terminal) cell.

Moves (up, down, left, right) are deterministic; bumping into the border stays put. The start
distribution is uniform over all cells. Two world variants (``world``):

* ``"goal"`` (default): each non-terminal cell carries one of ``num_features − 1`` terrain
  features, the terminal cell the last one (the goal); true weights are a uniform draw from the
  unit sphere, sorted so the goal feature has the largest weight (``random_feature_mdp`` with
  ``goal=True`` in the paper's code, which no experiment of the paper uses).
* ``"paper"``: as the paper's experiments call ``random_feature_mdp``: every cell carries one of
  ``num_features`` terrain features drawn uniformly, the weights are a uniform draw from the unit
  sphere, **not** sorted, and one random terminal cell keeps its random terrain feature.

The PIOB baseline policy is ``baseline`` (``mjsuff.domains.baselines``): a random deterministic
policy (default) or the paper's non-pessimal policy under the true reward.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from mjsuff.domains.baselines import BaselineKind, draw_baseline
from mjsuff.domains.tabular import TabularDomain, TabularMDP
from mjsuff.sphere import random_unit_vectors

#: (row, column) displacement of the four actions: up, down, left, right.
MOVES = ((-1, 0), (1, 0), (0, -1), (0, 1))


class GridworldParams(BaseModel):
    """Instance parameters of a gridworld."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)

    rows: int = Field(5, ge=2, le=12, description="grid rows (dense solver: at most 144 cells)")
    cols: int = Field(5, ge=2, le=12, description="grid columns")
    num_features: int = Field(
        4,
        ge=2,
        le=10,
        description="k: terrain features + 1 goal feature (world 'goal'), or terrain features "
        "(world 'paper')",
    )
    gamma: float = Field(0.95, ge=0.0, lt=1.0, description="discount factor")
    world: Literal["goal", "paper"] = Field(
        "goal",
        description="'goal': a goal feature on the terminal cell, sorted weights; "
        "'paper': the paper's experiments' worlds (no goal feature, unsorted)",
    )
    baseline: BaselineKind = Field(
        "random",
        description="PIOB baseline: 'random' deterministic policy, or the paper's 'nonpessimal' "
        "policy under the true reward",
    )


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
    """A random gridworld instance: terrain, terminal cell, hidden ``w*`` and the PIOB baseline,
    drawn from ``rng`` in that order (the ``"goal"`` world with the ``"random"`` baseline makes
    the same draws as before these variants existed)."""
    n = params.rows * params.cols
    k = params.num_features
    goal = int(rng.integers(n))
    if params.world == "goal":
        terrain = rng.integers(k - 1, size=n)
        terrain[goal] = k - 1
    else:
        terrain = rng.integers(k, size=n)
    features = np.eye(k)[terrain]
    terminal = np.zeros(n, dtype=bool)
    terminal[goal] = True
    mdp = TabularMDP(grid_transitions(params.rows, params.cols, terminal), features, params.gamma, terminal)
    true_weights = random_unit_vectors(rng, 1, k)[0]
    if params.world == "goal":
        true_weights = np.sort(true_weights)
    baseline = draw_baseline(params.baseline, mdp, true_weights, rng)
    layout = np.stack(np.divmod(np.arange(n), params.cols), axis=1)
    return TabularDomain(mdp, true_weights, np.full(n, 1.0 / n), baseline, layout)
