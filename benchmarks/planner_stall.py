"""Benchmark: would stopping a stalled planner problem early save the check's V* time? (issue #17)

A check's time is almost all ``V*`` (79–84% on the lander), and ``V*`` is almost all the CMA-ES
of the samples that can move the bound: every (sample, evaluation start) runs the full
``cma_iterations`` generations, even when its warm start is already its optimum. This benchmark
runs the two checks of ``benchmarks/scene_check.py`` (10 demos, then an 11th: the warm state) at
the scenario's settings and records, for every problem the planner solves inside them, its best
value after each generation. Then it replays a stopping rule on those traces:

    stop a problem after generation g when its best rose by at most tol · (V* − V_rand) over the
    last W generations (V*: its best at the full budget; V_rand: the random policy's value there)

and prints, per W, the share of the planner's generations the rule would spend and what it would
lose against the full budget (in units of V* − V_rand: mean, max, and how many problems lose more
than 0.001). The issue's tail target is 1% mean / 3% max against a 10×-budget plan, so a rule that
loses more than that against the learner's own budget cannot be taken.

    python benchmarks/planner_stall.py [--scene lander] [--windows 8 12 16] [--tol 0.001]
        [--set KEY=VALUE ...]

Only problems at the planner's (π's) budget are replayed: the samples planned one by one, and
π_MAP (with ``planning.decisive`` set, the samples' problems only where it has π's CMA-ES
generations). The traces are recorded by wrapping the planner's best-so-far bookkeeping; nothing the
planner does changes.
"""

from __future__ import annotations

import argparse

import numpy as np
from scene_check import NUM_DEMOS, SCENARIOS, check
from threadpoolctl import threadpool_limits

from mjsuff.experiment.replicate import make_instance
from mjsuff.experiment.scenario import load_scenario
from mjsuff.scenes import planner as planner_module


class Traces:
    """Every plan's best values after each generation, with its problems' starts and weights:
    ``SamplingPlanner.plan`` and the best-so-far bookkeeping wrapped while inside."""

    def __init__(self) -> None:
        #: Per plan call: starts ``(B,)``, weights ``(B, k)``, best values after every update.
        self.plans: list[tuple[np.ndarray, np.ndarray, list[np.ndarray]]] = []
        self._plan = planner_module.SamplingPlanner.plan
        self._update = planner_module._Best.update

    def __enter__(self) -> Traces:
        plans, plan, update = self.plans, self._plan, self._update

        def recording_plan(planner, starts, weights, rng, warm_knots=None):
            plans.append((np.asarray(starts), np.asarray(weights), []))
            return plan(planner, starts, weights, rng, warm_knots=warm_knots)

        def recording_update(best, samples, features, values):
            update(best, samples, features, values)
            plans[-1][2].append(best.values.copy())

        planner_module.SamplingPlanner.plan = recording_plan
        planner_module._Best.update = recording_update
        return self

    def __exit__(self, *exc) -> None:
        planner_module.SamplingPlanner.plan = self._plan
        planner_module._Best.update = self._update


def replay(history: np.ndarray, scale: np.ndarray, window: int, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Generations spent ``(B,)`` and loss against the full budget in units of ``scale`` ``(B,)``
    under the stall rule with ``window`` and ``tol`` (module docs)."""
    generations, count = history.shape
    spent = np.full(count, generations)
    for j in range(count):
        for g in range(window, generations):
            if history[g, j] - history[g - window, j] <= tol * scale[j]:
                spent[j] = g + 1
                break
    loss = (history[-1] - history[spent - 1, np.arange(count)]) / scale
    return spent, loss


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="lander")
    parser.add_argument("--windows", nargs="+", type=int, default=[8, 12, 16])
    parser.add_argument("--tol", type=float, default=1e-3)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    scenario = load_scenario(SCENARIOS / f"{args.scene}.toml", args.set)
    with threadpool_limits(limits=1):
        domain = make_instance(scenario, 0)
        rng = np.random.default_rng(1)
        pool = len(domain.pool)
        demos = [domain.demonstrate(s % pool, rng) for s in range(NUM_DEMOS + 1)]
        random_mu = domain.random_start_feature_expectations()
        generations = domain.planner.config.cma_iterations
        results = {}
        for label, shown, seed in (("first check", demos[:NUM_DEMOS], 2), ("warm check", demos, 3)):
            with Traces() as traces:
                check(domain, shown, scenario, np.random.default_rng(seed))
            results[label] = traces
    print(
        f"\n{args.scene}: problems at π's budget ({generations} CMA-ES generations); "
        f"rule: stop when the best rose ≤ {args.tol:g} of V* − V_rand over the last W generations"
    )
    for label, traces in results.items():
        runs = []
        for starts, weights, values in traces.plans:
            if len(values) != generations or starts.max() >= len(random_mu):
                continue  # another budget (refinements), or not from the evaluation starts
            history = np.array(values)
            scale = history[-1] - np.einsum("bk,bk->b", weights, random_mu[starts])
            runs.append((history, scale))
        print(f"  {label}: {sum(h.shape[1] for h, _ in runs)} problems in {len(runs)} plan calls")
        for window in args.windows:
            spent, loss = (
                np.concatenate(part)
                for part in zip(*(replay(h, s, window, args.tol) for h, s in runs), strict=True)
            )
            print(
                f"    W = {window:2d}: {spent.mean() / generations:.2f} of the generations; loss mean "
                f"{loss.mean():.4f}, max {loss.max():.4f}, > 0.001 in {(loss > 1e-3).sum()} of {len(loss)}"
            )


if __name__ == "__main__":
    main()
