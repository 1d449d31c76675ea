"""Registered domains: each name maps to a factory and its parameter model (with defaults)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel

from mjsuff.domain import Domain
from mjsuff.domains.driving import DrivingParams, make_driving
from mjsuff.domains.gridworld import GridworldParams, make_gridworld
from mjsuff.domains.tabular import OptimalPolicyCache, TabularDomain, TabularMDP


@dataclass(frozen=True)
class DomainSpec:
    """A registered domain: how to build a random instance and which parameters it takes."""

    name: str
    params: type[BaseModel]
    factory: Callable[[BaseModel, np.random.Generator], Domain]

    def make(self, params: BaseModel | dict | None, rng: np.random.Generator) -> Domain:
        """Validate ``params`` (defaults when ``None``) and build an instance from ``rng``."""
        if not isinstance(params, BaseModel):
            params = self.params.model_validate(params or {})
        return self.factory(params, rng)


REGISTRY: dict[str, DomainSpec] = {
    "gridworld": DomainSpec("gridworld", GridworldParams, make_gridworld),
    "driving": DomainSpec("driving", DrivingParams, make_driving),
}


def get_domain(name: str) -> DomainSpec:
    """The registered domain called ``name``."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise KeyError(f"unknown domain {name!r}; expected one of {sorted(REGISTRY)}") from None


__all__ = [
    "REGISTRY",
    "DomainSpec",
    "OptimalPolicyCache",
    "TabularDomain",
    "TabularMDP",
    "get_domain",
]
