"""Benchmark: MuJoCo's own step on each scene, the floor under a check's rollouts (issue #17).

For each scene (the shipped scenario's instance 0), 1,200 uniformly drawn knot sets from its
evaluation starts are simulated with ``mujoco.rollout`` alone (no features, no checks): the
microseconds per step on one thread and the wall microseconds per step on ``--threads``; then, one
thread each, the model with each of MuJoCo's disable flags that the scene does not already set,
and with the other Jacobian form, and whether the trajectories (states and sensor data) keep the
same bits. A flag that
keeps the bits and saves time would be a free speed-up; one that changes the bits changes the
physics (and every result). Medians of ``--rounds`` alternating rounds.

    python benchmarks/mujoco_step.py [--rounds 5] [--threads 2] [--scenes lava_reacher lander]
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np
from mujoco import rollout
from threadpoolctl import threadpool_limits

from mjsuff.experiment.replicate import make_instance
from mjsuff.experiment.run_summary import machine_info
from mjsuff.experiment.scenario import load_scenario
from mjsuff.scenes.domain import SceneDomain

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
BATCH = 1200
#: Flags whose stage these scenes may not need; each is tried alone.
FLAGS = ("SENSOR", "MIDPHASE", "EQUALITY", "FRICTIONLOSS", "LIMIT", "FILTERPARENT", "WARMSTART", "CONTACT")


Result = tuple[np.ndarray, np.ndarray]  # states, sensor data


def median_times(calls: dict[str, Callable[[], Result]], rounds: int) -> dict[str, tuple[float, Result]]:
    """Median seconds and the last result of each call, rounds alternating between them."""
    times: dict[str, list[float]] = {name: [] for name in calls}
    results: dict[str, Result] = {}
    for _ in range(rounds):
        for name, call in calls.items():
            t0 = time.perf_counter()
            results[name] = call()
            times[name].append(time.perf_counter() - t0)
    return {name: (float(np.median(t)), results[name]) for name, t in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--scenes", nargs="+", default=["lava_reacher", "lander"])
    args = parser.parse_args()
    machine = machine_info()
    print(f"machine: {machine['cpu']}, {os.cpu_count()} cores; MuJoCo {machine['mujoco']}")
    for name in args.scenes:
        with threadpool_limits(limits=1):
            domain = make_instance(load_scenario(SCENARIOS / f"{name}.toml"), 0)
        if not isinstance(domain, SceneDomain):
            raise SystemExit(f"{name}: not a MuJoCo scene")
        scene, model = domain.scene, domain.scene.model
        rng = np.random.default_rng(1)
        starts = scene.starts[rng.integers(len(scene.starts), size=BATCH)]
        anchor = scene.anchor(starts) if scene.spline.anchored else None
        controls = np.ascontiguousarray(scene.spline.controls(scene.spline.uniform(rng, BATCH), anchor))
        initial = np.ascontiguousarray(scene.start_states(starts))
        steps = controls.shape[0] * controls.shape[1]

        def run(
            m: mujoco.MjModel, threads: int, initial: np.ndarray = initial, controls: np.ndarray = controls
        ) -> Callable[[], Result]:
            datas = [mujoco.MjData(m) for _ in range(threads)]
            return lambda: rollout.rollout(m, datas, initial, controls)

        variants = {"shipped": model}
        for flag in FLAGS:
            bit = int(getattr(mujoco.mjtDisableBit, f"mjDSBL_{flag}"))
            if not model.opt.disableflags & bit:
                variant = model.__copy__()
                variant.opt.disableflags |= bit
                variants[f"no {flag.lower()}"] = variant
        jacobian = model.__copy__()
        dense = int(mujoco.mjtJacobian.mjJAC_DENSE)
        jacobian.opt.jacobian = int(mujoco.mjtJacobian.mjJAC_SPARSE) if model.opt.jacobian == dense else dense
        variants["other jacobian"] = jacobian
        calls = {f"{v}, 1 thread": run(m, 1) for v, m in variants.items()}
        calls[f"shipped, {args.threads} threads"] = run(model, args.threads)
        measured = median_times(calls, args.rounds)
        base_time, base = measured["shipped, 1 thread"]
        print(
            f"\n{name}: {BATCH} rollouts of {controls.shape[1]} steps from its evaluation starts "
            f"(timestep {model.opt.timestep:g} s), medians of {args.rounds} alternating rounds"
        )
        for label, (seconds, result) in measured.items():
            us = seconds / steps * 1e6
            same = all(np.array_equal(a, b) for a, b in zip(result, base, strict=True))
            print(f"  {label}: {us:.2f} µs a step ({base_time / seconds:.2f}x shipped); same bits: {same}")


if __name__ == "__main__":
    main()
