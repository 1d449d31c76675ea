"""Run every replicate of a scenario (every cell of its sweep) into a run directory.

See ``mjsuff.experiment.results`` for the layout. Replicates run on a ``Backend`` (in this process,
local worker processes or Ray) and each is written to disk the moment it finishes, so a killed run
loses only the replicates that were running; ``resume=True`` continues it without redoing or
duplicating any finished replicate.

Recordings: each replicate's recording comes back from the backend with its rows and is written,
before them, to ``recordings/replicate-NNNNN.rrd`` of its cell; when the run ends, however it ends,
those parts are merged into the cell's ``recording.rrd`` (``rerun rrd merge``), the one file to
open.
"""

from __future__ import annotations

import json
import platform
import subprocess
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from mjsuff import __version__
from mjsuff.atomic import atomic_write_bytes, atomic_write_parquet, atomic_write_text
from mjsuff.experiment.backend import Backend, ReplicateResult, ReplicateTask, SerialBackend
from mjsuff.experiment.measures import sampler_diagnostics, summarize
from mjsuff.experiment.replicate import DemoSource
from mjsuff.experiment.results import (
    OutputError,
    prepare_output,
    read_steps,
    replicate_path,
    write_json,
    write_replicate,
)
from mjsuff.experiment.scenario import Scenario, SweepCell, flat_keys
from mjsuff.experiment.step_row import SIMULATION_COUNTERS

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
    recording_error: str | None = None
    sampler: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class CellResult:
    """One sweep cell's labels (``{dotted key: value}``) and its run."""

    labels: dict[str, Any]
    result: RunResult


def simulation_totals(steps: pd.DataFrame) -> dict[str, int]:
    """MuJoCo steps simulated and diverged rollouts over the finished replicates (the step
    columns are running counts per replicate; exact domains have none)."""
    columns = SIMULATION_COUNTERS
    if steps.empty or not all(c in steps for c in columns):
        return {c: 0 for c in columns}
    last = steps.groupby("replicate")[list(columns)].max()
    return {c: int(last[c].sum()) for c in columns}


def sampler_totals(steps: pd.DataFrame) -> dict[str, Any]:
    """The posteriors of the finished replicates (one per replicate and step): how many, how many
    hit the sampler's step cap before R̂ and ESS met their targets (``converged`` False; their
    bounds lack the stated confidence and the bound rules did not stop on them), and their worst
    R̂ and smallest ESS."""
    if steps.empty or "converged" not in steps:
        return {"posteriors": 0, "unconverged_posteriors": 0}
    per_step = steps.drop_duplicates(["replicate", "step"])
    d = sampler_diagnostics(per_step)
    return {
        "posteriors": len(per_step),
        "unconverged_posteriors": int((~per_step["converged"].astype(bool)).sum()),
        **{k: d[k] for k in ("max_rhat", "min_ess", "mean_mcmc_steps")},
    }


def merge_recordings(directory: Path) -> str | None:
    """Merge ``recording.rrd`` and the parts ``recordings/replicate-*.rrd`` of finished replicates
    into ``recording.rrd`` (atomically), then drop the merged parts and any orphans (a part whose
    replicate's rows were never written). Returns None, or why the merge failed (parts kept)."""
    parts_dir = directory / RECORDINGS
    if not parts_dir.is_dir():
        return None
    parts = []
    for part in sorted(parts_dir.glob("replicate-*.rrd")):
        replicate = int(part.stem.removeprefix("replicate-"))
        if replicate_path(directory, replicate).exists():
            parts.append(part)
        else:
            part.unlink()
    for stale in parts_dir.glob(".*.tmp"):
        stale.unlink(missing_ok=True)
    target = directory / RECORDING
    if not parts:
        return None
    if not target.exists() and len(parts) == 1:
        parts[0].replace(target)
        return None
    inputs = ([target] if target.exists() else []) + parts
    tmp = directory / f".{RECORDING}.tmp"
    try:
        done = subprocess.run(
            [sys.executable, "-m", "rerun", "rrd", "merge", *map(str, inputs), "-o", str(tmp)],
            capture_output=True,
            text=True,
        )
    except OSError as exc:
        return f"rerun rrd merge could not start ({exc})"
    if done.returncode != 0 or not tmp.exists():
        tmp.unlink(missing_ok=True)
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        return f"rerun rrd merge failed ({last}); the parts are kept in {parts_dir}"
    tmp.replace(target)
    for part in parts:
        part.unlink()
    return None


def _drop_empty(directory: Path) -> None:
    if directory.is_dir() and not any(directory.iterdir()):
        directory.rmdir()


def finalize(
    directory: Path,
    scenario: Scenario,
    started: float,
    interrupted: bool,
    backend: str = "serial",
    recorded: bool = True,
) -> RunResult:
    """Combine a cell's finished replicates into ``steps.parquet``, ``summary.json`` and
    ``run.json``, then merge its recordings (a failed merge is reported in ``run.json`` and
    ``RunResult.recording_error``, never at the cost of the results)."""
    steps = read_steps(directory)
    completed = int(steps["replicate"].nunique()) if not steps.empty else 0
    summary = (
        summarize(steps, scenario.rules.nevd_thresholds)
        if completed
        else {"entries": [], "nevd_bound_by_step": []}
    )
    if completed:
        atomic_write_parquet(directory / "steps.parquet", steps)
    write_json(directory / "summary.json", {"scenario": scenario.name, **summary})
    simulation = simulation_totals(steps)
    sampler = sampler_totals(steps)
    run = {
        **_run_info(scenario, backend, recorded, started, interrupted),
        "planned_replicates": scenario.replicates,
        "completed_replicates": completed,
        **simulation,
        "sampler": sampler,
    }
    write_json(directory / "run.json", run)
    error = merge_recordings(directory)
    _drop_empty(directory / RECORDINGS)
    if error is not None:
        write_json(directory / "run.json", {**run, "recording_error": error})
    return RunResult(
        directory,
        completed,
        scenario.replicates,
        interrupted,
        summary,
        simulation,
        recording_error=error,
        sampler=sampler,
    )


def _run_info(
    scenario: Scenario, backend: str, recorded: bool, started: float, interrupted: bool
) -> dict[str, Any]:
    """The fields every ``run.json`` starts with."""
    return {
        "mjsuff_version": __version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "seed": scenario.seed,
        "backend": backend,
        "recorded": recorded,
        "interrupted": interrupted,
        "elapsed_seconds": round(time.perf_counter() - started, 3),
    }


def check_resumable(directory: Path, scenario: Scenario, record: bool) -> None:
    """A run directory can be resumed with ``scenario``: the same scenario apart from
    ``replicates`` (which may grow, not shrink), recorded as before."""
    import tomllib

    config = directory / "config.toml"
    if not config.is_file():
        raise OutputError(f"{directory}: --resume: no config.toml here, so no run to resume")
    try:
        old = flat_keys(tomllib.loads(config.read_text()))
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise OutputError(f"{config}: --resume: cannot read the run's scenario ({exc})") from None
    new = flat_keys(tomllib.loads(scenario.to_toml()))
    for key in sorted(set(old) | set(new)):
        if key != "replicates" and old.get(key) != new.get(key):
            raise OutputError(
                f"{directory}: --resume: the scenario differs from the run's "
                f"config.toml at {key} ({old.get(key)!r} there, {new.get(key)!r} "
                "now); resume with the same scenario and overrides"
            )
    done = [
        int(p.stem.removeprefix("replicate-")) for p in directory.glob("**/replicates/replicate-*.parquet")
    ]
    if done and max(done) >= scenario.replicates:
        raise OutputError(
            f"{directory}: --resume: the run already has replicate {max(done)}; "
            f"--replicates can grow, not shrink (got {scenario.replicates})"
        )
    for run_json in directory.glob("**/run.json"):
        try:
            was_recorded = json.loads(run_json.read_text()).get("recorded", True)
        except (OSError, json.JSONDecodeError):
            continue
        if was_recorded != record:
            flag = "without --no-record" if was_recorded else "with --no-record"
            raise OutputError(
                f"{directory}: --resume: the run was started {flag}; resume it "
                "the same way, so its recording covers every replicate"
            )


def _cell_directory(directory: Path, cell: SweepCell, sweep: bool) -> Path:
    return directory / "cells" / cell.dirname if sweep else directory


def _check_demo_sources(
    directory: Path, sweep: bool, resume: bool, demo_sources: Mapping[int, DemoSource] | None
) -> None:
    """Saved demos serve one run from its start: not a sweep, not a resumed run."""
    if sweep and demo_sources:
        raise OutputError(f"{directory}: saved demos (--demos) cannot be used with a sweep")
    if resume and demo_sources:
        raise OutputError(
            f"{directory}: --resume cannot be combined with --demos (nothing "
            "records which demo files the first part of the run used)"
        )


def _plan_tasks(
    directory: Path,
    scenario: Scenario,
    cells: list[SweepCell],
    record: bool,
    demo_sources: Mapping[int, DemoSource] | None,
) -> tuple[list[ReplicateTask], int]:
    """Make every cell's directories and list the replicates still to run, with how many are
    finished already (a resumed run keeps those)."""
    sweep = bool(scenario.sweep)
    tasks: list[ReplicateTask] = []
    finished = 0
    for cell in cells:
        cell_dir = _cell_directory(directory, cell, sweep)
        (cell_dir / "replicates").mkdir(parents=True, exist_ok=True)
        if sweep:
            atomic_write_text(cell_dir / "config.toml", cell.scenario.to_toml())
        if record:
            (cell_dir / RECORDINGS).mkdir(exist_ok=True)
        for replicate in range(scenario.replicates):
            if replicate_path(cell_dir, replicate).exists():
                finished += 1
                continue
            source = (demo_sources or {}).get(replicate)
            tasks.append(ReplicateTask((cell.index, replicate), cell.scenario, replicate, source, record))
    return tasks, finished


def _write_sweep_json(directory: Path, scenario: Scenario, cells: list[SweepCell]) -> None:
    """``sweep.json``: the swept keys, and each cell's labels and directory."""
    write_json(
        directory / "sweep.json",
        {
            "keys": list(scenario.sweep),
            "cells": [
                {
                    "index": c.index,
                    "labels": c.labels,
                    "directory": str(_cell_directory(directory, c, True).relative_to(directory)),
                }
                for c in cells
            ],
        },
    )


def run_scenario(
    scenario: Scenario,
    directory: Path,
    overwrite: bool = False,
    progress: ProgressCallback | None = None,
    demo_sources: Mapping[int, DemoSource] | None = None,
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
    _check_demo_sources(directory, sweep, resume, demo_sources)
    if resume:
        check_resumable(directory, scenario, record)
    prepare_output(directory, overwrite, resume)
    atomic_write_text(directory / "config.toml", scenario.to_toml())
    tasks, finished = _plan_tasks(directory, scenario, cells, record, demo_sources)
    if sweep:
        _write_sweep_json(directory, scenario, cells)

    planned = len(cells) * scenario.replicates
    started = time.perf_counter()
    fractions: dict[tuple[int, int], float] = {}
    done_keys: set[tuple[int, int]] = set()

    def report() -> None:
        if progress is not None:
            progress(finished, planned, finished + sum(fractions.values()))

    def on_step(task: ReplicateTask, step: int, max_demos: int) -> None:
        if task.key not in done_keys:  # a late event from a worker must not count twice
            fractions[task.key] = step / max_demos
            report()

    report()
    interrupted = True
    try:
        for task, result in backend.run(tasks, on_step if progress is not None else None):
            _save_replicate(_cell_directory(directory, cells[task.key[0]], sweep), task, result)
            done_keys.add(task.key)
            fractions.pop(task.key, None)
            finished += 1
            report()
        interrupted = False
    finally:
        # Ctrl-C, or anything failing mid-run (e.g. a saved demo set without the demo asked
        # for): the finished replicates are summarized before the error goes up.
        total = _summarize(directory, scenario, cells, started, interrupted, backend.describe(), record)
    return total


def _save_replicate(cell_dir: Path, task: ReplicateTask, result: ReplicateResult) -> None:
    """A finished replicate's recording part, then its rows. In that order, a replicate whose rows
    are on disk always has its part (a kill in between leaves a part without rows, which the merge
    drops and a resume writes again when it redoes the replicate)."""
    if result.recording is not None:
        atomic_write_bytes(cell_dir / RECORDINGS / f"replicate-{task.replicate:05d}.rrd", result.recording)
    write_replicate(cell_dir, task.replicate, result.rows)


def _summarize(
    directory: Path,
    scenario: Scenario,
    cells: list[SweepCell],
    started: float,
    interrupted: bool,
    backend: str,
    record: bool,
) -> RunResult:
    """Summaries of the finished replicates: per cell, and for a sweep over the cells."""
    sweep = bool(scenario.sweep)
    results = [
        CellResult(
            c.labels,
            finalize(_cell_directory(directory, c, sweep), c.scenario, started, interrupted, backend, record),
        )
        for c in cells
    ]
    if not sweep:
        return results[0].result
    return finalize_sweep(directory, scenario, results, started, interrupted, backend, record)


def finalize_sweep(
    directory: Path,
    scenario: Scenario,
    results: list[CellResult],
    started: float,
    interrupted: bool,
    backend: str,
    recorded: bool = True,
) -> RunResult:
    """The top level of a sweep: every cell's steps in one ``steps.parquet`` (with a ``cell``
    column and one column per sweep key), ``summary.json`` with each cell's summary, ``run.json``."""
    frames = []
    for index, cell in enumerate(results):
        steps = read_steps(cell.result.directory)
        if steps.empty:
            continue
        steps.insert(0, "cell", index)
        for key, value in cell.labels.items():  # lists and tables as their JSON text
            steps.insert(1, key, value if isinstance(value, str | int | float | bool) else json.dumps(value))
        frames.append(steps)
    if frames:
        atomic_write_parquet(directory / "steps.parquet", pd.concat(frames, ignore_index=True))
    write_json(
        directory / "summary.json",
        {"scenario": scenario.name, "cells": [{"labels": c.labels, **c.result.summary} for c in results]},
    )
    completed = sum(c.result.completed for c in results)
    simulation = {k: sum(c.result.simulation[k] for c in results) for k in SIMULATION_COUNTERS}
    sampler = {
        k: sum(c.result.sampler.get(k, 0) for c in results) for k in ("posteriors", "unconverged_posteriors")
    }
    write_json(
        directory / "run.json",
        {
            **_run_info(scenario, backend, recorded, started, interrupted),
            "cells": len(results),
            "planned_replicates": scenario.replicates * len(results),
            "completed_replicates": completed,
            **simulation,
            "sampler": sampler,
        },
    )
    errors = [c.result.recording_error for c in results if c.result.recording_error]
    return RunResult(
        directory,
        completed,
        scenario.replicates * len(results),
        interrupted,
        {"entries": [], "nevd_bound_by_step": []},
        simulation,
        tuple(results),
        errors[0] if errors else None,
        sampler,
    )
