"""Driving (paper §4.1): a wrapping road of 3 lanes between 2 off-road borders, with motorists.

The car advances one row per step (the road wraps) and chooses to stay in its column or move one
column left or right; moving past a border keeps the column. Features (k = 5), one-hot per cell:
left lane, middle lane, right lane, collision (a motorist's cell), off-road (a border cell). True
weights are integers drawn uniformly from ranges of the paper's ``random_driving_simulator``, then
normalized (``weight_ranges``):

* ``"default"`` (``reward_function=None`` there): lanes {1..9} each, collision {−20..−11},
  off-road {−10..−1};
* ``"safe"`` (``reward_function="safe"``, what every experiment of the paper uses): left and middle
  lane {1..4}, right lane {5..9}, collision {−10..−6}, off-road {−5..−1}.

The start distribution is uniform over all cells; there is no terminal. The PIOB baseline policy is
``baseline`` (``mjsuff.domains.baselines``): a random deterministic policy (default) or the paper's
non-pessimal policy under the true reward.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from mjsuff.domains.baselines import BaselineKind, draw_baseline
from mjsuff.domains.tabular import TabularDomain, TabularMDP

LANE_COLUMNS = (1, 2, 3)
NUM_COLUMNS = 5
#: Column change of the three actions: stay, left, right.
STEERING = (0, -1, 1)
FEATURE_NAMES = ("left_lane", "middle_lane", "right_lane", "collision", "off_road")
#: Half-open integer ranges ``[low, high)`` of the five true weights, per ``weight_ranges`` variant
#: (``np.random.randint`` bounds of the paper's ``random_driving_simulator``).
WEIGHT_RANGES = {
    "default": ((1, 10), (1, 10), (1, 10), (-20, -10), (-10, 0)),
    "safe": ((1, 5), (1, 5), (5, 10), (-10, -5), (-5, 0)),
}


class DrivingParams(BaseModel):
    """Instance parameters of the driving domain."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)

    rows: int = Field(5, ge=2, le=40, description="road length in rows (the road wraps)")
    motorists: int = Field(5, ge=0, description="number of other cars, placed in lane cells")
    gamma: float = Field(0.95, ge=0.0, lt=1.0, description="discount factor")
    weight_ranges: Literal["default", "safe"] = Field(
        "default", description="ranges of the true weights: 'default' or the paper's 'safe'"
    )
    baseline: BaselineKind = Field(
        "random",
        description="PIOB baseline: 'random' deterministic policy, or the paper's 'nonpessimal' "
        "policy under the true reward",
    )

    @model_validator(mode="after")
    def _motorists_fit(self) -> DrivingParams:
        lane_cells = len(LANE_COLUMNS) * self.rows
        if self.motorists > lane_cells:
            raise ValueError(f"motorists must be at most {lane_cells} (3 lanes x {self.rows} rows)")
        return self


def road_transitions(rows: int) -> np.ndarray:
    """Deterministic driving moves -> ``P`` of shape ``(S, 3, S)``."""
    n = rows * NUM_COLUMNS
    p = np.zeros((n, len(STEERING), n))
    for s in range(n):
        r, c = divmod(s, NUM_COLUMNS)
        for a, dc in enumerate(STEERING):
            cc = min(max(c + dc, 0), NUM_COLUMNS - 1)
            p[s, a, ((r + 1) % rows) * NUM_COLUMNS + cc] = 1.0
    return p


def make_driving(params: DrivingParams, rng: np.random.Generator) -> TabularDomain:
    """A random driving instance: motorist cells, hidden ``w*`` and the PIOB baseline, drawn from
    ``rng`` in that order (the default variants make the same draws as before they existed)."""
    n = params.rows * NUM_COLUMNS
    lanes = [s for s in range(n) if s % NUM_COLUMNS in LANE_COLUMNS]
    if params.motorists > len(lanes):
        raise ValueError(f"motorists must be at most {len(lanes)} (lane cells), got {params.motorists}")
    cars = rng.choice(lanes, size=params.motorists, replace=False)
    kind = np.empty(n, dtype=np.int64)
    for s in range(n):
        c = s % NUM_COLUMNS
        kind[s] = 4 if c in (0, NUM_COLUMNS - 1) else c - 1
    kind[cars] = 3
    features = np.eye(len(FEATURE_NAMES))[kind]
    # One scalar draw per weight in feature order, as the paper's code (and this module) always drew.
    ranges = WEIGHT_RANGES[params.weight_ranges]
    weights = np.array([rng.integers(low, high) for low, high in ranges], dtype=float)
    terminal = np.zeros(n, dtype=bool)
    mdp = TabularMDP(road_transitions(params.rows), features, params.gamma, terminal)
    baseline = draw_baseline(params.baseline, mdp, weights, rng)
    layout = np.stack(np.divmod(np.arange(n), NUM_COLUMNS), axis=1)
    return TabularDomain(mdp, weights, np.full(n, 1.0 / n), baseline, layout)
