"""Run every replicate of a scenario (every cell of its sweep) into a run directory.

See ``mjsuff.experiment.results`` for the layout. Replicates run on a ``Backend`` (in this process,
local worker processes or Ray) and each is written to disk the moment it finishes, so a killed run
loses only the replicates that were running; ``resume=True`` continues it without redoing or
duplicating any finished replicate.

Recordings: each replicate records into ``recordings/replicate-NNNNN.rrd`` of its cell (renamed
from a temporary name when it finishes); when the run ends, however it ends, the finished ones are
merged into the cell's ``recording.rrd`` (``rerun rrd merge``), which is then the one file to open.
"""

from __future__ import annotations

import platform
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from mjsuff import __version__
from mjsuff.experiment.backends import Backend, ReplicateTask, SerialBackend, partial_path
from mjsuff.experiment.measures import summarize
from mjsuff.experiment.replicate import DemoSource
from mjsuff.experiment.results import (
    OutputError,
    atomic_write_parquet,
    atomic_write_text,
    prepare_output,
    read_steps,
    replicate_path,
    write_json,
    write_replicate,
)
from mjsuff.experiment.scenario import Scenario, SweepCell

#: A cell's merged Rerun recording, in its output directory.
RECORDING = "recording.rrd"
#: Per-replicate recordings, before they are merged into ``RECORDING``.
RECORDINGS = "recordings"

ProgressCallback = Callable[[int, int, float], None]
"""Called as ``(finished replicates, planned replicates, work done in replicates)``."""


@dataclass(frozen=True)
class RunResult:
    """What a run left on disk (for a sweep: totals, with each cell's own result in ``cells``)."""

    directory: Path
    completed: int
    planned: int
    interrupted: bool
    summary: dict[str, Any]
    simulation: dict[str, int]
    cells: tuple[CellResult, ...] = ()


@dataclass(frozen=True)
class CellResult:
    labels: dict[str, Any]
    result: RunResult


def simulation_totals(steps: pd.DataFrame) -> dict[str, int]:
    """MuJoCo steps simulated and diverged rollouts over the finished replicates (the step
    columns are running counts per replicate; exact domains have none)."""
    columns = ("simulated_steps", "diverged_rollouts")
    if steps.empty or not all(c in steps for c in columns):
        return {c: 0 for c in columns}
    last = steps.groupby("replicate")[list(columns)].max()
    return {c: int(last[c].sum()) for c in columns}


def merge_recordings(directory: Path) -> Path | None:
    """Merge ``recording.rrd`` and the finished ``recordings/replicate-*.rrd`` into
    ``recording.rrd`` (atomically), then drop the merged parts and any unfinished ones."""
    parts_dir = directory / RECORDINGS
    parts = sorted(parts_dir.glob("replicate-*.rrd")) if parts_dir.is_dir() else []
    for stale in parts_dir.glob(".*.partial") if parts_dir.is_dir() else []:
        stale.unlink(missing_ok=True)
    target = directory / RECORDING
    if not parts:
        return target if target.exists() else None
    inputs = ([target] if target.exists() else []) + parts
    if len(inputs) == 1:
        parts[0].replace(target)
        return target
    tmp = directory / f".{RECORDING}.tmp"
    done = subprocess.run([sys.executable, "-m", "rerun", "rrd", "merge", *map(str, inputs),
                           "-o", str(tmp)], capture_output=True, text=True)
    if done.returncode != 0 or not tmp.exists():
        tmp.unlink(missing_ok=True)
        raise OutputError(f"{directory}: merging the replicates' recordings failed "
                          f"({done.stderr.strip().splitlines()[-1:] or 'no message'}); they are "
                          f"kept in {parts_dir}")
    tmp.replace(target)
    for part in parts:
        part.unlink()
    return target


def _drop_empty(directory: Path) -> None:
    if directory.is_dir() and not any(directory.iterdir()):
        directory.rmdir()


def finalize(directory: Path, scenario: Scenario, started: float, interrupted: bool,
             backend: str = "serial") -> RunResult:
    """Combine a cell's finished replicates into ``steps.parquet``, ``summary.json``, ``run.json``
    and merge its recordings."""
    merge_recordings(directory)
    _drop_empty(directory / RECORDINGS)
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
        "backend": backend,
        "planned_replicates": scenario.replicates,
        "completed_replicates": completed,
        "interrupted": interrupted,
        "elapsed_seconds": round(time.perf_counter() - started, 3),
        **simulation,
    })
    return RunResult(directory, completed, scenario.replicates, interrupted, summary, simulation)


def _flatten(data: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(data, dict):
        out: dict[str, Any] = {}
        for k, v in data.items():
            out.update(_flatten(v, f"{prefix}{k}."))
        return out
    return {prefix.rstrip("."): data}


def check_resumable(directory: Path, scenario: Scenario) -> None:
    """A run directory can be resumed with ``scenario``: same scenario apart from ``replicates``."""
    import tomllib

    config = directory / "config.toml"
    if not config.is_file():
        raise OutputError(f"{directory}: --resume: no config.toml here, so no run to resume")
    try:
        old = _flatten(tomllib.loads(config.read_text()))
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise OutputError(f"{config}: --resume: cannot read the run's scenario ({exc})") from None
    new = _flatten(tomllib.loads(scenario.to_toml()))
    for key in sorted(set(old) | set(new)):
        if key != "replicates" and old.get(key) != new.get(key):
            raise OutputError(f"{directory}: --resume: the scenario differs from the run's "
                              f"config.toml at {key} ({old.get(key)!r} there, {new.get(key)!r} "
                              "now); resume with the same scenario and overrides")


def _cell_directory(directory: Path, cell: SweepCell, sweep: bool) -> Path:
    return directory / "cells" / cell.dirname if sweep else directory


def run_scenario(
    scenario: Scenario,
    directory: Path,
    overwrite: bool = False,
    progress: ProgressCallback | None = None,
    demo_sources: dict[int, DemoSource] | None = None,
    record: bool = True,
    backend: Backend | None = None,
    resume: bool = False,
) -> RunResult:
    """Run every replicate of every sweep cell on ``backend`` (default: in this process).

    Each finished replicate is written at once; on Ctrl-C or any error the finished ones are
    summarized (and their recordings merged) before the error goes up. With ``resume``, the
    replicates already in ``directory`` are kept and only the others run.

    ``demo_sources`` maps replicates to saved demos that replace the live expert (not with a
    sweep). Without a sweep the directory holds one run; with one, each cell is a run of its own
    under ``cells/`` and the top level holds ``sweep.json`` and the combined ``steps.parquet``.

    Raises:
        OutputError: ``directory`` cannot be used (before any work starts).
        KeyboardInterrupt: after the finished replicates are on disk and summarized.
        Any other error mid-run (e.g. ``DemoFileError``) likewise goes up after that.
    """
    backend = backend or SerialBackend()
    cells = scenario.cells()
    sweep = bool(scenario.sweep)
    if sweep and demo_sources:
        raise OutputError(f"{directory}: saved demos (--demos) cannot be used with a sweep")
    if resume:
        check_resumable(directory, scenario)
    prepare_output(directory, overwrite, resume)
    atomic_write_text(directory / "config.toml", scenario.to_toml())
    tasks: list[ReplicateTask] = []
    finished = 0
    for cell in cells:
        cell_dir = _cell_directory(directory, cell, sweep)
        if sweep:
            cell_dir.mkdir(parents=True, exist_ok=True)
            (cell_dir / "replicates").mkdir(exist_ok=True)
            atomic_write_text(cell_dir / "config.toml", cell.scenario.to_toml())
        if record:
            (cell_dir / RECORDINGS).mkdir(exist_ok=True)
        for replicate in range(scenario.replicates):
            if replicate_path(cell_dir, replicate).exists():
                finished += 1
                continue
            recording = (cell_dir / RECORDINGS / f"replicate-{replicate:05d}.rrd") if record else None
            if recording is not None:
                partial_path(recording).unlink(missing_ok=True)
            tasks.append(ReplicateTask((cell.index, replicate), cell.scenario, replicate,
                                       (demo_sources or {}).get(replicate), recording))
    if sweep:
        write_json(directory / "sweep.json", {"keys": list(scenario.sweep), "cells": [
            {"index": c.index, "labels": c.labels,
             "directory": str(_cell_directory(directory, c, True).relative_to(directory))}
            for c in cells]})

    planned = len(cells) * scenario.replicates
    started = time.perf_counter()
    fractions: dict[tuple[int, int], float] = {}

    def report() -> None:
        if progress is not None:
            progress(finished, planned, finished + sum(fractions.values()))

    def on_step(task: ReplicateTask, step: int, max_demos: int) -> None:
        fractions[task.key] = step / max_demos
        report()

    report()
    interrupted = True
    try:
        for task, rows in backend.run(tasks, on_step if progress is not None else None):
            write_replicate(_cell_directory(directory, cells[task.key[0]], sweep),
                            task.replicate, rows)
            fractions.pop(task.key, None)
            finished += 1
            report()
        interrupted = False
    finally:
        # Ctrl-C, or anything failing mid-run (e.g. a saved demo set without the demo asked
        # for): the finished replicates are summarized before the error goes up.
        results = [CellResult(c.labels, finalize(_cell_directory(directory, c, sweep), c.scenario,
                                                 started, interrupted, backend.describe()))
                   for c in cells]
    if not sweep:
        return results[0].result
    return finalize_sweep(directory, scenario, results, started, interrupted, backend.describe())


def finalize_sweep(directory: Path, scenario: Scenario, results: list[CellResult], started: float,
                   interrupted: bool, backend: str) -> RunResult:
    """The top level of a sweep: every cell's steps in one ``steps.parquet`` (with a ``cell``
    column and one column per sweep key), ``summary.json`` with each cell's summary, ``run.json``."""
    frames = []
    for index, cell in enumerate(results):
        steps = read_steps(cell.result.directory)
        if steps.empty:
            continue
        steps.insert(0, "cell", index)
        for key, value in cell.labels.items():
            steps.insert(1, key, value)
        frames.append(steps)
    if frames:
        atomic_write_parquet(directory / "steps.parquet", pd.concat(frames, ignore_index=True))
    write_json(directory / "summary.json", {"scenario": scenario.name, "cells": [
        {"labels": c.labels, **c.result.summary} for c in results]})
    completed = sum(c.result.completed for c in results)
    simulation = {k: sum(c.result.simulation[k] for c in results)
                  for k in ("simulated_steps", "diverged_rollouts")}
    write_json(directory / "run.json", {
        "mjsuff_version": __version__,
        "python": platform.python_version(),
        "seed": scenario.seed,
        "backend": backend,
        "cells": len(results),
        "planned_replicates": scenario.replicates * len(results),
        "completed_replicates": completed,
        "interrupted": interrupted,
        "elapsed_seconds": round(time.perf_counter() - started, 3),
        **simulation,
    })
    return RunResult(directory, completed, scenario.replicates * len(results), interrupted,
                     {"entries": [], "nevd_bound_by_step": []}, simulation, tuple(results))
