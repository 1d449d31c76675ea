"""Registered domains: each name maps to a factory and its parameter model (with defaults)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from pydantic import BaseModel

from mjsuff.domain import Domain
from mjsuff.domains.driving import DrivingParams, make_driving
from mjsuff.domains.gridworld import GridworldParams, make_gridworld
from mjsuff.domains.tabular import OptimalPolicyCache, TabularDomain, TabularMDP
from mjsuff.scenes.domain import make_scene_domain
from mjsuff.scenes.lander import Lander, LanderParams
from mjsuff.scenes.lava_reacher import LavaReacher, LavaReacherParams
from mjsuff.scenes.params import SceneParams
from mjsuff.scenes.scene import Scene

if TYPE_CHECKING:
    from mjsuff.experts.expert import Expert


@dataclass(frozen=True)
class DomainSpec:
    """A registered domain: how to build a random instance and which parameters it takes.

    Attributes:
        name: The scenario's ``domain.name``.
        params: The parameter model of ``domain.params`` (its defaults are the domain's).
        factory: ``(params, rng) -> Domain``: one instance, hidden weights and expert included,
            drawn from ``rng`` alone.
        kind: ``"tabular"`` (exact MDP) or ``"scene"`` (MuJoCo, trajectory-level).
        scene: A scene domain's ``Scene`` type (its physics and features); ``None`` otherwise.
        expert: A scene domain's kinesthetic expert type, loaded on first use (mink is imported
            only when a scene runs); ``None`` otherwise.
    """

    name: str
    params: type[BaseModel]
    factory: Callable[[Any, np.random.Generator], Domain]
    kind: Literal["tabular", "scene"] = "tabular"
    scene: type[Scene] | None = None
    expert: Callable[[], type[Expert]] | None = None

    def make(self, params: BaseModel | dict | None, rng: np.random.Generator) -> Domain:
        """Validate ``params`` (defaults when ``None``) and build an instance from ``rng``."""
        if not isinstance(params, BaseModel):
            params = self.params.model_validate(params or {})
        return self.factory(params, rng)


def scene_domain(
    name: str, scene: type[Scene], params: type[SceneParams], expert: Callable[[], type[Expert]]
) -> DomainSpec:
    """The spec of a MuJoCo scene domain: the scene, its parameter model and (a loader of) its
    expert; instances are ``SceneDomain``s (``mjsuff.scenes.domain.make_scene_domain``)."""

    def factory(p: SceneParams, rng: np.random.Generator) -> Domain:
        return make_scene_domain(scene, expert(), p, rng)

    return DomainSpec(name, params, factory, "scene", scene, expert)


def _reacher_expert() -> type[Expert]:
    from mjsuff.experts.reacher import ReacherExpert  # mink only when a scene runs

    return ReacherExpert


def _lander_expert() -> type[Expert]:
    from mjsuff.experts.lander import LanderExpert  # mink only when a scene runs

    return LanderExpert


REGISTRY: dict[str, DomainSpec] = {
    "gridworld": DomainSpec("gridworld", GridworldParams, make_gridworld),
    "driving": DomainSpec("driving", DrivingParams, make_driving),
    "lava_reacher": scene_domain("lava_reacher", LavaReacher, LavaReacherParams, _reacher_expert),
    "lander": scene_domain("lander", Lander, LanderParams, _lander_expert),
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
    "scene_domain",
]
