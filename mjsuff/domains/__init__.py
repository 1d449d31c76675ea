"""The one registry of domains: each name maps to a spec (parameter model, factory, expert, view).

Every part of mjsuff that needs a domain (the scenario, the run, demo generation, recordings, the
dm_control suite, the tests) looks it up here. Domains from outside mjsuff register themselves
(``register``) or are named by import path in a scenario (``domain.name = "my_lab.toy:SPEC"``).
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from pydantic import BaseModel

from mjsuff.domain import Domain
from mjsuff.domains.driving import DrivingParams, make_driving
from mjsuff.domains.gridworld import GridworldParams, make_gridworld
from mjsuff.domains.tabular import OptimalPolicyCache, TabularDomain, TabularMDP
from mjsuff.errors import MjsuffError
from mjsuff.scenes.domain import make_scene_domain
from mjsuff.scenes.lander import Lander, LanderParams
from mjsuff.scenes.lava_reacher import LavaReacher, LavaReacherParams
from mjsuff.scenes.params import SceneParams
from mjsuff.scenes.scene import Scene

if TYPE_CHECKING:
    from mjsuff.experts.expert import Expert
    from mjsuff.recording.views import DomainView


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
        view: How a recording draws the domain's instances (``mjsuff.recording.views``), loaded
            on first use; ``None`` draws nothing of the instance (the plots still show the run).
    """

    name: str
    params: type[BaseModel]
    factory: Callable[[Any, np.random.Generator], Domain]
    kind: Literal["tabular", "scene"] = "tabular"
    scene: type[Scene] | None = None
    expert: Callable[[], type[Expert]] | None = None
    view: Callable[[], type[DomainView]] | None = None

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

    return DomainSpec(name, params, factory, "scene", scene, expert, _scene_view)


def _scene_view() -> type[DomainView]:
    from mjsuff.recording.views import SceneView  # rerun only when a run records

    return SceneView


def _tabular_view() -> type[DomainView]:
    from mjsuff.recording.views import TabularView  # rerun only when a run records

    return TabularView


def _reacher_expert() -> type[Expert]:
    from mjsuff.experts.reacher import ReacherExpert  # mink only when a scene runs

    return ReacherExpert


def _lander_expert() -> type[Expert]:
    from mjsuff.experts.lander import LanderExpert  # mink only when a scene runs

    return LanderExpert


REGISTRY: dict[str, DomainSpec] = {
    "gridworld": DomainSpec("gridworld", GridworldParams, make_gridworld, view=_tabular_view),
    "driving": DomainSpec("driving", DrivingParams, make_driving, view=_tabular_view),
    "lava_reacher": scene_domain("lava_reacher", LavaReacher, LavaReacherParams, _reacher_expert),
    "lander": scene_domain("lander", Lander, LanderParams, _lander_expert),
}


class UnknownDomainError(MjsuffError, KeyError):
    """No domain of that name is registered or can be imported; the message is one line."""

    def __str__(self) -> str:
        return str(self.args[0])


def register(spec: DomainSpec) -> DomainSpec:
    """Add ``spec`` to the registry under ``spec.name`` and return it.

    Raises:
        ValueError: Another spec is registered under that name.
    """
    known = REGISTRY.setdefault(spec.name, spec)
    if known is not spec:
        raise ValueError(f"domain {spec.name!r} is registered already")
    return spec


def get_domain(name: str) -> DomainSpec:
    """The registered domain called ``name``.

    A name ``module:attribute`` (e.g. ``my_lab.toy:SPEC``) names a ``DomainSpec`` outside mjsuff:
    the module is imported (it must be importable, e.g. installed or on ``PYTHONPATH``) and the
    spec registered under that name, so a scenario can run a domain mjsuff does not ship.

    Raises:
        UnknownDomainError: Nothing is registered under ``name`` and it names no importable spec.
    """
    if name in REGISTRY:
        return REGISTRY[name]
    module_name, colon, attribute = name.partition(":")
    if not colon:
        raise UnknownDomainError(f"expected one of {sorted(REGISTRY)} or module:attribute (got {name!r})")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise UnknownDomainError(f"cannot import module {module_name!r} ({exc})") from None
    spec = getattr(module, attribute, None)
    if not isinstance(spec, DomainSpec):
        raise UnknownDomainError(f"{name!r}: expected a mjsuff.domains.DomainSpec, got {type(spec).__name__}")
    if spec.name != name:
        spec = dataclasses.replace(spec, name=name)
    return REGISTRY.setdefault(name, spec)


__all__ = [
    "REGISTRY",
    "DomainSpec",
    "OptimalPolicyCache",
    "TabularDomain",
    "TabularMDP",
    "UnknownDomainError",
    "get_domain",
    "register",
    "scene_domain",
]
