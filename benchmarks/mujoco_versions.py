"""Benchmark: raw ``mujoco.rollout`` and planner throughput on two MuJoCo versions in one run (issue #16).

mjsuff pins the MuJoCo that dm_control runs on; this compares it with another version (e.g. the
newest) on the same machine at the same time. For each scene (16 evaluation starts, built as
``benchmarks/scenes.py`` builds it) one measurement is:

1. raw ``mujoco.rollout`` steps/s (uniform-random controls, best of 5 batches of 2048
   trajectories, measured before and after the planner runs, best kept; ``scenes.py``'s code);
2. the planner's simulated steps/s for one reward vector from every evaluation start (the same
   reward vector as ``scenes.py``), and its share of (1).

Given ``--interpreters``, the measurement runs in a fresh subprocess of each interpreter in turn,
alternating (A B A B …, ``--rounds`` times) so that the machine's load falls on both alike; each
subprocess reports JSON, and the table gives per scene and version the median over rounds of raw
and planner steps/s and of the share, and the ratio of the first version to the second. Both
interpreters must import the same mjsuff (e.g. a venv with ``--system-site-packages`` and another
mujoco). Without ``--interpreters`` it measures once in this interpreter and prints the JSON.

    python benchmarks/mujoco_versions.py --interpreters python /tmp/venv40/bin/python [--rounds 3]
                                         [--scenes lava_reacher lander] [--starts 16]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import mujoco
import numpy as np
from scenes import SCENES, make_domain, make_scene, planner_steps_per_second, raw_steps_per_second

from mjsuff.sphere import random_unit_vectors


def measure(names: list[str], starts: int) -> dict:
    """One measurement of every scene in this interpreter."""
    result = {"mujoco": mujoco.__version__, "python": sys.executable, "scenes": {}}
    for name in names:
        scene = make_scene(name, starts)
        raw = raw_steps_per_second(scene)
        domain = make_domain(scene, np.random.default_rng(1))
        w = -np.abs(random_unit_vectors(np.random.default_rng(2), 1, scene.num_features))[0]
        planner, plan_time = planner_steps_per_second(domain, w)
        raw = max(raw, raw_steps_per_second(scene))  # the machine's state may change in between
        result["scenes"][name] = {
            "raw": raw,
            "planner": planner,
            "share": planner / raw,
            "plan_time": plan_time,
            "threads": scene.simulator.threads,
        }
    return result


def run_worker(python: str, names: list[str], starts: int) -> dict:
    command = [python, __file__, "--scenes", *names, "--starts", str(starts)]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode:
        sys.exit(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def drive(interpreters: list[str], rounds: int, names: list[str], starts: int) -> None:
    print(f"load average before: {load()}", flush=True)
    runs: dict[str, list[dict]] = {}
    for r in range(rounds):
        for python in interpreters:
            t = time.perf_counter()
            result = run_worker(python, names, starts)
            version = result["mujoco"]
            runs.setdefault(version, []).append(result)
            cells = ", ".join(
                f"{n} raw {s['raw'] / 1e3:,.0f}k planner {s['planner'] / 1e3:,.0f}k ({s['share']:.0%})"
                for n, s in result["scenes"].items()
            )
            print(
                f"round {r + 1}, mujoco {version} ({python}, {time.perf_counter() - t:.0f} s): {cells}",
                flush=True,
            )
    print(f"load average after: {load()}")
    if len(runs) < len(interpreters):
        print("warning: two interpreters reported the same mujoco version")
    versions = list(runs)
    threads = {s["threads"] for rs in runs.values() for r in rs for s in r["scenes"].values()}
    print(
        f"\nmedian over {rounds} rounds ({starts} evaluation starts; rollout threads "
        f"{', '.join(map(str, sorted(threads)))}):"
    )
    header = f"{'scene':<14}{'mujoco':<12}{'raw steps/s':>14}{'planner steps/s':>18}{'share':>8}"
    print(header)
    print("-" * len(header))
    for name in names:
        med = {
            v: {
                key: statistics.median(r["scenes"][name][key] for r in runs[v])
                for key in ("raw", "planner", "share")
            }
            for v in versions
        }
        for v in versions:
            m = med[v]
            print(
                f"{name:<14}{v:<12}{m['raw'] / 1e3:>13,.0f}k{m['planner'] / 1e3:>17,.0f}k{m['share']:>8.0%}"
            )
        if len(versions) == 2:
            a, b = (med[v] for v in versions)
            print(
                f"{name:<14}{'ratio':<12}{a['raw'] / b['raw']:>14.3f}"
                f"{a['planner'] / b['planner']:>18.3f}{a['share'] / b['share']:>8.3f}"
            )
    if len(versions) == 2:
        print(f"(ratio = {versions[0]} / {versions[1]})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--interpreters",
        nargs="+",
        metavar="PYTHON",
        help="run the measurement in each, alternately, and print the table",
    )
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--scenes", nargs="+", choices=sorted(SCENES), default=list(SCENES))
    parser.add_argument("--starts", type=int, default=16)
    args = parser.parse_args()
    if args.interpreters:
        drive(args.interpreters, args.rounds, args.scenes, args.starts)
    else:
        print(json.dumps(measure(args.scenes, args.starts)))


if __name__ == "__main__":
    main()
