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
from mjsuff.scenes.lander import Lander, LanderParams
from mjsuff.scenes.lava_reacher import LavaReacher, LavaReacherParams


@dataclass(frozen=True)
class DomainSpec:
    """A registered domain: how to build a random instance and which parameters it takes.

    Attributes:
        kind: ``"tabular"`` (exact MDP) or ``"scene"`` (MuJoCo, trajectory-level).
    """

    name: str
    params: type[BaseModel]
    factory: Callable[[BaseModel, np.random.Generator], Domain]
    kind: str = "tabular"

    def make(self, params: BaseModel | dict | None, rng: np.random.Generator) -> Domain:
        """Validate ``params`` (defaults when ``None``) and build an instance from ``rng``."""
        if not isinstance(params, BaseModel):
            params = self.params.model_validate(params or {})
        return self.factory(params, rng)


def _scene(scene_type: type) -> Callable[[BaseModel, np.random.Generator], Domain]:
    def factory(params: BaseModel, rng: np.random.Generator) -> Domain:
        from mjsuff.scenes.domain import make_scene_domain  # MuJoCo only when asked for

        return make_scene_domain(scene_type, params, rng)

    return factory


REGISTRY: dict[str, DomainSpec] = {
    "gridworld": DomainSpec("gridworld", GridworldParams, make_gridworld),
    "driving": DomainSpec("driving", DrivingParams, make_driving),
    "lava_reacher": DomainSpec("lava_reacher", LavaReacherParams, _scene(LavaReacher), "scene"),
    "lander": DomainSpec("lander", LanderParams, _scene(Lander), "scene"),
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
