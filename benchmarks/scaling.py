"""Benchmark: replicates per minute on each backend (issue #7), side by side in one run.

The same scenario and seeds run on the serial backend (1 process), on 2 local worker processes and
on a local Ray instance with 2 CPUs; the results must be identical (checked), and the throughput
of each is printed with its ratio to serial. Start-up (process spawn, Ray start) is included: it
is what a user waits for.

    python benchmarks/scaling.py [--scenario scenarios/gridworld.toml] [--replicates 8]
                                 [--set KEY=VALUE ...] [--backends serial local ray]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import pandas as pd

from mjsuff.experiment.backends import make_backend
from mjsuff.experiment.runner import run_scenario
from mjsuff.experiment.scenario import load_scenario


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="scenarios/gridworld.toml")
    parser.add_argument("--replicates", type=int, default=8)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--backends", nargs="+", default=["serial", "local", "ray"])
    args = parser.parse_args()
    scenario = load_scenario(args.scenario, [*args.set, f"replicates={args.replicates}"])
    print(f"{scenario.name}: {args.replicates} replicates, overrides {args.set or 'none'}")
    reference = None
    serial_rate = None
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.backends:
            backend = make_backend(name, workers=1 if name == "serial" else 2)
            started = time.perf_counter()
            run_scenario(scenario, Path(tmp) / name, backend=backend, record=False)
            elapsed = time.perf_counter() - started
            if name == "ray":
                backend.shutdown()
            steps = pd.read_parquet(Path(tmp) / name / "steps.parquet")
            same = (
                "reference"
                if reference is None
                else ("identical" if steps.equals(reference) else "DIFFERENT")
            )
            reference = steps if reference is None else reference
            rate = args.replicates / elapsed * 60
            serial_rate = serial_rate or rate
            print(
                f"  {backend.describe():32s} {elapsed:7.1f} s  {rate:7.2f} replicates/min  "
                f"{rate / serial_rate:4.2f}x serial  results {same}",
                flush=True,
            )


if __name__ == "__main__":
    main()
