"""What every backend shares: a replicate as a task, its result, the Backend interface, and the
serial backend that runs tasks in this process.

A replicate is a pure function of (scenario, replicate index, demo source): its randomness comes
from its own seed streams (``mjsuff.seeds``), so every backend gives the same rows for the same
seeds. A backend takes a list of ``ReplicateTask`` and yields ``(task, ReplicateResult)`` as each
one finishes, in whatever order they finish; the runner writes each to disk at once.
"""

from __future__ import annotations

import abc
import errno
import tempfile
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from threadpoolctl import threadpool_limits

from mjsuff.errors import MjsuffError
from mjsuff.experiment.replicate import DemoSource, StepCallback, run_replicate
from mjsuff.experiment.scenario import Scenario


def shared_threads(cores: int, replicates: int) -> int:
    """Rollout threads of each of ``replicates`` ≥ 1 replicates running at once on ``cores``
    cores: the cores shared among no more replicates than there are cores, at least one each
    (a single replicate gets them all; the thread count never changes results).

    Raises:
        ValueError: ``cores`` or ``replicates`` is under 1.
    """
    if cores < 1 or replicates < 1:
        raise ValueError(f"shared_threads: cores and replicates must be ≥ 1 (got {cores}, {replicates})")
    return max(1, cores // min(cores, replicates))


TaskProgress = Callable[["ReplicateTask", int, int], None]
"""Called as ``(task, step, max_demos)`` after each demonstration step of a task."""


class BackendError(MjsuffError, RuntimeError):
    """A backend cannot be used (e.g. Ray is not installed); the message is one line for the user."""


class ClusterConnectionError(BackendError):
    """The Ray cluster at ``--address`` cannot be used from here: nothing answers there, or it
    refused the connection (token authentication); the message is one line saying what to do."""

    exit_code = 69  # EX_UNAVAILABLE


@dataclass(frozen=True)
class ReplicateTask:
    """One replicate of one scenario (a sweep cell).

    Attributes:
        key: The task's identity in the run (``(cell, replicate)``), echoed back.
        scenario: The fully resolved scenario of the cell.
        replicate: Replicate index (selects the seed streams).
        demo_source: Saved demos replacing the live expert, or None.
        record: Whether to make the replicate's Rerun recording.
    """

    key: tuple[int, int]
    scenario: Scenario
    replicate: int
    demo_source: DemoSource | None = None
    record: bool = False


@dataclass(frozen=True)
class ReplicateResult:
    """What a finished task sends back: its rows and its recording (``.rrd`` bytes) if any.

    The recording is streamed to a local temporary file while the replicate runs (memory does
    not grow with it) and read back once at the end, so workers need no shared filesystem.
    """

    rows: list[dict[str, Any]]
    recording: bytes | None = None


def execute(task: ReplicateTask, on_step: StepCallback | None = None) -> ReplicateResult:
    """Run one task in this process (BLAS limited to one thread: the matrices are small)."""
    if not task.record:
        with threadpool_limits(limits=1):
            return ReplicateResult(run_replicate(task.scenario, task.replicate, on_step, task.demo_source))
    from mjsuff.recording.recorder import RunRecorder  # Rerun only when recording

    with tempfile.TemporaryDirectory(prefix="mjsuff-rec-") as tmp:
        path = Path(tmp) / f"replicate-{task.replicate:05d}.rrd"
        recorder = RunRecorder(path, task.scenario, default_layout=task.replicate == 0)
        try:
            with threadpool_limits(limits=1):
                rows = run_replicate(
                    task.scenario,
                    task.replicate,
                    on_step,
                    task.demo_source,
                    recorder.replicate(task.replicate),
                )
        finally:
            recorder.close()
        last = max((int(row["step"]) for row in rows), default=0)
        _check_recorded(path, task.replicate, last)
        return ReplicateResult(rows, path.read_bytes())


def _check_recorded(path: Path, replicate: int, last_step: int) -> None:
    """The replicate's recording part reaches its last demo step, through to what is logged last
    (the rules' ``true_value`` series, written when the replicate ends). Rerun writes in the
    background and only logs a failure (a full disk where the worker records): a part cut short
    would be merged and the replicate's steps lost from ``recording.rrd`` for good.

    Raises:
        OSError: The part cannot be read, or stops before ``last_step``.
    """
    from mjsuff.recording.reader import Recording

    try:
        with warnings.catch_warnings():  # the reader warns as well as raising
            warnings.simplefilter("ignore")
            chunks = Recording(path).chunks
    except Exception as exc:  # the reader raises several types for a damaged file
        message = f"the recording of replicate {replicate} cannot be read back ({exc})"
        raise OSError(errno.EIO, message, str(path)) from None
    root = f"/r{replicate}/"
    steps = [
        step
        for c in chunks
        if c.entity_path.startswith(root)
        and c.entity_path.endswith("/true_value")
        and "demo" in c.timeline_names
        for step in c.to_record_batch().column("demo").to_pylist()
    ]
    if max(steps, default=0) < last_step:
        raise OSError(
            errno.EIO,
            f"Rerun could not write the recording of replicate {replicate} (it stops before demo step "
            f"{last_step}; is the disk of the temporary directory full?)",
            str(path),
        )


class Backend(abc.ABC):
    """Runs replicate tasks; ``run`` yields each ``(task, rows)`` as soon as it finishes."""

    name: str = "backend"

    @abc.abstractmethod
    def run(
        self, tasks: list[ReplicateTask], on_step: TaskProgress | None = None
    ) -> Iterator[tuple[ReplicateTask, ReplicateResult]]:
        """Run ``tasks``; on an exception or when the consumer stops, unstarted tasks are cancelled."""

    def describe(self) -> str:
        """A short description for run.json and the summary line."""
        return self.name

    def connect(self) -> None:
        """Make sure the backend can run tasks, before anything is written (here: nothing to do)."""
        return


class SerialBackend(Backend):
    """Every task in this process, one after another."""

    name = "serial"

    def run(
        self, tasks: list[ReplicateTask], on_step: TaskProgress | None = None
    ) -> Iterator[tuple[ReplicateTask, ReplicateResult]]:
        for task in tasks:
            callback = None if on_step is None else (lambda s, m, t=task: on_step(t, s, m))
            yield task, execute(task, callback)
