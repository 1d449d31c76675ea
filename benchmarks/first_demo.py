"""Benchmark: is one demo enough, and where does π_MAP go wrong (issue #17, item 1)?

For replicates of a scene's scenario (a run's own streams: ``--seed`` and replicate indices), one
demonstration is shown as in a run (``demos.max_demos = 1``) and π_MAP after it is scored under
w*, per evaluation start. Printed per replicate: w*, the MAP weights, the run's true nEVD of π_MAP
(the end-of-replicate truth) and its bound, and the per-start regret split by side — the
evaluation starts on the side the demo came from ("seen") and the others ("unseen"), each in
units of the mean ``V* − V_rand``, so that their mean over all starts is the true nEVD. On the lava
reacher the sides are its two start regions (``LavaReacher.start_sides`` / ``pool_sides``); a
scene without sides counts every start as seen.

Use design seeds only (not a seed reported as evidence): this is how a scene is designed.

    python benchmarks/first_demo.py lava_reacher --seed 2 --replicates 10

A candidate design is measured with ``--set KEY=VALUE`` (a scenario key, e.g. ``--set
'domain.params.zone_radii=[0.6,0.9]'`` on the lander) or ``--constant NAME=VALUE`` (a scene
module's constant the scenario does not set, e.g. ``--constant IMPACT_SCALE=10``;
``scene_constants.py``).
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from scene_constants import add_argument, set_scene_constants
from threadpoolctl import threadpool_limits

from mjsuff.experiment.replicate import run_replicate
from mjsuff.experiment.scenario import ScenarioError, load_scenario

ROOT = Path(__file__).resolve().parent.parent


class _LastStep:
    """Keeps the instance and the last step a replicate shows its observer."""

    def begin(self, domain) -> None:
        self.domain = domain

    def step(self, step, demo, samples, nevd, map_weights, map_policy, rows) -> None:
        self.demo, self.map_weights, self.map_policy, self.rows = demo, map_weights, map_policy, rows

    def end(self, rows) -> None:
        pass


def one_demo(seed: int, overrides: list[str]) -> list[str]:
    """The scenario overrides of a first-demo replicate: the seed, ``--set``'s, one demo."""
    return [f"seed={seed}", *overrides, "demos.max_demos=1"]


def run_one(
    scene: str, seed: int, replicate: int, overrides: list[str], constants: list[tuple[str, object]]
) -> dict:
    """One replicate with one demo: π_MAP's regret per evaluation start, split by side."""
    set_scene_constants(scene, constants)
    scenario = load_scenario(ROOT / "scenarios" / f"{scene}.toml", one_demo(seed, overrides))
    seen = _LastStep()
    with threadpool_limits(limits=1):
        rows = run_replicate(scenario, replicate, observer=seen)
    domain, w = seen.domain, seen.domain.true_weights
    nevd_row = next(r for r in rows if r["rule"] == "nevd")
    v_star = domain.true_optimal_start_values()
    mu_rand = domain.random_start_feature_expectations()
    regret = (v_star - domain.start_feature_expectations(seen.map_policy) @ w) / np.mean(v_star - mu_rand @ w)
    scene_obj = domain.scene
    sides = np.asarray(getattr(scene_obj, "start_sides", np.zeros(len(v_star), int)))
    pool_sides = np.asarray(getattr(scene_obj, "pool_sides", np.zeros(domain.pool.size, int)))
    same = sides == pool_sides[seen.demo.start]
    return {
        "replicate": replicate,
        "w_star": w.round(3).tolist(),
        "map_weights": np.asarray(seen.map_weights).round(3).tolist(),
        "true_nevd": nevd_row["true_nevd"],
        "bound": nevd_row["bound"],
        "seen": float(regret[same].mean()),
        "unseen": float(regret[~same].mean()) if (~same).any() else float("nan"),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", choices=["lava_reacher", "lander"])
    parser.add_argument("--seed", type=int, required=True, help="a design seed")
    parser.add_argument("--replicates", type=int, default=10)
    parser.add_argument("--first", type=int, default=0, help="index of the first replicate")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--json", type=Path, help="also write the rows to this file")
    add_argument(parser)
    args = parser.parse_args()
    set_scene_constants(args.scene, args.constant)  # here too: an unknown name fails at once
    try:  # a bad --set fails here, in one line, not in a worker
        load_scenario(ROOT / "scenarios" / f"{args.scene}.toml", one_demo(args.seed, args.set))
    except ScenarioError as error:
        parser.error(str(error))
    t0 = time.perf_counter()
    jobs = [
        (args.scene, args.seed, r, args.set, args.constant)
        for r in range(args.first, args.first + args.replicates)
    ]
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(run_one, *zip(*jobs, strict=True)))
    print(
        f"{args.scene}, seed {args.seed}, replicates {args.first}–{args.first + args.replicates - 1}, "
        "one demo "
        f"({time.perf_counter() - t0:.0f} s)"
        + "".join(f", {name} = {value}" for name, value in args.constant)
        + "".join(f", {text}" for text in args.set)
    )
    print("| replicate | w* | MAP weights | true nEVD | bound | regret, seen side | unseen side |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        print(
            f"| {r['replicate']} | {r['w_star']} | {r['map_weights']} | {r['true_nevd']:.3f} | "
            f"{r['bound']:.3f} | {r['seen']:.3f} | {r['unseen']:.3f} |"
        )
    nevd = np.array([r["true_nevd"] for r in rows])
    print(
        f"mean true nEVD after one demo {nevd.mean():.3f} (median {np.median(nevd):.3f}); "
        f"unseen side's regret mean {np.nanmean([r['unseen'] for r in rows]):.3f}"
    )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
