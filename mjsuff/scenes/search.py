"""Searches that start from a trajectory library: its best warm starts, and local polishing.

Every planner run in a scene domain starts from the library's best trajectory for its reward
(``library_warm``); the local quadratic model (``mjsuff.scenes.surrogate``) then proposes better
ones near it (``polish_library``). Both write nothing but the library.
"""

from __future__ import annotations

import numpy as np

from mjsuff.scenes.library import TrajectoryLibrary
from mjsuff.scenes.scene import Scene
from mjsuff.scenes.surrogate import polish


def library_warm(library: TrajectoryLibrary, starts: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The library's best knots ``(B, K, nu)`` from each of ``starts`` under ``w`` ``(B, k)``: the
    warm starts of every search.

    Raises:
        RuntimeError: A start has no valid trajectory (every rollout from it diverged).
    """
    best = [int(library.best(int(s), w[j][None])[1][0]) for j, s in enumerate(starts)]
    if min(best) < 0:
        raise RuntimeError(
            f"no valid trajectory from start {int(starts[best.index(-1)])} "
            "to warm-start from (every rollout diverged)"
        )
    return np.stack([library.arrays(int(s))[1][j] for s, j in zip(starts, best, strict=True)])


def polish_library(
    scene: Scene,
    library: TrajectoryLibrary,
    starts: np.ndarray,
    weights: np.ndarray,
    rounds: int,
    neighbours: int,
    until_converged: bool = False,
) -> None:
    """``rounds`` rounds of the local quadratic model's proposals (``neighbours`` library
    trajectories each) for problems ``(starts[j], weights[j])``, into ``library``; with
    ``until_converged``, fewer once two rounds in a row improve no problem's best value."""
    starts, weights = np.asarray(starts), np.asarray(weights)

    def best() -> np.ndarray:
        return np.array([library.best(int(s), w[None])[0][0] for s, w in zip(starts, weights, strict=True)])

    before, idle = (best() if until_converged else None), 0
    for _ in range(rounds):
        polish(scene, library, starts, weights, neighbours)
        if before is not None:  # until_converged
            after = best()
            idle = idle + 1 if np.all(after <= before + 1e-12 * (1.0 + np.abs(before))) else 0
            if idle == 2:  # two rounds in a row improved no problem
                break
            before = after
