"""What a run leaves when it ends, however it ends: each cell's finished replicates combined into
``steps.parquet``, ``summary.json`` and ``run.json``, its recording parts merged into
``recording.rrd``, and for a sweep the totals over its cells."""

from __future__ import annotations

import json
import platform
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from mjsuff import __version__
from mjsuff.atomic import atomic_write_parquet
from mjsuff.domain import TRUTH_SETTLED
from mjsuff.experiment.measures import sampler_diagnostics, summarize
from mjsuff.experiment.results import read_steps, replicate_path, write_json
from mjsuff.experiment.scenario import Scenario
from mjsuff.experiment.step_row import SIMULATION_COUNTERS

#: A cell's merged Rerun recording, in its output directory.
RECORDING = "recording.rrd"
#: Per-replicate recordings, before they are merged into ``RECORDING``.
RECORDINGS = "recordings"


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
    truth: dict[str, Any] = field(default_factory=dict)


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


def truth_totals(steps: pd.DataFrame) -> dict[str, Any]:
    """Ground truth raised at the end of a replicate (a scene's, to the best of everything the
    replicate simulated under ``w*``, then searched again) over the finished replicates: in how
    many, at how many evaluation starts in all, the largest raise (a share of ``V* − V_rand`` at
    its start), the searches run again in all, and the replicates whose last search still raised
    a start by more than ``TRUTH_SETTLED`` (unsettled). An exact domain's truth is never raised."""
    totals: dict[str, Any] = {"raised_replicates": 0, "raised_starts": 0, "largest_raise": 0.0}
    columns = ["truth_raised_starts", "truth_raise"]
    if steps.empty or not all(c in steps for c in columns):
        return totals | {"searches": 0, "unsettled_replicates": 0}
    last = steps.groupby("replicate")[columns].max()
    totals = {
        "raised_replicates": int((last["truth_raised_starts"] > 0).sum()),
        "raised_starts": int(last["truth_raised_starts"].sum()),
        "largest_raise": float(last["truth_raise"].max()),
    }
    searched = ["truth_passes", "truth_last_gain"]
    if not all(c in steps for c in searched):  # a run from before the searches
        return totals | {"searches": 0, "unsettled_replicates": 0}
    ends = steps.groupby("replicate")[searched].max()
    unsettled = (ends["truth_passes"] > 0) & (ends["truth_last_gain"] > TRUTH_SETTLED)
    searches = int(ends["truth_passes"].sum())
    return totals | {"searches": searches, "unsettled_replicates": int(unsettled.sum())}


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
    replicate's rows were never written). Returns None, or why the merge failed (parts kept).

    A merge killed after the replace but before the parts are dropped merges them again next time;
    ``rerun rrd merge`` keeps one copy of rows it sees twice (same row ids), so nothing is
    duplicated (tested in ``tests/test_resume.py``)."""
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
    truth = truth_totals(steps)
    run = {
        **_run_info(directory, scenario, backend, recorded, started, interrupted),
        "planned_replicates": scenario.replicates,
        "completed_replicates": completed,
        **simulation,
        "sampler": sampler,
        "truth": truth,
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
        truth=truth,
    )


def machine_info() -> dict[str, str]:
    """What a run's floating point depends on beyond the seed: the CPU (model, and on Linux its
    family and model numbers), the BLAS library numpy calls and the kernel it chose for this CPU,
    and MuJoCo's version. Results are bit-identical only where these match (README, after the
    golden records)."""
    from importlib.metadata import PackageNotFoundError, version

    from threadpoolctl import threadpool_info

    fields: dict[str, str] = {}
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if not line.strip():
                    break  # the first processor's block is enough
                key, _, value = line.partition(":")
                fields.setdefault(key.strip(), value.strip())
    except OSError:
        pass  # not Linux
    cpu = fields.get("model name") or platform.processor() or platform.machine()
    if "cpu family" in fields:
        cpu += f" (family {fields['cpu family']}, model {fields.get('model', '?')})"
    blas = [
        f"{i.get('internal_api')} {i.get('version')} ({i.get('architecture')})"
        for i in threadpool_info()
        if i.get("user_api") == "blas"
    ]
    try:
        mujoco = version("mujoco")
    except PackageNotFoundError:
        mujoco = "not installed"
    return {
        "cpu": cpu,
        "blas": "; ".join(blas) or "none found",
        "mujoco": mujoco,
    }


def _run_info(
    directory: Path, scenario: Scenario, backend: str, recorded: bool, started: float, interrupted: bool
) -> dict[str, Any]:
    """The fields every ``run.json`` starts with. The elapsed time covers every invocation of a
    resumed run (the last one's own in ``elapsed_seconds_last``), added to the previous
    ``run.json`` in ``directory``."""
    last = round(time.perf_counter() - started, 3)
    before, invocations = 0.0, 0
    try:
        previous = json.loads((directory / "run.json").read_text())
        before = float(previous.get("elapsed_seconds", 0.0))
        invocations = int(previous.get("invocations", 1))
    except (OSError, ValueError, TypeError, AttributeError):
        pass  # no earlier invocation (or an unreadable record of it)
    return {
        "mjsuff_version": __version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "machine": machine_info(),
        "seed": scenario.seed,
        "backend": backend,
        "recorded": recorded,
        "interrupted": interrupted,
        "elapsed_seconds": round(before + last, 3),
        "elapsed_seconds_last": last,
        "invocations": invocations + 1,
    }


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
    truth = {
        "raised_replicates": sum(c.result.truth.get("raised_replicates", 0) for c in results),
        "raised_starts": sum(c.result.truth.get("raised_starts", 0) for c in results),
        "largest_raise": max((c.result.truth.get("largest_raise", 0.0) for c in results), default=0.0),
        "searches": sum(c.result.truth.get("searches", 0) for c in results),
        "unsettled_replicates": sum(c.result.truth.get("unsettled_replicates", 0) for c in results),
    }
    write_json(
        directory / "run.json",
        {
            **_run_info(directory, scenario, backend, recorded, started, interrupted),
            "cells": len(results),
            "planned_replicates": scenario.replicates * len(results),
            "completed_replicates": completed,
            **simulation,
            "sampler": sampler,
            "truth": truth,
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
        truth,
    )
