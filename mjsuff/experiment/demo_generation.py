"""Demo generation for a scenario: the instance of a replicate, its expert, demos in order.

The instance, the hidden weights, the order of starts and each demo's randomness come from the same
seed streams ``mjsuff run`` uses for that replicate, so a saved demo set holds exactly the demos a
run of the same scenario and seed would be shown.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable

import mujoco
import numpy as np
from pydantic import BaseModel

from mjsuff import __version__
from mjsuff.demo_schedule import DemoSchedule
from mjsuff.domains import REGISTRY, get_domain
from mjsuff.experiment.scenario import Scenario, ScenarioError
from mjsuff.experts.demo_set import DemoSet
from mjsuff.experts.expert import Expert, ExpertDemo
from mjsuff.scenes.domain import draw_instance
from mjsuff.scenes.params import SceneParams
from mjsuff.scenes.scene import Scene
from mjsuff.seeds import stream_rng


def scene_parts(name: str) -> tuple[type[Scene], type[Expert]]:
    """The scene and expert types of registered scene domain ``name``; a one-line error for a
    tabular or unknown one."""
    spec = get_domain(name)
    if spec.scene is None or spec.expert is None:
        scenes = sorted(n for n, s in REGISTRY.items() if s.kind == "scene")
        raise ScenarioError(f"domain.name: demos are generated for the MuJoCo scenes {scenes}, not {name!r}")
    return spec.scene, spec.expert()


def scene_instance(scenario: Scenario, replicate: int = 0) -> tuple[Scene, np.ndarray]:
    """Replicate ``replicate``'s scene instance and hidden weights (as ``mjsuff run`` builds them)."""
    return replicate_instance(scenario.domain.name, scenario.domain_params(), scenario.seed, replicate)


def replicate_instance(
    name: str, params: BaseModel, seed: int, replicate: int, threads: int | None = None
) -> tuple[Scene, np.ndarray]:
    """The scene instance and hidden weights of replicate ``replicate`` of a run of scene ``name``
    with scenario seed ``seed`` (``scene_instance`` without the scenario)."""
    scene_type, _ = scene_parts(name)
    return draw_instance(scene_type, _scene_params(params), stream_rng(seed, replicate, "instance"), threads)


def _scene_params(params: BaseModel) -> SceneParams:
    """``params`` as a scene's parameters (every registered scene's model extends them)."""
    if not isinstance(params, SceneParams):
        raise TypeError(f"a scene's parameters extend SceneParams; got {type(params).__name__}")
    return params


def instance_fingerprint(scene: Scene) -> str:
    """A short hash of what makes an instance: model geometry and evaluation starts."""
    h = hashlib.sha256()
    for array in (
        scene.model.geom_pos,
        scene.model.geom_size,
        scene.model.site_pos,
        scene.starts,
        scene.pool_starts,
    ):
        h.update(np.ascontiguousarray(array, dtype=float).tobytes())
    return h.hexdigest()[:16]


def instance_meta(scenario: Scenario, replicate: int, scene: Scene) -> dict:
    """The metadata a demo set of this instance carries (and is checked against on load)."""
    return {
        "scene": scenario.domain.name,
        "seed": scenario.seed,
        "replicate": replicate,
        "instance": instance_fingerprint(scene),
    }


def generate_demos(
    scenario: Scenario,
    count: int,
    replicate: int = 0,
    on_demo: Callable[[int, ExpertDemo], None] | None = None,
    stop: Callable[[], bool] | None = None,
) -> DemoSet:
    """``count`` demos of replicate ``replicate``'s instance, in the run's passive order.

    Starts cycle through a shuffled order of the demonstration pool; a demo is poor with probability
    ``demos.noise_fraction``. ``on_demo(i, demo)`` reports progress. On ``KeyboardInterrupt`` the
    demos finished so far are returned (``meta["interrupted"]`` is True), never lost.
    """
    scene, weights = scene_instance(scenario, replicate)
    params = _scene_params(scenario.domain_params())
    expert = scene_parts(scenario.domain.name)[1](scene, params.expert)
    d = scenario.demos
    schedule = DemoSchedule.of_replicate(
        scenario.seed, replicate, len(scene.pool_starts), d.max_demos, d.noise_fraction
    )
    demos: list[ExpertDemo] = []
    starts: list[int] = []
    interrupted = False
    try:
        for i in range(count):
            start = schedule.start(i)
            poor = schedule.next_is_poor()
            demos.append(expert.demonstrate(scene.pool_starts[start], weights, schedule.rng, poor=poor))
            starts.append(start)
            if on_demo is not None:
                on_demo(i, demos[-1])
    except KeyboardInterrupt:
        interrupted = True
    m = scene.model
    meta = {
        **instance_meta(scenario, replicate, scene),
        "scene_params": params.model_dump(mode="json"),
        "expert": params.expert.model_dump(mode="json"),
        "noise_fraction": scenario.demos.noise_fraction,
        "feature_names": list(scene.feature_names),
        "num_features": scene.num_features,
        "nq": m.nq,
        "nv": m.nv,
        "nu": m.nu,
        "steps": scene.spline.num_steps,
        "path_dims": 2,
        "timestep": m.opt.timestep,
        "mjsuff_version": __version__,
        "mujoco_version": mujoco.__version__,
        "candidates": [d.candidates for d in demos],
        "ik_failures": [d.ik_failures for d in demos],
        "params": [d.params.tolist() for d in demos],
        "interrupted": interrupted,
    }
    arrays = _stack(demos, starts, scene)
    return DemoSet(arrays, meta, true_weights=weights, values=np.array([d.value for d in demos]))


def _stack(demos: list[ExpertDemo], starts: list[int], scene: Scene) -> dict[str, np.ndarray]:
    m, t = scene.model, scene.spline.num_steps
    n = len(demos)

    def stack(name: str, shape: tuple[int, ...]) -> np.ndarray:
        return np.array([getattr(d, name) for d in demos], dtype=float).reshape(n, *shape)

    return {
        "start_index": np.array(starts, dtype=np.int64).reshape(n),
        "start_qpos": stack("start_qpos", (m.nq,)),
        "qpos": stack("qpos", (t, m.nq)),
        "qvel": stack("qvel", (t, m.nv)),
        "controls": stack("controls", (t, m.nu)),
        "features": stack("features", (scene.num_features,)),
        "intended": stack("intended", (t, 2)),
        "executed": stack("executed", (t, 2)),
        "tracking_error": stack("tracking_error", ()),
        "poor": np.array([d.poor for d in demos], dtype=bool).reshape(n),
    }
