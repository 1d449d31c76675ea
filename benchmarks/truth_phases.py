"""Benchmark: where a replicate's end searches of ground truth find their gains (issue #17, item 3).

With ``planning.truth_passes`` a replicate's truth is searched again when it ends
(``mjsuff.scenes.truth.converge_truth``), each pass one :func:`~mjsuff.scenes.truth.search_truth`
on the truth's library: a cloud of rewards around ``w*`` planned with the planner's budget, then
``w*``'s three searches (the seed planner's wide one, a broad CMA-ES, the planner itself, each
``truth_scale`` × its budget), then the local quadratic model until it stops improving. The
passes cost a third to a half of a lander replicate's simulation (docs/issue-17-measurements.md,
stop 55). This runs replicates as ``mjsuff run`` does and records, in every end pass, what each
phase raised the truth by at every evaluation start (in units of that start's ``V* − V_rand``)
and the MuJoCo steps it cost, so a cheaper pass can be chosen by what finds the gains.

Printed per replicate and pass: per phase, the starts it raised by more than ``TRUTH_SETTLED``
(0.001), its largest gain and its steps; then per phase over all passes.

Use design seeds only (not a seed reported as evidence):

    python benchmarks/truth_phases.py lander --seed 2 --replicates 0 1 2 3
"""

from __future__ import annotations

import argparse
import inspect
import itertools
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

import mjsuff.scenes.domain as scene_domain
import mjsuff.scenes.truth as truth
from mjsuff.domain import TRUTH_SETTLED
from mjsuff.experiment.backend import shared_threads
from mjsuff.experiment.replicate import run_replicate
from mjsuff.experiment.scenario import load_scenario
from mjsuff.threads import SIM_THREADS_ENV, thread_budget

ROOT = Path(__file__).resolve().parent.parent
PHASES = ("cloud", "wide", "broad", "planner", "polish")


class _Recorder:
    """The end passes' phases: per pass, per phase, the library's best under ``w*`` per start
    after it and the steps it cost."""

    def __init__(self) -> None:
        self.active = False
        self.passes: list[list[tuple[np.ndarray, int]]] = []

    def begin_pass(self, library, scene, w) -> None:
        self.library, self.scene, self.w = library, scene, w[None]
        self.passes.append([(self.values(), scene.simulator.steps_simulated)])

    def values(self) -> np.ndarray:
        return np.array([self.library.best_value(s, self.w)[0] for s in range(len(self.scene.starts))])

    def mark(self) -> None:
        if self.active:
            self.passes[-1].append((self.values(), self.scene.simulator.steps_simulated))


RECORDER = _Recorder()


class _RecordingPlanner(truth.SamplingPlanner):
    def plan(self, *args, **kwargs):
        plans = super().plan(*args, **kwargs)
        RECORDER.mark()
        return plans


def _recording_polish(*args, **kwargs) -> None:
    _polish(*args, **kwargs)
    RECORDER.mark()


def _recording_search(scene, library, true_weights, *args, **kwargs):
    if RECORDER.active:
        RECORDER.begin_pass(library, scene, true_weights)
        if kwargs.get("cloud", truth.TRUTH_CLOUD) == 0:  # no cloud planned: an empty phase
            RECORDER.mark()
    return _search(scene, library, true_weights, *args, **kwargs)


def _recording_converge(*args, **kwargs):
    bound = inspect.signature(_converge).bind(*args, **kwargs)
    RECORDER.v_rand = np.asarray(bound.arguments["v_rand"])
    RECORDER.active = True
    try:
        return _converge(*args, **kwargs)
    finally:
        RECORDER.active = False


_polish, _search, _converge = truth.polish_library, truth.search_truth, truth.converge_truth


def run_one(scene: str, seed: int, replicate: int, overrides: list[str]) -> dict:
    RECORDER.passes = []  # a worker process runs several replicates
    truth.SamplingPlanner = _RecordingPlanner
    truth.polish_library = _recording_polish
    truth.search_truth = _recording_search
    scene_domain.converge_truth = _recording_converge
    scenario = load_scenario(ROOT / "scenarios" / f"{scene}.toml", [f"seed={seed}", *overrides])
    t0 = time.perf_counter()
    with threadpool_limits(limits=1):
        rows = run_replicate(scenario, replicate)
    passes = []
    for marks in RECORDER.passes:
        base = marks[0][0]
        span = np.maximum(base - RECORDER.v_rand, 1e-12)
        phases = []
        for (before, steps_before), (after, steps_after) in itertools.pairwise(marks):
            gain = np.maximum(after - before, 0.0) / span
            phases.append(
                {
                    "starts": int(np.sum(gain > TRUTH_SETTLED)),
                    "largest": float(gain.max()),
                    "steps": steps_after - steps_before,
                }
            )
        passes.append(phases)
    return {
        "replicate": replicate,
        "passes": passes,
        "settled": float(rows[-1]["truth_last_gain"]) <= TRUTH_SETTLED,
        "seconds": time.perf_counter() - t0,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", choices=["lava_reacher", "lander"])
    parser.add_argument("--seed", type=int, required=True, help="a design seed")
    parser.add_argument("--replicates", type=int, nargs="+", default=[0, 1, 2, 3])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    t0 = time.perf_counter()
    threads = str(shared_threads(thread_budget(), args.workers))  # MuJoCo's rollout threads, shared
    jobs = [(args.scene, args.seed, r, args.set) for r in args.replicates]
    with ProcessPoolExecutor(
        args.workers, initializer=os.environ.__setitem__, initargs=(SIM_THREADS_ENV, threads)
    ) as pool:
        results = list(pool.map(run_one, *zip(*jobs, strict=True)))
    print(f"{args.scene}, seed {args.seed}, replicates {args.replicates} ({time.perf_counter() - t0:.0f} s)")
    print("| replicate | pass | " + " | ".join(PHASES) + " |")
    print("| --- | --- |" + " --- |" * len(PHASES))
    totals = {p: [0, 0.0, 0] for p in PHASES}
    for r in results:
        for i, phases in enumerate(r["passes"]):
            cells = []
            for name, p in zip(PHASES, phases, strict=True):
                cells.append(f"{p['starts']} / {p['largest']:.4f} / {p['steps'] / 1e6:.1f}M")
                total = totals[name]
                total[0] += p["starts"]
                total[1] = max(total[1], p["largest"])
                total[2] += p["steps"]
            print(f"| {r['replicate']} | {i + 1} | " + " | ".join(cells) + " |")
        passes, seconds = len(r["passes"]), r["seconds"]
        print(f"replicate {r['replicate']}: {passes} passes, settled {r['settled']}, {seconds:.0f} s")
    print("(cells: starts raised by > 0.001 of V* - V_rand / largest gain / MuJoCo steps)")
    for name, (starts, largest, steps) in totals.items():
        print(f"{name}: {starts} start-raises, largest {largest:.4f}, {steps / 1e6:.0f}M steps in all")


if __name__ == "__main__":
    main()
