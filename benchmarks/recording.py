"""Benchmark: the cost of recording a run (issue #6).

Side by side in one process tree, each configuration in a fresh subprocess (so peak memory is its
own): the same scenario run with and without the Rerun recording, for a short and a 4× longer run.
Printed: wall time with and without recording, the recording's size per demo step, and the peak
resident memory of each (what recording adds must not grow with the run's length: the recording
goes to the file as the run goes, not into memory).

    python benchmarks/recording.py [--scenario scenarios/gridworld.toml] [--replicates 2]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd

CHILD = """
import json, resource, sys, time
from pathlib import Path
from mjsuff.experiment.runner import run_scenario
from mjsuff.experiment.scenario import load_scenario
scenario = load_scenario(sys.argv[1], [f"replicates={sys.argv[2]}", *sys.argv[5:]])
t = time.perf_counter()
run_scenario(scenario, Path(sys.argv[3]), record=sys.argv[4] == "1")
print(json.dumps({"seconds": time.perf_counter() - t,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def run(scenario: str, replicates: int, out: Path, record: bool, sets: list[str]) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", CHILD, scenario, str(replicates), str(out), "1" if record else "0", *sets],
        capture_output=True,
        text=True,
        check=True,
    )
    result = json.loads(done.stdout.strip().splitlines()[-1])
    steps = pd.read_parquet(out / "steps.parquet")
    result["demo_steps"] = int(steps.groupby("replicate")["step"].nunique().sum())
    rrd = out / "recording.rrd"
    result["bytes"] = rrd.stat().st_size if rrd.exists() else 0
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="scenarios/gridworld.toml")
    parser.add_argument("--replicates", type=int, default=2)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        plain = run(args.scenario, args.replicates, tmp / "plain", False, args.set)
        recorded = run(args.scenario, args.replicates, tmp / "rec", True, args.set)
        long = run(args.scenario, 4 * args.replicates, tmp / "long", True, args.set)
        long_plain = run(args.scenario, 4 * args.replicates, tmp / "long-plain", False, args.set)
    print(f"{args.scenario}, {args.replicates} replicates ({plain['demo_steps']} demo steps):")
    print(
        f"  without recording {plain['seconds']:.1f} s, with {recorded['seconds']:.1f} s "
        f"({recorded['seconds'] / plain['seconds'] - 1:+.0%})"
    )
    print(
        f"  recording {recorded['bytes'] / 1e6:.2f} MB, "
        f"{recorded['bytes'] / recorded['demo_steps'] / 1e3:.1f} kB per demo step"
    )
    print(
        f"  peak memory: {plain['peak_mb']:.0f} MB without, {recorded['peak_mb']:.0f} MB with "
        f"(recording +{recorded['peak_mb'] - plain['peak_mb']:.0f} MB)"
    )
    print(
        f"  4x longer ({long['demo_steps']} steps, {long['bytes'] / 1e6:.1f} MB file): "
        f"{long_plain['peak_mb']:.0f} MB without, {long['peak_mb']:.0f} MB with (recording "
        f"+{long['peak_mb'] - long_plain['peak_mb']:.0f} MB)"
    )


if __name__ == "__main__":
    main()
