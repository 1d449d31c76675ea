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
import time
from collections.abc import Callable, Mapping
from pathlib import Path

from mjsuff.atomic import atomic_write_bytes, atomic_write_text
from mjsuff.errors import MjsuffError
from mjsuff.experiment.backend import Backend, ReplicateResult, ReplicateTask, SerialBackend
from mjsuff.experiment.replicate import DemoSource
from mjsuff.experiment.results import (
    OutputError,
    prepare_output,
    replicate_path,
    write_json,
    write_replicate,
)
from mjsuff.experiment.run_summary import (
    RECORDING,
    RECORDINGS,
    CellResult,
    RunResult,
    finalize,
    finalize_sweep,
)
from mjsuff.experiment.scenario import Scenario, ScenarioError, SweepCell, flat_keys, stored_settings

ProgressCallback = Callable[[int, int, float], None]
"""Called as ``(finished replicates, planned replicates, work done in replicates)``."""


def check_resumable(directory: Path, scenario: Scenario, record: bool) -> None:
    """A run directory can be resumed with ``scenario``: the same scenario apart from
    ``replicates`` (which may grow, not shrink), recorded as before. A key the run's
    ``config.toml`` lacks (added since) counts as its default, the behaviour the run had."""
    import tomllib

    config = directory / "config.toml"
    if not config.is_file():
        raise OutputError(f"{directory}: --resume: no config.toml here, so no run to resume")
    try:
        stored = tomllib.loads(config.read_text())
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise OutputError(f"{config}: --resume: cannot read the run's scenario ({exc})") from None
    try:
        old = stored_settings(stored, str(config))  # a key added since the run: its default
    except ScenarioError as exc:
        raise OutputError(
            f"{directory}: --resume: the run's scenario no longer validates ({exc}); it was made by "
            "another version of mjsuff: start a new run"
        ) from None
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
    for replicates in directory.glob("**/replicates"):
        was_recorded = _was_recorded(replicates.parent)
        if was_recorded is not None and was_recorded != record:
            flag = "without --no-record" if was_recorded else "with --no-record"
            raise OutputError(
                f"{directory}: --resume: the run was started {flag}; resume it "
                "the same way, so its recording covers every replicate"
            )


def _was_recorded(cell_dir: Path) -> bool | None:
    """Whether the run in ``cell_dir`` records: its ``run.json`` says so, or, for a run stopped
    before it wrote one (killed), its recording or parts directory exists (a recorded run makes
    the parts directory before its first replicate). None: no replicate finished there."""
    try:
        return bool(json.loads((cell_dir / "run.json").read_text()).get("recorded", True))
    except (OSError, json.JSONDecodeError):
        pass
    if not any((cell_dir / "replicates").glob("replicate-*.parquet")):
        return None
    return (cell_dir / RECORDINGS).is_dir() or (cell_dir / RECORDING).exists()


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
    except MjsuffError:
        raise
    except OSError as exc:  # a full disk, a directory made read-only, ...
        raise RunWriteError.of(exc, directory, finished) from exc
    finally:
        # Ctrl-C, or anything failing mid-run (e.g. a saved demo set without the demo asked
        # for): the finished replicates are summarized before the error goes up. When the
        # summary cannot be written either, the error already going up is the one to report.
        try:
            total = _summarize(directory, scenario, cells, started, interrupted, backend.describe(), record)
        except OSError as exc:
            if not interrupted:
                raise RunWriteError.of(exc, directory, finished) from exc
    return total


class RunWriteError(MjsuffError, OSError):
    """Results could not be written mid-run (disk full, permissions); the finished replicates are
    on disk and ``--resume`` continues once the fault is fixed."""

    exit_code = 74  # sysexits.h's EX_IOERR (mjsuff.cli.console.EXIT_WRITE)

    @classmethod
    def of(cls, exc: OSError, directory: Path, finished: int) -> RunWriteError:
        where = exc.filename or directory
        return cls(
            f"{where}: cannot write ({exc.strerror or exc}); {finished} finished replicate(s) are kept "
            f"in {directory}: fix that, then run the same command with --resume (--out {directory})"
        )


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
