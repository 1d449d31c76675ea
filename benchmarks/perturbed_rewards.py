"""Benchmark: how much a wrong reward costs on a scene (issue #17's table).

For instances of a scene (the scenario file's settings), the true nEVD (under w*, against the
instance's random policy) of the policy the planner makes for: w* itself (the planner–expert
floor under every π_MAP), w* with one feature's weight zeroed, and random all-negative rewards,
each with π's budget (``replan_cosine`` off).
Demos can only matter where wrong weights produce different motions.

    python benchmarks/perturbed_rewards.py lava_reacher --seeds 1 2 3

A candidate design is measured with ``--set KEY=VALUE`` (a scenario key, e.g.
``--set 'domain.params.zone_shape="hemisphere"'``) or ``--constant NAME=VALUE`` (a scene module's
constant, ``scene_constants.py``).
"""

import argparse
import time
from pathlib import Path

import numpy as np
from scene_constants import add_argument, set_scene_constants

from mjsuff.experiment.replicate import make_instance
from mjsuff.experiment.scenario import ScenarioError, load_scenario
from mjsuff.sphere import random_unit_vectors

ROOT = Path(__file__).resolve().parent.parent


def measure(
    name: str, seed: int, random_rewards: int, features: bool = False, overrides: tuple[str, ...] = ()
) -> dict[str, float]:
    """The true nEVD of each perturbed reward's plan; with ``features``, also print each plan's
    (and the random policy's) feature expectations per evaluation start."""
    scenario = load_scenario(ROOT / "scenarios" / f"{name}.toml", [f"seed={seed}", *overrides])
    domain = make_instance(scenario, 0)
    # Every reward here gets π's own budget: nearby ones (w* with a small weight zeroed) would
    # otherwise be re-planned with the refinement budget (``replan_cosine``, shipped on the reacher).
    domain.planning = domain.planning.model_copy(update={"replan_cosine": None})
    w = domain.true_weights
    v_star = domain.true_optimal_start_values()
    gap = np.mean(v_star - domain.random_start_feature_expectations() @ w)

    names = domain.scene.feature_names
    if features:
        print(f"seed {seed}: w* {np.round(w, 3).tolist()}; per evaluation start, {', '.join(names)}")
        print(f"  random policy:\n{np.round(domain.random_start_feature_expectations(), 3)}")

    def nevd(policy: np.ndarray, label: str) -> float:
        mu = domain.start_feature_expectations(policy)
        v = mu @ w
        regret = (np.maximum(v_star, v) - v) / gap
        if features:
            print(f"  {label}: regret per start {np.round(regret, 3).tolist()}\n{np.round(mu, 3)}")
        return float(regret.mean())

    rows = {"w* plan": nevd(domain.plan(w), "w* plan")}
    for i, feature in enumerate(names):
        zeroed = w.copy()
        zeroed[i] = 0.0
        label = f"{feature} zeroed"
        rows[label] = nevd(domain.plan(zeroed / np.linalg.norm(zeroed)), label)
    draws = -np.abs(random_unit_vectors(np.random.default_rng(seed + 7), random_rewards, len(w)))
    for j, other in enumerate(draws):
        rows[f"random {j}"] = nevd(domain.plan(other), f"random {j}")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", choices=["lava_reacher", "lander"])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--random", type=int, default=4, help="random all-negative rewards")
    parser.add_argument(
        "--features", action="store_true", help="also print every plan's features per evaluation start"
    )
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    add_argument(parser)
    args = parser.parse_args()
    set_scene_constants(args.scene, args.constant)
    try:  # a bad --set fails here, in one line, before any planning
        load_scenario(ROOT / "scenarios" / f"{args.scene}.toml", args.set)
    except ScenarioError as error:
        parser.error(str(error))
    if args.set:
        print(f"{args.scene} with " + ", ".join(args.set), flush=True)
    for seed in args.seeds:
        t = time.perf_counter()
        rows = measure(args.scene, seed, args.random, args.features, tuple(args.set))
        print(
            f"{args.scene} seed {seed} ({time.perf_counter() - t:.0f} s): "
            + ", ".join(f"{k} {v:.3f}" for k, v in rows.items()),
            flush=True,
        )


if __name__ == "__main__":
    main()
