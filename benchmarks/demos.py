"""Benchmark the kinesthetic experts (issue #4): demos per second, gap to the planner, tracking.

For each scene, ``--instances`` random instances with their hidden weights ``w*``; from each of
``--starts`` evaluation starts the expert demonstrates (timed), and the robot's planner (its
default budget, from scratch) plans for ``w*`` from the same start. Printed per scene:

* demos/s (whole demo: candidates, mink IK, execution, refinement; one BLAS thread);
* the gap ``(V_plan − V_demo) / (V_plan − V_rand)``: its distribution over all demos (negative:
  the expert beat the planner);
* the tracking error between the intended and executed task-space path (m);
* candidates executed per demo and how many mink could not follow.

    python benchmarks/demos.py [--instances 4] [--starts 4]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from threadpoolctl import threadpool_limits

from mjsuff.experts.lander import LanderExpert
from mjsuff.experts.reacher import ReacherExpert
from mjsuff.scenes.domain import draw_true_weights
from mjsuff.scenes.lander import Lander, LanderParams
from mjsuff.scenes.lava_reacher import LavaReacher, LavaReacherParams
from mjsuff.scenes.planner import SamplingPlanner

SCENES = {
    "lava_reacher": (LavaReacher, LavaReacherParams, ReacherExpert),
    "lander": (Lander, LanderParams, LanderExpert),
}
RANDOM = 64


def bench(name: str, instances: int, starts: int) -> dict:
    scene_type, params_type, expert_type = SCENES[name]
    gaps, errors, seconds, candidates, failures = [], [], [], [], []
    for i in range(instances):
        rng = np.random.default_rng(1000 + i)
        scene = scene_type(params_type(eval_starts=starts), rng)
        w = draw_true_weights(rng, scene.num_features)
        expert = expert_type(scene)
        values = []
        for s in range(starts):
            t = time.perf_counter()
            demo = expert.demonstrate(scene.starts[s], w, np.random.default_rng(s))
            seconds.append(time.perf_counter() - t)
            values.append(demo.value)
            errors.append(demo.tracking_error)
            candidates.append(demo.candidates)
            failures.append(demo.ik_failures)
        planned = (
            SamplingPlanner(scene, scene.planner_config)
            .plan(np.arange(starts), np.tile(w, (starts, 1)), np.random.default_rng(0))
            .values
        )
        _, feats = scene.simulate(
            np.repeat(scene.starts, RANDOM, axis=0),
            scene.spline.uniform(np.random.default_rng(1), RANDOM * starts),
        )
        v_rand = np.nanmean(feats.reshape(starts, RANDOM, -1), axis=1) @ w
        values = np.array(values)
        gaps.extend((planned - values) / (np.maximum(planned, values) - v_rand))
    return {
        "gaps": np.array(gaps),
        "errors": np.array(errors),
        "seconds": np.array(seconds),
        "candidates": np.array(candidates),
        "failures": np.array(failures),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--instances", type=int, default=4)
    parser.add_argument("--starts", type=int, default=4)
    args = parser.parse_args()
    with threadpool_limits(1):
        for name in SCENES:
            r = bench(name, args.instances, args.starts)
            g, e = r["gaps"], r["errors"]
            q = np.percentile(g, [0, 25, 50, 75, 100])
            print(
                f"{name}: {len(g)} demos, {1 / r['seconds'].mean():.2f} demos/s "
                f"({r['seconds'].mean():.2f} s each); "
                f"candidates {r['candidates'].mean():.0f}/demo, "
                f"IK failures {r['failures'].mean():.1f}/demo"
            )
            print(
                f"  gap to planner (share of V_plan - V_rand): mean {g.mean():+.3f}; "
                f"min/25%/median/75%/max {' / '.join(f'{x:+.3f}' for x in q)}; "
                f"expert better on {np.mean(g < 0):.0%}"
            )
            print(f"  tracking error: median {np.median(e) * 1000:.1f} mm, max {e.max() * 1000:.1f} mm")


if __name__ == "__main__":
    main()
