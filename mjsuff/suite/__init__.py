"""mjsuff's MuJoCo scenes as dm_control environments, loaded by name like ``dm_control.suite``.

Each episode is one trajectory of the scene's horizon; the reward of a step is ``w·φ_t``, its share
of the trajectory's features (``Scene.step_features``), so an episode's return is the value
mjsuff's learner and expert give the trajectory. ``w`` is the instance's hidden ``w*`` unless given.

    from mjsuff import suite
    env = suite.load("lava_reacher", seed=0)
    timestep = env.reset()
    while not timestep.last():
        timestep = env.step(policy(timestep.observation))
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import numpy as np
from pydantic import BaseModel

from mjsuff.domains import REGISTRY
from mjsuff.experiment.demo_generation import instance_fingerprint, replicate_instance
from mjsuff.experts.demo_set import DemoFileError, DemoSet
from mjsuff.experts.demo_set import load_demo_set as read_demo_set
from mjsuff.scenes.domain import draw_true_weights
from mjsuff.scenes.scene import Scene
from mjsuff.suite import lander, lava_reacher
from mjsuff.suite._dm_control import control
from mjsuff.suite.physics import ScenePhysics
from mjsuff.suite.task import Instance, SceneTask, environment

#: The registered MuJoCo scenes (``mjsuff.domains.REGISTRY``), each with its environment module.
_MODULES: dict[str, ModuleType] = {"lava_reacher": lava_reacher, "lander": lander}
SCENES: tuple[str, ...] = tuple(name for name, spec in REGISTRY.items() if spec.kind == "scene")


def _module(scene_name: str) -> ModuleType:
    if scene_name not in _MODULES:
        raise ValueError(f"unknown scene {scene_name!r}; mjsuff.suite has {sorted(_MODULES)}")
    return _MODULES[scene_name]


def _weights(scene_name: str, weights: np.ndarray | None, scene: Scene) -> np.ndarray | None:
    if weights is None:
        return None
    w = np.asarray(weights, dtype=float)
    if w.shape != (scene.num_features,) or not np.isfinite(w).all():
        raise ValueError(
            f"weights: scene {scene_name!r} rewards {scene.num_features} features "
            f"{scene.feature_names}; expected {scene.num_features} finite numbers, "
            f"got shape {w.shape}"
        )
    return w


def load(
    scene_name: str,
    seed: int | np.random.Generator | None = None,
    *,
    weights: np.ndarray | None = None,
    params: BaseModel | dict | None = None,
    environment_kwargs: dict | None = None,
) -> control.Environment:
    """An environment of scene ``scene_name`` whose every episode is a new instance (goal and
    lava, or pad) with its own ``w*`` and a start from its start distribution, drawn from ``seed``.

    Args:
        weights: Reward weights ``(k,)`` for every episode; None: each instance's ``w*``.
        params: The scene's parameters (``domain`` keys of a scenario; defaults when None).
        environment_kwargs: Passed to ``control.Environment`` (e.g. ``flat_observation``).

    Raises:
        ValueError: An unknown scene, bad parameters, or weights of the wrong length.
    """
    module = _module(scene_name)
    spec = REGISTRY[scene_name]
    params = params if isinstance(params, BaseModel) else spec.params.model_validate(params or {})
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)

    def draw(rng: np.random.Generator) -> Instance:
        scene = module.SCENE(params, rng, threads=1)
        return Instance(scene, draw_true_weights(rng, scene.num_features))

    first = draw(rng)
    task = module.TASK(first, rng, _weights(scene_name, weights, first.scene), draw=draw)
    return environment(module.PHYSICS.for_scene(first.scene), task, environment_kwargs)


def load_instance(
    scene: Scene,
    true_weights: np.ndarray,
    *,
    weights: np.ndarray | None = None,
    starts: np.ndarray | None = None,
    seed: int | np.random.Generator | None = None,
    environment_kwargs: dict | None = None,
) -> control.Environment:
    """An environment of one fixed scene instance (e.g. a run's: ``demo_generation.scene_instance``).

    Args:
        true_weights: The instance's ``w*`` (the reward unless ``weights`` is given).
        starts: Start joint positions ``(n, nq)`` the episodes take in turn (e.g. the evaluation
            starts, ``scene.starts``); None draws each from the start distribution with ``seed``.
    """
    name = next((n for n, m in _MODULES.items() if isinstance(scene, m.SCENE)), None)
    if name is None:
        raise ValueError(
            f"no environment for scene type {type(scene).__name__}; mjsuff.suite has {sorted(_MODULES)}"
        )
    module = _MODULES[name]
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    instance = Instance(scene, np.asarray(true_weights, dtype=float))
    if starts is not None:
        starts = np.atleast_2d(np.asarray(starts, dtype=float))
        if starts.shape[1] != scene.model.nq:
            raise ValueError(
                f"starts: scene {name!r} needs {scene.model.nq} joint positions per "
                f"start, got shape {starts.shape}"
            )
    task = module.TASK(instance, rng, _weights(name, weights, scene), starts)
    return environment(module.PHYSICS.for_scene(scene), task, environment_kwargs)


def load_demo_set(
    path: str | Path, *, weights: np.ndarray | None = None, environment_kwargs: dict | None = None
) -> tuple[control.Environment, DemoSet]:
    """The instance a saved demo set was recorded on, as an environment whose episodes start at
    the demos' starts in order (replay demo ``i``'s ``controls`` in episode ``i``), and the set.

    Raises:
        DemoFileError: The file cannot be read, or its instance cannot be rebuilt exactly.
    """
    demo_set = read_demo_set(path)
    meta = demo_set.meta
    name = meta.get("scene")
    if name not in _MODULES:
        raise DemoFileError(f"{path}: field 'meta.scene': expected one of {sorted(_MODULES)}, got {name!r}")
    try:
        params = REGISTRY[name].params.model_validate(meta["scene_params"])
        scene, true_weights = replicate_instance(
            name, params, int(meta["seed"]), int(meta["replicate"]), threads=1
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise DemoFileError(f"{path}: field 'meta': cannot rebuild the instance ({exc})") from None
    if instance_fingerprint(scene) != meta.get("instance"):
        raise DemoFileError(
            f"{path}: field 'meta.instance': the rebuilt instance differs "
            f"(recorded with mjsuff {meta.get('mjsuff_version')}, MuJoCo "
            f"{meta.get('mujoco_version')})"
        )
    env = load_instance(
        scene,
        true_weights,
        weights=weights,
        starts=demo_set.arrays["start_qpos"],
        environment_kwargs=environment_kwargs,
    )
    return env, demo_set


__all__ = [
    "SCENES",
    "Instance",
    "ScenePhysics",
    "SceneTask",
    "load",
    "load_demo_set",
    "load_instance",
]
