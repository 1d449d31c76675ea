"""Ground truth of a scene instance: ``V*_{w*}(s)`` per evaluation start, planned harder than the
learner ever plans, from a copy of its library and with randomness of its own.

Nothing of ``w*`` reaches the learner's library, warm starts or refinement record. When the
replicate ends, the truth is raised to anything better it simulated under ``w*`` and, with
``planning.truth_passes``, searched again from there until a search raises no start by more
than ``TRUTH_SETTLED`` of its ``V* − V_rand`` (:func:`converge_truth`), so the truth is the best
of everything.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from mjsuff.domain import TRUTH_SETTLED
from mjsuff.scenes.library import TrajectoryLibrary
from mjsuff.scenes.planner import SamplingPlanner
from mjsuff.scenes.planner_config import PlannerConfig
from mjsuff.scenes.planning import PlanningSettings
from mjsuff.scenes.scene import Scene
from mjsuff.scenes.search import library_warm, polish_library
from mjsuff.sphere import normalize

if TYPE_CHECKING:
    from mjsuff.experts.expert import Expert

#: Ground truth's broad CMA-ES step, as a share of the control range.
TRUTH_SIGMA = 0.2
#: Ground truth's rounds of the local quadratic model after its searches, at most: it stops once
#: two rounds in a row improve no start (the learner polishes plans near w* at every step, so the
#: truth must have converged where the learner's polish would go).
TRUTH_POLISH_ROUNDS = 64
#: Ground truth first plans this many rewards around w* (w* plus this s.d. of noise per weight,
#: normalized: about 14° off) with the planner's budget, as the learner does near w*.
TRUTH_CLOUD = 16
TRUTH_CLOUD_SPREAD = 0.15


def search_truth(
    scene: Scene,
    library: TrajectoryLibrary,
    true_weights: np.ndarray,
    planner: PlannerConfig,
    planning: PlanningSettings,
    expert: Expert | None,
    rng: np.random.Generator,
    cloud: int = TRUTH_CLOUD,
) -> np.ndarray:
    """``V*_{w*}(s)`` ``(S,)``: the best under ``w*`` of ``library`` (which gains every plan: never
    pass the learner's own) after ``cloud`` rewards around ``w*`` are planned from every start
    with the planner's budget (``planner``; none when ``cloud`` is 0), then ``w*`` by three
    searches, each from the best found so far and with ``planning.truth_scale`` × its budget (the
    seed planner's wide one, the planner's CMA-ES with a broad step, the planner itself), the
    local quadratic model's proposals until they stop improving, and, when there is an expert,
    its best demo from every evaluation start (a demonstrator that is never asked there in the
    run)."""
    k = len(true_weights)
    starts = np.arange(len(scene.starts))
    w = np.tile(true_weights, (len(starts), 1))
    # First the learner's own kind of search, for rewards around w* (as its π_MAP plans for
    # posterior modes near w* are): each lands in some basin, and w*'s searches then start from
    # the best of them all.
    if cloud > 0:
        near = normalize(true_weights + TRUTH_CLOUD_SPREAD * rng.standard_normal((cloud, k)))
        problems, directions = np.repeat(starts, cloud), np.tile(near, (len(starts), 1))
        SamplingPlanner(scene, planner, library).plan(
            problems, directions, rng, warm_knots=library_warm(library, problems, directions)
        )
    # Searches of growing locality, each truth_scale × its budget: the seed plans' wide search;
    # the planner's CMA-ES with a broad first step (TRUTH_SIGMA: it reaches basins next to the
    # library's best that the planner's own step does not); the planner itself.
    wide = planning.seed_planner or scene.seed_config
    broad = planner.model_copy(update={"cma_sigma": max(TRUTH_SIGMA, planner.cma_sigma)})
    for search in (wide, broad, planner):
        SamplingPlanner(scene, search.stronger(planning.truth_scale), library).plan(
            starts, w, rng, warm_knots=library_warm(library, starts, w)
        )
    polish_library(
        scene, library, starts, w, TRUTH_POLISH_ROUNDS, planning.polish_neighbours, until_converged=True
    )
    if expert is not None:
        best = type(expert)(scene, expert.settings.model_copy(update={"rationality": None}))
        for s in starts:
            demo = best.demonstrate(scene.starts[s], true_weights, rng)
            library.add_features(int(s), demo.features)
    return np.array([library.best_value(int(s), w[:1])[0] for s in starts])


def converge_truth(
    scene: Scene,
    truth_library: TrajectoryLibrary,
    learner_library: TrajectoryLibrary,
    copied: Sequence[int],
    truth: np.ndarray,
    true_weights: np.ndarray,
    v_rand: np.ndarray,
    planner: PlannerConfig,
    planning: PlanningSettings,
    rng: np.random.Generator,
) -> tuple[np.ndarray, int, float]:
    """Ground truth when a replicate ends, searched until it settles: every trajectory with
    knots the learner simulated from an evaluation start since ``truth_library`` was copied from
    its library (``copied``: the learner's entries per start then) joins it, so the searches
    warm-start from the learner's basins as well as the first truth's plans (a feature-only
    entry, a demo, raises the values but starts no search), then
    :func:`search_truth` runs on it again (no expert) until a pass raises no
    start by more than ``TRUTH_SETTLED`` of its value before the pass minus ``V_rand``
    (``v_rand`` ``(S,)``), at most ``planning.truth_passes`` times (passes after the first
    without the cloud around ``w*`` unless ``planning.truth_cloud_every_pass``).

    Returns the values ``(S,)`` (at least ``truth`` and the learner's best), the passes run and
    the last pass's largest gain (in those units; above ``TRUTH_SETTLED``: still rising when
    the passes allowed ran out). A quiet pass is no proof of a fixed point: an independent
    search can still find another basin (docs/issue-17-measurements.md, "The lander's truth budget").
    """
    starts = range(len(scene.starts))
    w = true_weights[None]
    for s in starts:
        features, knots = learner_library.arrays(s)  # in the order they were added
        truth_library.add(s, features[copied[s] :], knots[copied[s] :])
    values = np.maximum(truth, [learner_library.best_value(s, w)[0] for s in starts])
    passes, gain = 0, 0.0
    while passes < planning.truth_passes:
        cloud = TRUTH_CLOUD if passes == 0 or planning.truth_cloud_every_pass else 0
        found = search_truth(scene, truth_library, true_weights, planner, planning, None, rng, cloud=cloud)
        passes += 1
        gain = float(np.max((found - values) / np.maximum(values - v_rand, 1e-12), initial=0.0))
        values = np.maximum(values, found)
        if gain <= TRUTH_SETTLED:
            break
    return values, passes, gain
