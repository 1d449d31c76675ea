"""Saved demo sets served to ``mjsuff run`` in place of the live expert.

A demo set made by ``mjsuff demos`` for a replicate holds the demos that replicate's run would be
shown, in its passive order (``mjsuff.experts.generate``). Served back, each request for a start
takes the file's next unused demo from that start, so a passive run reproduces the live run.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mjsuff.domain import Demo
from mjsuff.experiment.scenario import Scenario
from mjsuff.experts.demo_set import DemoFileError, DemoSet, load_demo_set
from mjsuff.experts.generate import instance_meta, scene_instance

#: The arrays a served ``Demo`` carries in ``data`` (as the live expert's do).
DEMO_ARRAYS = ("features", "qpos", "qvel", "controls", "intended", "executed")


class RecordedDemos:
    """Demos of one replicate read from a demo-set file."""

    def __init__(self, demo_set: DemoSet, path: str | Path) -> None:
        self.demo_set = demo_set
        self.path = Path(path)
        self._used: set[int] = set()

    def demonstrate(self, start: int, rng: np.random.Generator, poor: bool = False) -> Demo:
        """The file's next unused demo from evaluation start ``start`` (its own ``poor`` flag
        wins: the file says how the demo was made)."""
        a = self.demo_set.arrays
        for i in np.flatnonzero(a["start_index"] == start):
            if int(i) not in self._used:
                self._used.add(int(i))
                return Demo(start=start, poor=bool(a["poor"][i]),
                            data={name: a[name][i] for name in DEMO_ARRAYS})
        raise DemoFileError(f"{self.path}: no unused demo from start {start} (the file has "
                            f"{len(self.demo_set)} demos; generate more with mjsuff demos --count)")


def load_recorded_demos(paths: list[str | Path], scenario: Scenario) -> dict[int, RecordedDemos]:
    """Read and check demo-set files for ``scenario``: replicate -> its demos.

    Each file must come from this scenario's scene, seed and instance of the replicate it names.

    Raises:
        DemoFileError: A file is unreadable or of another scene, seed or instance, names a
            replicate the scenario does not run, or two files name the same replicate.
    """
    served: dict[int, RecordedDemos] = {}
    for path in paths:
        replicate = load_demo_set(path).meta.get("replicate")
        if not isinstance(replicate, int) or not 0 <= replicate < scenario.replicates:
            raise DemoFileError(f"{path}: field 'meta.replicate': expected a replicate in "
                                f"0..{scenario.replicates - 1}, got {replicate!r}")
        if replicate in served:
            raise DemoFileError(f"{path}: replicate {replicate} already has demos from "
                                f"{served[replicate].path}")
        scene, _ = scene_instance(scenario, replicate)
        demo_set = load_demo_set(path, expect=instance_meta(scenario, replicate, scene))
        served[replicate] = RecordedDemos(demo_set, path)
    return served
