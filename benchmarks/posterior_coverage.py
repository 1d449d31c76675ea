"""Benchmark: does the posterior keep w* where the bound looks (issue #17, bound vs. truth)?

The α-VaR bound can only be above the true nEVD as often as it claims if ``w*`` is a typical draw
of the posterior. This checks that directly, without the bound's V* search, on calibration
instances of a scene (the streams ``mjsuff calibrate`` uses; never a run's): each instance is shown
the demos a passive run would be shown, and after every demo the posterior is sampled and π_MAP
planned, as in a run (the library grows the same way; V* is the library's best, unrefined). For
each β, printed per demo count over instances:

* ``HPD``: the share of instances whose ``w*`` lies outside the posterior's 90% highest-density
  region (its log-posterior below 90% of the samples'); 0.10 if the posterior is calibrated;
* ``tail``: the share whose nEVD of π_MAP at ``w*`` exceeds the samples' α-quantile (the bound's
  point estimate, without its finite-sample margin); at most 1 − α (0.05) if the posterior is
  calibrated.

A share that grows with the demos means the likelihood is misspecified in a way more demos make
more confident: the bound then loses its confidence against the truth however good V* is.

``--demonstrator likelihood`` is the sanity check of the machinery (sampler, HPD, quantile): every
demo shown is instead drawn from the likelihood's own candidate set ``C_j`` (built around the
expert's demo) with probability ∝ ``exp(β w*·φ)``, the demonstrator the likelihood describes. Its
shares should then be near their calibrated values (up to the set's own dependence on ``w*``).

    python benchmarks/posterior_coverage.py lava_reacher --instances 10 --betas 34 17 8.5
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from mjsuff.bounds import normalized_evd, policy_values
from mjsuff.demo_schedule import DemoSchedule
from mjsuff.domain import Demo
from mjsuff.experiment.replicate import make_instance
from mjsuff.experiment.scenario import load_scenario
from mjsuff.posterior import sample_posterior
from mjsuff.seeds import stream_rng, stream_seed

ROOT = Path(__file__).resolve().parent.parent
HPD_LEVEL = 0.9


def likelihood_demo(domain, demo: Demo, beta: float, rng: np.random.Generator) -> Demo:
    """A demo drawn from ``demo``'s candidate set ∝ exp(β w*·φ), with that same candidate set."""
    candidates = domain.candidate_features(demo)
    logits = beta * (candidates @ domain.true_weights)
    p = np.exp(logits - logits.max())
    pick = int(rng.choice(len(candidates), p=p / p.sum()))
    return domain.candidate_sets.choose(demo, pick)


def run_instance(
    scene: str, instance: int, beta: float, overrides: list[str], demonstrator: str = "expert"
) -> list[dict]:
    """Per demo count: w*'s HPD rank among the posterior's samples, its nEVD and the samples' α-quantile."""
    scenario = load_scenario(ROOT / "scenarios" / f"{scene}.toml", [*overrides, f"demos.beta={beta}"])
    alpha = scenario.sufficiency.alpha
    with threadpool_limits(limits=1):
        domain = make_instance(scenario, instance, stream_seed(scenario.seed, instance, "calibration", 0))
        schedule = DemoSchedule.draw(  # calibration's schedule, without its poor-demo draws
            domain.pool.size,
            scenario.demos.max_demos,
            0.0,
            stream_rng(scenario.seed, instance, "calibration", 1),
            stream_rng(scenario.seed, instance, "calibration", 2),
        )
        demo_rng = schedule.rng
        w_star = np.asarray(domain.true_weights, dtype=float)
        sw, mu_rand = domain.start_weights, domain.random_start_feature_expectations()
        demos, rows, previous = [], [], None
        for n, start in enumerate(schedule.passive_starts(), start=1):
            demo = domain.demonstrate(int(start), demo_rng)
            if demonstrator == "likelihood":
                demo = likelihood_demo(domain, demo, beta, demo_rng)
            demos.append(demo)

            def log_post(w, used=tuple(demos)):
                return domain.log_prior(w) + domain.log_likelihood(w, list(used), beta)

            rng = stream_rng(scenario.seed, instance, "calibration", 3, n)
            initial = (
                previous if previous is not None else domain.sample_prior(rng, 4 * scenario.sampler().chains)
            )
            post = sample_posterior(log_post, domain.num_features, scenario.sampler(), rng, initial=initial)
            previous = post.samples
            mu = domain.start_feature_expectations(domain.plan(post.map_weights))
            weights = np.vstack([post.samples, w_star])
            v_opt = domain.optimal_start_values(weights, refine=False) @ sw
            nevd = normalized_evd(v_opt, policy_values(weights, mu, sw), policy_values(weights, mu_rand, sw))
            lp = log_post(weights)
            rows.append(
                {
                    "instance": instance,
                    "beta": beta,
                    "demos": n,
                    "hpd_rank": float(np.mean(lp[:-1] < lp[-1])),
                    "true_nevd": float(nevd[-1]),
                    "quantile": float(np.quantile(nevd[:-1], alpha)),
                }
            )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", choices=["lava_reacher", "lander"])
    parser.add_argument("--instances", type=int, default=10)
    parser.add_argument("--betas", type=float, nargs="+", default=[34.0, 17.0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument(
        "--demonstrator",
        choices=["expert", "likelihood"],
        default="expert",
        help="who shows the demos: the scene's expert, or a Boltzmann draw from the "
        "likelihood's candidate set (the sanity check)",
    )
    args = parser.parse_args()
    t0 = time.perf_counter()
    jobs = [
        (args.scene, i, b, args.set, args.demonstrator) for b in args.betas for i in range(args.instances)
    ]
    with ProcessPoolExecutor(args.workers) as pool:
        rows = [r for rs in pool.map(run_instance, *zip(*jobs, strict=True)) for r in rs]
    alpha = load_scenario(ROOT / "scenarios" / f"{args.scene}.toml", args.set).sufficiency.alpha
    demos = sorted({r["demos"] for r in rows})
    print(
        f"{args.scene}: {args.instances} calibration instances, demonstrator {args.demonstrator},"
        f" {time.perf_counter() - t0:.0f} s"
    )
    print("| β | share | " + " | ".join(str(n) for n in demos) + " |")
    print("| --- | --- |" + " --- |" * len(demos))
    for beta in args.betas:
        mine = [r for r in rows if r["beta"] == beta]
        hpd = [np.mean([r["hpd_rank"] < 1 - HPD_LEVEL for r in mine if r["demos"] == n]) for n in demos]
        tail = [np.mean([r["true_nevd"] > r["quantile"] for r in mine if r["demos"] == n]) for n in demos]
        print(f"| {beta:g} | w* outside 90% HPD | " + " | ".join(f"{v:.2f}" for v in hpd) + " |")
        print(f"| {beta:g} | nEVD(w*) > {alpha:g}-quantile | " + " | ".join(f"{v:.2f}" for v in tail) + " |")
    for beta in args.betas:
        mine = [r for r in rows if r["beta"] == beta]
        print(
            f"β {beta:g}: overall outside HPD {np.mean([r['hpd_rank'] < 1 - HPD_LEVEL for r in mine]):.3f},"
            f" nEVD above quantile {np.mean([r['true_nevd'] > r['quantile'] for r in mine]):.3f}"
            f" ({len(mine)} posteriors)"
        )


if __name__ == "__main__":
    main()
