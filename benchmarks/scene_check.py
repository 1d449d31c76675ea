"""Benchmark: one sufficiency check on each MuJoCo scene (issues #5, #17).

One check = the posterior from 10 demos (the pool's starts; MCMC under the scene's orthant prior,
the scenario's sample count, until converged), π_MAP (planned from every evaluation start), ``V*``
of every sample from the library with refinement of the nEVD tail (as the replicate loop does),
nEVD and the α-VaR bound, with the scenario file's evaluation starts (6 shipped; ``--starts 16``
is the issue's first measurement) and planning budgets. Printed: the total and the share spent
building the demos' candidate sets (simulating the perturbed demos; the demonstrator's first
candidates are those its demo executed, ``Expert.first_candidates``), sampling, planning π_MAP
and ``V*``; then a second check after an 11th demo (the loop's warm state, where ``V*``
refinement skips directions already refined). Building the instance and the expert's demos are
timed apart (they are not part of a check). Beside each phase that simulates: the MuJoCo steps it
simulated and the time spent inside ``mujoco.rollout`` for them (timed as it runs, so the
machine's drift between runs does not enter): the phase's floor at its rollout count. Time above
it is overhead; below it a phase gets only with fewer rollouts.

    python benchmarks/scene_check.py [--scenes lava_reacher lander] [--starts N] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
from mujoco import rollout
from threadpoolctl import threadpool_limits

from mjsuff.bounds import normalized_evd, policy_values, upper_var_bound
from mjsuff.errors import MjsuffError
from mjsuff.experiment.replicate import make_instance, nevd_bound_index
from mjsuff.experiment.run_summary import machine_info
from mjsuff.experiment.scenario import load_scenario
from mjsuff.posterior import sample_posterior

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
NUM_DEMOS = 10
#: Seconds spent inside ``mujoco.rollout`` so far (every scene simulates through it).
IN_MUJOCO = [0.0]
_rollout = rollout.rollout


def _timed_rollout(*args, **kwargs):
    t0 = time.perf_counter()
    try:
        return _rollout(*args, **kwargs)
    finally:
        IN_MUJOCO[0] += time.perf_counter() - t0


def check(domain, demos, scenario, rng) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """One check: each phase's seconds (and the bound, sampler steps, re-plan and polish counts),
    and per simulating phase its (MuJoCo steps, seconds inside ``mujoco.rollout``)."""
    beta, suff = scenario.demos.beta, scenario.sufficiency
    t, steps = {}, {}

    def simulated() -> np.ndarray:  # MuJoCo steps so far, seconds inside mujoco.rollout so far
        return np.array([domain.simulation_stats()["simulated_steps"], IN_MUJOCO[0]])

    n0 = simulated()
    t0 = time.perf_counter()
    for demo in demos:
        domain.candidate_features(demo)
    t["candidates"] = time.perf_counter() - t0
    steps["candidates"] = simulated() - n0
    t0 = time.perf_counter()
    post = sample_posterior(
        lambda w: domain.log_prior(w) + domain.log_likelihood(w, demos, beta),
        domain.num_features,
        scenario.sampler(),
        rng,
        initial=domain.sample_prior(rng, 4 * scenario.sampler().chains),
    )
    t["sampling"] = time.perf_counter() - t0
    n0, t0 = simulated(), time.perf_counter()
    policy = domain.plan(post.map_weights)
    mu = domain.start_feature_expectations(policy)
    t["planning"] = time.perf_counter() - t0
    steps["planning"] = simulated() - n0
    n0, t0 = simulated(), time.perf_counter()
    bound_index = nevd_bound_index(post, suff.alpha, suff.delta, suff.quantile_method)
    v_opt = (
        domain.optimal_start_values(post.samples, robot=mu, bound_index=bound_index) @ domain.start_weights
    )
    t["V*"] = time.perf_counter() - t0
    steps["V*"] = simulated() - n0
    sw, w = domain.start_weights, post.samples
    nevd = normalized_evd(
        v_opt, policy_values(w, mu, sw), policy_values(w, domain.random_start_feature_expectations(), sw)
    )
    t["bound"] = upper_var_bound(
        nevd, suff.alpha, suff.delta, suff.quantile_method, post.effective_size(nevd, suff.alpha)
    )
    t["steps"] = post.steps
    t["replans"] = domain.replans
    t["extra_polish"] = domain.vstar.extra_polish_rounds
    return t, steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--scenes", nargs="+", choices=["lava_reacher", "lander"], default=["lava_reacher", "lander"]
    )
    parser.add_argument(
        "--starts", type=int, default=None, help="evaluation starts (default: the scenario file's)"
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="scenario override, e.g. domain.params.planning.plan_samples=5 (repeatable)",
    )
    args = parser.parse_args()
    rollout.rollout = _timed_rollout  # this benchmark's runs only (planner_stall imports check)
    machine = machine_info()
    print(
        f"machine: {machine['cpu']}, {os.cpu_count()} cores; "
        f"BLAS {machine['blas']}; MuJoCo {machine['mujoco']}"
    )
    scenarios = {}
    for name in args.scenes:
        sets = [*([f"domain.params.eval_starts={args.starts}"] if args.starts is not None else []), *args.set]
        try:  # every scenario checked before any work: a bad value is the scenario's one line
            scenarios[name] = load_scenario(SCENARIOS / f"{name}.toml", sets)
        except MjsuffError as err:
            parser.error(str(err))
    for name, scenario in scenarios.items():
        with threadpool_limits(limits=1):
            t0 = time.perf_counter()
            domain = make_instance(scenario, 0)
            build = time.perf_counter() - t0
            rng = np.random.default_rng(1)
            t0 = time.perf_counter()
            pool = len(domain.pool)
            demos = [domain.demonstrate(s % pool, rng) for s in range(NUM_DEMOS + 1)]
            demo_time = time.perf_counter() - t0
            first = check(domain, demos[:NUM_DEMOS], scenario, np.random.default_rng(2))
            second = check(domain, demos, scenario, np.random.default_rng(3))
        print(
            f"\n{name}: {len(domain.scene.starts)} evaluation starts, {NUM_DEMOS} demos, "
            f"{scenario.posterior.num_samples} samples" + (f"; {' '.join(args.set)}" if args.set else "")
        )
        print(
            f"  instance {build:.1f} s (random trajectories and seed plans); "
            f"expert demos {demo_time / len(demos):.2f} s each (not part of a check)"
        )
        for label, (t, steps) in (("first check", first), ("warm check (11th demo)", second)):
            parts = {k: v for k, v in t.items() if k not in ("bound", "steps", "replans", "extra_polish")}
            total = sum(parts.values())
            shares = ", ".join(
                f"{k} {v:.1f} s ({v / total:.0%})"
                + (f" [{steps[k][0] / 1e6:.1f} M steps, {steps[k][1]:.1f} s in MuJoCo]" if k in steps else "")
                for k, v in parts.items()
            )
            print(
                f"  {label}: {total:.1f} s = {shares}; bound {t['bound']:.3f}; "
                f"{t['steps']} sampler steps per chain; π_MAP with the refinement budget "
                f"(replan_cosine) in {t['replans']} check(s), extra polish rounds "
                f"(polish_extra_rounds) {t['extra_polish']}, so far"
            )


if __name__ == "__main__":
    main()
