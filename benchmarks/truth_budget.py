"""Benchmark: is ground truth's budget large enough (issue #17, item 3)?

A replicate raises its truth, ``V*_{w*}(s)`` per evaluation start, to the best of everything it
simulated under ``w*`` (the learner's plans, refinements, candidates, demos). If that happens
often, the truth's own search is weaker than what the learner stumbles on, and its budget is too
small. This runs replicates as ``mjsuff run`` does and, beside the scenario's truth, computes
truths with other budgets at the same moment, from the same copy of the learner's library and
with randomness of their own (``truth_scale`` × the planner's budget for ``w*``'s searches, and
``cloud`` rewards planned around ``w*`` first). Nothing of them reaches the learner, so every
variant faces the same replicate. When the replicate ends, each variant is compared with the best
the replicate simulated, as the run's own truth is; the rows' own ``truth_raised_starts`` and
``truth_raise`` (the scenario's truth, with its own randomness) are printed beside them. A variant
at the scenario's budget (``4x16``) is an independent draw of the same search: how much of a raise
is the search's luck. The variants simulate on the instance's simulator, so the rows' simulation
counters include them (nothing else in the rows changes).

Printed per replicate and variant: the evaluation starts whose truth the replicate beat, the
largest raise (in units of that start's ``V* − V_rand``), how far the variant's truth lies above
the scenario's (mean over starts, same units), and the seconds it took.

With ``--re-search``, when the replicate ends a truth search at the scenario's budget (its own
randomness) runs once more, from a copy of the learner's *end* library: everything the learner
simulated, the plans with which the learner raised the truth among them (the truth's own plans
are not in it, so at a start the learner did not raise this is a second, independent truth
search). What it still gains over the end truth (the rows' truth) says whether that truth is
converged: printed are the starts it beats by more than a thousandth, the largest gain (units of
that start's ``V* − V_rand``) at the starts the learner's finds raised and at the others, and
the shift it would make in a near-optimal policy's true nEVD (the start-weighted gain over the
start-weighted ``V* − V_rand``). With ``--set domain.params.planning.truth_passes=N`` the rows'
truth was itself searched again at the replicate's end, from the first truth's plans and the
learner's best, until it settled (``mjsuff.scenes.truth.converge_truth``; the table prints its
searches and its last one's gain): the re-search, from the learner's library alone, then asks
whether a truth settled that way is one an independent search does not beat.

Use design seeds only (not a seed reported as evidence):

    python benchmarks/truth_budget.py lander --seed 2 --replicates 4 --variants 4x16 16x64
    python benchmarks/truth_budget.py lander --seed 2 --replicates 0 1 --variants --re-search
"""

from __future__ import annotations

import argparse
import copy
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from mjsuff.domain import TRUTH_SETTLED
from mjsuff.experiment.backend import shared_threads
from mjsuff.experiment.replicate import run_replicate
from mjsuff.experiment.scenario import load_scenario
from mjsuff.scenes.truth import search_truth
from mjsuff.threads import SIM_THREADS_ENV, thread_budget

ROOT = Path(__file__).resolve().parent.parent


def parse_variant(text: str) -> tuple[float, int]:
    """``SCALExCLOUD`` (``4x16``): the truth's budget scale and its cloud's size."""
    scale, cloud = text.lower().split("x")
    return float(scale), int(cloud)


class _Truths:
    """Computes every variant's truth when the replicate begins (before its own truth)."""

    def __init__(self, variants: list[tuple[float, int]], seed: int, replicate: int) -> None:
        self.variants, self.seed, self.replicate = variants, seed, replicate

    def begin(self, domain) -> None:
        self.domain, self.values, self.seconds = domain, [], []
        for i, (scale, cloud) in enumerate(self.variants):
            t0 = time.perf_counter()
            planning = domain.planning.model_copy(update={"truth_scale": scale})
            rng = np.random.default_rng((self.seed, self.replicate, 1 + i))
            self.values.append(
                search_truth(
                    domain.scene,
                    copy.deepcopy(domain.library),
                    domain.true_weights,
                    domain.planner.config,
                    planning,
                    domain.expert,
                    rng,
                    cloud=cloud,
                )
            )
            self.seconds.append(time.perf_counter() - t0)

    def step(self, *args) -> None:
        pass

    def end(self, rows) -> None:
        pass


#: A re-search's gain at a start counts when above this share of its V* − V_rand (below it:
#: polishing digits, not another basin): the rule a settled truth's searches stop by.
NOTICEABLE = TRUTH_SETTLED


def beaten(truth: np.ndarray, best: np.ndarray) -> np.ndarray:
    """Per start ``(S,)``: ``best`` lies above ``truth`` by more than rounding (the rule
    ``_Truth.raise_to`` counts raised starts by)."""
    return best - truth > 1e-12 * (1 + np.abs(truth))


def re_search(domain, end_truth: np.ndarray, raised: np.ndarray, seed: int, replicate: int) -> dict:
    """A truth search at the scenario's budget from a copy of the end library; what it gains
    over ``end_truth`` ``(S,)`` (``raised``: the starts the replicate raised, ``(S,)`` bool)."""
    t0 = time.perf_counter()
    w = domain.true_weights
    values = search_truth(
        domain.scene,
        copy.deepcopy(domain.library),
        w,
        domain.planner.config,
        domain.planning,
        domain.expert,
        np.random.default_rng((seed, replicate, 99)),
    )
    span = np.maximum(end_truth - domain.random_start_feature_expectations() @ w, 1e-12)
    gain = np.maximum(values - end_truth, 0.0)
    weights = domain.start_weights
    share = gain / span
    return {
        "starts": int(np.sum(share > NOTICEABLE)),
        "largest_raised": float(np.max(share[raised], initial=0.0)),
        "largest_other": float(np.max(share[~raised], initial=0.0)),
        "nevd_shift": float(weights @ gain / (weights @ span)),
        "seconds": time.perf_counter() - t0,
    }


def run_one(
    scene: str,
    seed: int,
    replicate: int,
    variants: list[tuple[float, int]],
    overrides: list[str],
    again: bool = False,
) -> dict:
    scenario = load_scenario(ROOT / "scenarios" / f"{scene}.toml", [f"seed={seed}", *overrides])
    truths = _Truths(variants, seed, replicate)
    t0 = time.perf_counter()
    with threadpool_limits(limits=1):
        rows = run_replicate(scenario, replicate, observer=truths)
    domain, w = truths.domain, truths.domain.true_weights
    best = domain.best_simulated_start_values(w)
    shipped = domain.true_optimal_start_values()
    v_rand = domain.random_start_feature_expectations() @ w
    out = []
    for (scale, cloud), values, seconds in zip(variants, truths.values, truths.seconds, strict=True):
        scale_ = np.maximum(values - v_rand, 1e-12)
        gain = np.maximum(best - values, 0.0)
        raised = beaten(values, best)
        out.append(
            {
                "variant": f"{scale:g}x{cloud}",
                "raised_starts": int(raised.sum()),
                "largest_raise": float(np.max(gain / scale_)),
                "above_scenario": float(np.mean((values - shipped) / np.maximum(shipped - v_rand, 1e-12))),
                "seconds": seconds,
            }
        )
    end_truth = np.maximum(shipped, domain.final_true_start_values().values)  # the rows' truth
    raised = beaten(shipped, best)  # by the learner's finds (the re-search starts from those)
    return {
        "replicate": replicate,
        "re_search": re_search(domain, end_truth, raised, seed, replicate) if again else None,
        "rows_raised_starts": int(rows[-1]["truth_raised_starts"]),
        "rows_raise": float(rows[-1]["truth_raise"]),
        "rows_passes": int(rows[-1]["truth_passes"]),
        "rows_last_gain": float(rows[-1]["truth_last_gain"]),
        "seconds": time.perf_counter() - t0,
        "variants": out,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", choices=["lava_reacher", "lander"])
    parser.add_argument("--seed", type=int, required=True, help="a design seed")
    parser.add_argument("--replicates", type=int, nargs="+", default=[0, 1, 2, 3])
    parser.add_argument(
        "--variants",
        nargs="*",
        default=["4x16", "16x64"],
        help="SCALExCLOUD: truth_scale × planner budget for w*'s searches, rewards planned around w* "
        "first (the scenario's: 4x16)",
    )
    parser.add_argument(
        "--re-search",
        action="store_true",
        help="when a replicate ends, search once more from the end library (is the end truth converged?)",
    )
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    variants = [parse_variant(v) for v in args.variants]
    if not variants and not args.re_search:
        parser.error("nothing to compute: give --variants, --re-search or both")
    t0 = time.perf_counter()
    jobs = [(args.scene, args.seed, r, variants, args.set, args.re_search) for r in args.replicates]
    threads = str(shared_threads(thread_budget(), args.workers))  # MuJoCo's rollout threads, shared
    with ProcessPoolExecutor(
        args.workers, initializer=os.environ.__setitem__, initargs=(SIM_THREADS_ENV, threads)
    ) as pool:
        results = []
        for r in pool.map(run_one, *zip(*jobs, strict=True)):  # in order, each as it is done
            results.append(r)
            print(f"replicate {r['replicate']} done ({r['seconds']:.0f} s): {r}", flush=True)
    print(f"{args.scene}, seed {args.seed}, replicates {args.replicates} ({time.perf_counter() - t0:.0f} s)")
    if variants:
        print(
            "| replicate | rows: starts raised / largest | variant | starts raised | largest raise "
            "| above the scenario's truth | truth s |"
        )
        print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in results:
        for v in r["variants"]:
            print(
                f"| {r['replicate']} | {r['rows_raised_starts']} / {r['rows_raise']:.4f} "
                f"| {v['variant']} | {v['raised_starts']} | {v['largest_raise']:.4f} "
                f"| {v['above_scenario']:+.4f} | {v['seconds']:.0f} |"
            )
    if args.re_search:
        print(
            "\n| replicate | rows: starts raised / largest | rows: searches again / last gain "
            "| re-search: starts gaining > 0.001 | largest gain at a raised start | at another "
            "| true-nEVD shift | s |"
        )
        print("| --- | --- | --- | --- | --- | --- | --- | --- |")
        for r in results:
            a = r["re_search"]
            print(
                f"| {r['replicate']} | {r['rows_raised_starts']} / {r['rows_raise']:.4f} "
                f"| {r['rows_passes']} / {r['rows_last_gain']:.4f} | {a['starts']} "
                f"| {a['largest_raised']:.4f} | {a['largest_other']:.4f} | {a['nevd_shift']:+.4f} "
                f"| {a['seconds']:.0f} |"
            )
    for i, name in enumerate(args.variants):
        counts = [r["variants"][i]["raised_starts"] for r in results]
        print(
            f"{name}: truth beaten in {sum(c > 0 for c in counts)} of {len(results)} replicates, "
            f"{sum(counts)} starts in all"
        )


if __name__ == "__main__":
    main()
