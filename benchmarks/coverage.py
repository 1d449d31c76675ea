"""Benchmark: does the α-VaR bound keep its confidence? (issue #15)

For each gridworld world × demo count, a fixed policy (the optimal policy of the reference
posterior's most likely point) and the reference quantiles of its nEVD and PIOB from importance
sampling (``mjsuff.experiment.coverage``), then one sufficiency check per sampler seed with the
scenario's sampler settings. Coverage = share of seeds whose nEVD upper bound is ≥ the reference
α-quantile (PIOB: lower bound ≤ the reference (1−α)-quantile). The same on the lava reacher
(k = 4) against its posterior (the orthant prior and the trajectory likelihood) tabulated on
400,000 uniform sphere points, with nEVD's V* from the trajectory library (no refinement, so the
statistic is one fixed function of w for both).

    python benchmarks/coverage.py [--worlds 6] [--demos 1 3 10] [--seeds 30] [--reacher-seeds 30]
                                  [--set posterior.KEY=VALUE ...] [--json FILE]

Settings: scenarios/gridworld.toml (β, α, δ, sampler) with any ``--set``; worlds are drawn from
``--world-seed`` (default 20261201), sampler seeds from ``--sampler-seed`` (default 1201),
both fixed before the reported run.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from mjsuff.domains import get_domain
from mjsuff.experiment.coverage import (
    Reference,
    Statistics,
    check,
    grid_reference,
    importance_reference,
)
from mjsuff.experiment.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
#: Importance draws of the reference posterior per demo count (more demos: a narrower posterior).
REFERENCE_SIZE = {1: 200_000, 3: 400_000, 10: 1_000_000}


def gridworld_case(scenario, world: int, demos: int, world_seed: int):
    """A world, its first ``demos`` demos of a shuffled order, the reference and the statistic."""
    rng = np.random.default_rng([world_seed, world])
    domain = get_domain("gridworld").make(scenario.domain_params(), rng)
    starts = rng.permutation(domain.pool.size)[:demos]
    shown = [domain.demonstrate(int(s), rng) for s in starts]
    beta = scenario.demos.beta

    def log_likelihood(w):
        return domain.log_likelihood(w, shown, beta)

    size = REFERENCE_SIZE.get(demos, 1_000_000)
    reference = importance_reference(
        log_likelihood, domain.num_features, size, np.random.default_rng([world_seed, world, demos, 1])
    )
    policy = domain.plan(reference.map_point())
    stats = Statistics(domain, policy, domain.optimal_start_values)
    return log_likelihood, domain.num_features, reference, stats


def reacher_case(demos: int, world_seed: int):
    scenario = load_scenario(ROOT / "scenarios" / "lava_reacher.toml")
    rng = np.random.default_rng([world_seed, 1000])
    domain = get_domain("lava_reacher").make(scenario.domain_params(), rng)
    shown = [domain.demonstrate(s, rng) for s in range(demos)]
    beta = scenario.demos.beta

    def log_posterior(w):  # the learner's: its orthant prior and the trajectory likelihood
        return domain.log_prior(w) + domain.log_likelihood(w, shown, beta)

    k = domain.num_features
    reference = grid_reference(log_posterior, 400_000, k=k, rng=np.random.default_rng([world_seed, 2000]))
    policy = domain.plan(reference.map_point())  # joins the library before anything is scored
    stats = Statistics(domain, policy, lambda w: domain.optimal_start_values(w, refine=False))

    def initial(rng):
        return domain.sample_prior(rng, 4 * scenario.sampler().chains)

    return log_posterior, k, reference, stats, initial, scenario


def run_cell(label: str, case, config, seeds: list[int], suff, progress, task) -> dict:
    log_likelihood, k, reference, stats, *initial = case
    ref_nevd, ref_piob = stats(reference.points)
    q_nevd = reference.quantile(ref_nevd, suff.alpha)
    finite = np.isfinite(ref_piob)
    q_piob = Reference(
        reference.points[finite], reference.probabilities[finite] / reference.probabilities[finite].sum()
    ).quantile(ref_piob[finite], 1.0 - suff.alpha)
    results = []
    for seed in seeds:
        results.append(
            check(
                log_likelihood,
                k,
                stats,
                config,
                np.random.default_rng(seed),
                suff.alpha,
                suff.delta,
                suff.quantile_method,
                initial[0] if initial else None,
            )
        )
        progress.advance(task)
    return {
        "cell": label,
        "reference_ess": reference.effective_size,
        "reference_nevd_quantile": q_nevd,
        "reference_piob_quantile": q_piob,
        "nevd_coverage": float(np.mean([r.nevd_bound >= q_nevd for r in results])),
        "piob_coverage": float(np.mean([r.piob_bound <= q_piob for r in results])),
        "mean_nevd_bound": float(np.mean([r.nevd_bound for r in results])),
        "mean_rhat": float(np.mean([r.rhat for r in results])),
        "mean_ess": float(np.mean([r.ess for r in results])),
        "mean_bound_ess": float(np.mean([r.bound_ess for r in results])),
        "converged": float(np.mean([r.converged for r in results])),
        "seconds_per_check": float(np.median([r.seconds for r in results])),
        "seeds": len(results),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=6)
    parser.add_argument("--demos", type=int, nargs="+", default=[1, 3, 10])
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--reacher-seeds", type=int, default=30)
    parser.add_argument("--reacher-demos", type=int, nargs="+", default=[1, 3])
    parser.add_argument("--world-seed", type=int, default=20261201)
    parser.add_argument("--sampler-seed", type=int, default=1201)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    scenario = load_scenario(ROOT / "scenarios" / "gridworld.toml", args.set)
    suff, config = scenario.sufficiency, scenario.sampler()
    seeds = [int(s) for s in np.random.default_rng(args.sampler_seed).integers(2**31, size=args.seeds)]
    cells = []
    started = time.perf_counter()
    total = args.worlds * len(args.demos) * args.seeds + len(args.reacher_demos) * args.reacher_seeds
    with Progress(transient=True) as progress:
        task = progress.add_task("coverage", total=total)
        for world in range(args.worlds):
            for demos in args.demos:
                case = gridworld_case(scenario, world, demos, args.world_seed)
                cells.append(
                    {
                        "domain": "gridworld",
                        "world": world,
                        "demos": demos,
                        **run_cell(f"gridworld w{world} d{demos}", case, config, seeds, suff, progress, task),
                    }
                )
        for demos in args.reacher_demos if args.reacher_seeds else []:
            *case, reacher = reacher_case(demos, args.world_seed)
            rseeds = (
                seeds[: args.reacher_seeds]
                if args.reacher_seeds <= len(seeds)
                else [
                    int(s)
                    for s in np.random.default_rng(args.sampler_seed).integers(2**31, size=args.reacher_seeds)
                ]
            )
            cells.append(
                {
                    "domain": "lava_reacher",
                    "world": 0,
                    "demos": demos,
                    **run_cell(
                        f"lava_reacher d{demos}",
                        tuple(case),
                        reacher.sampler(),
                        rseeds,
                        reacher.sufficiency,
                        progress,
                        task,
                    ),
                }
            )
    table = Table(
        title=f"Bound coverage (target {1 - suff.delta:g}); sampler: "
        f"{config.chains} chains, burn-in {config.burn_in}, R̂ ≤ {config.rhat_target}, "
        f"ESS ≥ {config.ess_target:g}, cap {config.max_steps}"
    )
    for col in (
        "cell",
        "ref. ESS",
        "nEVD cov.",
        "PIOB cov.",
        "mean R̂",
        "mean ESS",
        "bound ESS",
        "converged",
        "s/check",
    ):
        table.add_column(col, justify="right")
    for c in cells:
        table.add_row(
            c["cell"],
            f"{c['reference_ess']:,.0f}",
            f"{c['nevd_coverage']:.2f}",
            f"{c['piob_coverage']:.2f}",
            f"{c['mean_rhat']:.3f}",
            f"{c['mean_ess']:.0f}",
            f"{c['mean_bound_ess']:.0f}",
            f"{c['converged']:.2f}",
            f"{c['seconds_per_check']:.3f}",
        )
    console = Console(width=160)
    console.print(table)
    for domain in ("gridworld", "lava_reacher"):
        mine = [c for c in cells if c["domain"] == domain]
        if not mine:
            continue
        n = sum(c["seeds"] for c in mine)
        for stat in ("nevd", "piob"):
            pooled = sum(c[f"{stat}_coverage"] * c["seeds"] for c in mine) / n
            margin = 2 * math.sqrt((1 - suff.delta) * suff.delta / n)
            worst = min(c[f"{stat}_coverage"] for c in mine)
            console.print(
                f"{domain} {stat}: pooled coverage {pooled:.3f} over {n} checks "
                f"(target ≥ {1 - suff.delta - margin:.3f} = {1 - suff.delta:g} − 2 binomial "
                f"s.e.), worst cell {worst:.2f} (target ≥ 0.85)"
            )
    console.print(f"total {time.perf_counter() - started:.0f} s")
    if args.json:
        args.json.write_text(json.dumps({"settings": config.model_dump(), "cells": cells}, indent=2))


if __name__ == "__main__":
    main()
