"""Saved demo sets served to ``mjsuff run`` in place of the live expert.

A demo set made by ``mjsuff demos`` for a replicate holds the demos that replicate's run would be
shown, in its passive order (``mjsuff.experiment.demo_generation``). Served back, each request for a start
takes the file's next unused demo from that start, so a passive run reproduces the live run.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mjsuff.demo_schedule import DemoSchedule
from mjsuff.domain import Demo
from mjsuff.experiment.demo_generation import instance_meta, scene_instance
from mjsuff.experiment.scenario import Scenario
from mjsuff.experts.demo_set import DemoFileError, DemoSet, load_demo_set
from mjsuff.scenes.scene import Scene

#: The arrays a served ``Demo`` carries in ``data`` (as the live expert's do).
DEMO_ARRAYS = ("features", "qpos", "qvel", "controls", "intended", "executed")


class RecordedDemos:
    """Demos of one replicate read from a demo-set file."""

    def __init__(self, demo_set: DemoSet, path: str | Path) -> None:
        self.demo_set = demo_set
        self.path = Path(path)
        self._used: set[int] = set()

    def demonstrate(self, start: int, rng: np.random.Generator, poor: bool = False) -> Demo:
        """The file's next unused demo from pool start ``start`` (its own ``poor`` flag
        wins: the file says how the demo was made)."""
        a = self.demo_set.arrays
        for i in np.flatnonzero(a["start_index"] == start):
            if int(i) not in self._used:
                self._used.add(int(i))
                return Demo(
                    start=start, poor=bool(a["poor"][i]), data={name: a[name][i] for name in DEMO_ARRAYS}
                )
        raise DemoFileError(
            f"{self.path}: no unused demo from start {start} (the file has "
            f"{len(self.demo_set)} demos; generate more with mjsuff demos --count)"
        )


#: Scene parameters that do not shape the demos (the learner's budgets and comparisons); the
#: expert's settings are checked on their own (``meta.expert``).
_NOT_DEMO_SETTINGS = ("planning", "expert", "candidates", "unchanged_tolerance", "match_tolerance")


def _demo_settings(params: dict[str, Any], expert: Any, noise: Any) -> dict[str, Any]:
    """What shapes the demos besides the instance."""
    return {
        "scene_params": {k: v for k, v in params.items() if k not in _NOT_DEMO_SETTINGS},
        "expert": expert,
        "noise_fraction": noise,
    }


def load_recorded_demos(paths: list[str | Path], scenario: Scenario) -> dict[int, RecordedDemos]:
    """Read and check demo-set files for ``scenario``: replicate -> its demos.

    Each file must come from this scenario's scene, seed and instance of the replicate it names,
    with the same scene parameters (horizon, knots, ...), expert settings and noise fraction, and
    hold a demo for every start the (passive) run will ask for.

    Raises:
        DemoFileError: Any of that fails, two files name the same replicate, or the scenario
            selects demos actively (a saved set can only follow the passive order).
    """
    if paths and scenario.demos.selection != "passive":
        raise DemoFileError(
            f"{paths[0]}: saved demos follow the passive order; the scenario has "
            f"demos.selection = {scenario.demos.selection!r}"
        )
    params = scenario.domain_params().model_dump(mode="json")
    wanted = _demo_settings(
        params,
        params.get("expert"),
        scenario.demos.noise_fraction,
    )
    served: dict[int, RecordedDemos] = {}
    for path in paths:
        demo_set = load_demo_set(path)
        replicate = demo_set.meta.get("replicate")
        if type(replicate) is not int or not 0 <= replicate < scenario.replicates:
            raise DemoFileError(
                f"{path}: field 'meta.replicate': expected a replicate in "
                f"0..{scenario.replicates - 1}, got {replicate!r}"
            )
        if replicate in served:
            raise DemoFileError(
                f"{path}: replicate {replicate} already has demos from {served[replicate].path}"
            )
        scene, _ = scene_instance(scenario, replicate)
        meta = demo_set.meta
        checks = {**instance_meta(scenario, replicate, scene), **wanted}
        got = {
            **meta,
            **_demo_settings(meta.get("scene_params") or {}, meta.get("expert"), meta.get("noise_fraction")),
        }
        for key, value in checks.items():
            if got.get(key) != value:
                raise DemoFileError(
                    f"{path}: field 'meta.{key}': expected {value!r}, got "
                    f"{got.get(key)!r} (demos of another scene, instance or "
                    "settings)"
                )
        pool = len(scene.pool_starts)
        _check_ranges(path, demo_set, scene)
        d = scenario.demos
        schedule = DemoSchedule.of_replicate(scenario.seed, replicate, pool, d.max_demos, d.noise_fraction)
        needed = np.bincount(schedule.passive_starts(), minlength=pool)
        have = np.bincount(demo_set.arrays["start_index"], minlength=pool)[:pool]
        short = np.flatnonzero(have < needed)
        if short.size:
            raise DemoFileError(
                f"{path}: the run asks for {int(needed.sum())} demos in passive "
                f"order but the file has none left from start {int(short[0])} "
                f"({len(demo_set)} demos); generate them with mjsuff demos "
                f"--count {int(needed.sum())}"
            )
        served[replicate] = RecordedDemos(demo_set, path)
    return served


def _check_ranges(path: str | Path, demo_set: DemoSet, scene: Scene) -> None:
    """Every array's values fit the scene the file names: pool start indices, their postures,
    controls within the actuators' ranges, tracking errors ≥ 0 (shapes and finiteness are
    ``load_demo_set``'s)."""
    a, pool = demo_set.arrays, len(scene.pool_starts)
    starts = a["start_index"]
    outside = starts[(starts < 0) | (starts >= pool)]
    if outside.size:
        raise DemoFileError(
            f"{path}: array 'start_index': expected pool starts 0..{pool - 1}, got {int(outside[0])}"
        )
    if not np.allclose(a["start_qpos"], scene.pool_starts[starts], atol=1e-9):
        raise DemoFileError(f"{path}: array 'start_qpos': not the postures of the pool starts it names")
    low, high = scene.model.actuator_ctrlrange.T
    if ((a["controls"] < low - 1e-9) | (a["controls"] > high + 1e-9)).any():
        raise DemoFileError(f"{path}: array 'controls': outside the actuators' ranges {low} .. {high}")
    if (a["tracking_error"] < 0).any():
        raise DemoFileError(f"{path}: array 'tracking_error': negative values")
