"""A domain from outside mjsuff: a chain MDP, registered by import path (README, "Add a domain").

Run it with a scenario whose ``[domain]`` says ``name = "chain_domain:SPEC"`` and this folder on
``PYTHONPATH``: ``PYTHONPATH=examples mjsuff run examples/chain.toml``.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from mjsuff.domains import DomainSpec, TabularDomain, TabularMDP
from mjsuff.sphere import random_unit_vectors


class ChainParams(BaseModel):
    """``domain.params`` of the chain (validated on load, like every domain's)."""

    model_config = ConfigDict(extra="forbid", strict=True)

    length: int = Field(8, ge=3, le=100, description="states in the chain; the last is terminal")
    kinds: int = Field(3, ge=2, le=10, description="terrain kinds: one-hot features (k)")
    gamma: float = Field(0.9, ge=0.0, lt=1.0, description="discount factor")


def make_chain(params: ChainParams, rng: np.random.Generator) -> TabularDomain:
    """A random chain: terrain, hidden ``w*`` and a random baseline, all drawn from ``rng``."""
    n, k = params.length, params.kinds
    features = np.eye(k)[rng.integers(k, size=n)]
    terminal = np.zeros(n, dtype=bool)
    terminal[-1] = True
    transitions = np.zeros((n, 2, n))  # actions: 0 = left, 1 = right
    for s in range(n - 1):
        transitions[s, 0, max(s - 1, 0)] = 1.0
        transitions[s, 1, s + 1] = 1.0
    mdp = TabularMDP(transitions, features, params.gamma, terminal)
    true_weights = random_unit_vectors(rng, 1, k)[0]
    baseline = rng.integers(2, size=n)
    layout = np.stack([np.zeros(n), np.arange(n)], axis=1)  # one row of cells in recordings
    return TabularDomain(mdp, true_weights, np.full(n, 1.0 / n), baseline, layout)


def _view():  # how recordings draw it: as the shipped tabular domains are
    from mjsuff.recording.views import TabularView

    return TabularView


SPEC = DomainSpec("chain", ChainParams, make_chain, view=_view)
