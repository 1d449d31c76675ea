"""Run every replicate of a scenario into a run directory (see ``mjsuff.experiment.results``)."""

from __future__ import annotations

import platform
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from mjsuff import __version__
from mjsuff.experiment.measures import summarize
from mjsuff.experiment.replicate import DemoSource, StepCallback, run_replicate
from mjsuff.experiment.results import (
    atomic_write_parquet,
    atomic_write_text,
    prepare_output,
    read_steps,
    write_json,
    write_replicate,
)
from mjsuff.experiment.scenario import Scenario


@dataclass(frozen=True)
class RunResult:
    """What a run left on disk."""

    directory: Path
    completed: int
    planned: int
    interrupted: bool
    summary: dict[str, Any]
    simulation: dict[str, int]


def finalize(directory: Path, scenario: Scenario, planned: int, started: float,
             interrupted: bool) -> RunResult:
    """Combine the finished replicates into ``steps.parquet``, ``summary.json``, ``run.json``."""
    steps = read_steps(directory)
    completed = int(steps["replicate"].nunique()) if not steps.empty else 0
    summary = summarize(steps, scenario.rules.nevd_thresholds) if completed else {
        "entries": [], "nevd_bound_by_step": []}
    if completed:
        atomic_write_parquet(directory / "steps.parquet", steps)
    write_json(directory / "summary.json", {"scenario": scenario.name, **summary})
    simulation = simulation_totals(steps)
    write_json(directory / "run.json", {
        "mjsuff_version": __version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "seed": scenario.seed,
        "planned_replicates": planned,
        "completed_replicates": completed,
        "interrupted": interrupted,
        "elapsed_seconds": round(time.perf_counter() - started, 3),
        **simulation,
    })
    return RunResult(directory, completed, planned, interrupted, summary, simulation)


def simulation_totals(steps: pd.DataFrame) -> dict[str, int]:
    """MuJoCo steps simulated and diverged rollouts over the finished replicates (the step
    columns are running counts per replicate; exact domains have none)."""
    columns = ("simulated_steps", "diverged_rollouts")
    if steps.empty or not all(c in steps for c in columns):
        return {c: 0 for c in columns}
    last = steps.groupby("replicate")[list(columns)].max()
    return {c: int(last[c].sum()) for c in columns}


#: The run's Rerun recording, in its output directory.
RECORDING = "recording.rrd"


def run_scenario(
    scenario: Scenario,
    directory: Path,
    overwrite: bool = False,
    on_step: StepCallback | None = None,
    on_replicate: Callable[[int], None] | None = None,
    demo_sources: dict[int, DemoSource] | None = None,
    record: bool = True,
) -> RunResult:
    """Run all replicates in order; on Ctrl-C keep and summarize the finished ones, then re-raise.

    ``demo_sources`` maps replicates to saved demos that replace the live expert. With ``record``,
    the run streams a Rerun recording to ``directory/recording.rrd`` (``mjsuff.recording``),
    completed however the run ends.

    Raises:
        OutputError: ``directory`` cannot be used (before any work starts).
        KeyboardInterrupt: after the finished replicates are on disk and summarized.
        Any other error mid-run (e.g. ``DemoFileError``) likewise goes up after that.
    """
    prepare_output(directory, overwrite)
    atomic_write_text(directory / "config.toml", scenario.to_toml())
    started = time.perf_counter()
    recorder = None
    if record:
        from mjsuff.recording.recorder import RunRecorder  # Rerun only when recording

        recorder = RunRecorder(directory / RECORDING, scenario)
    try:
        for replicate in range(scenario.replicates):
            # The engine's matrices are small: BLAS threads only add overhead.
            with threadpool_limits(limits=1):
                rows = run_replicate(scenario, replicate, on_step,
                                     (demo_sources or {}).get(replicate),
                                     recorder.replicate(replicate) if recorder else None)
            write_replicate(directory, replicate, rows)
            if on_replicate is not None:
                on_replicate(replicate)
    except BaseException:
        # Ctrl-C, or anything failing mid-run (e.g. a saved demo set without the demo asked
        # for): the finished replicates are summarized before the error goes up.
        finalize(directory, scenario, scenario.replicates, started, interrupted=True)
        raise
    finally:
        if recorder is not None:
            recorder.close()
    return finalize(directory, scenario, scenario.replicates, started, interrupted=False)
