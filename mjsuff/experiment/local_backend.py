"""``LocalBackend(workers)``: a pool of ``workers`` local processes (``spawn``), with per-step
progress through a queue. MuJoCo's rollout threads are divided among the processes started (no
more than there are replicates to run)."""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import queue
import signal
import threading
import time
from collections.abc import Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from multiprocessing import resource_tracker
from multiprocessing.managers import SyncManager
from typing import Any

from mjsuff.experiment.backend import (
    Backend,
    BackendError,
    ReplicateResult,
    ReplicateTask,
    TaskProgress,
    execute,
    shared_threads,
)
from mjsuff.experiment.deferred_signals import DeferredSignals
from mjsuff.threads import SIM_THREADS_ENV, thread_budget

_POLL_SECONDS = 0.1  # longest wait on the workers before a Ctrl-C is handled (s)


@contextlib.contextmanager
def _sigint_held() -> Iterator[None]:
    """Block SIGINT in this (main) thread while child processes start: they inherit it blocked,
    so a Ctrl-C cannot end them during their imports (their initializer then ignores it). A
    Ctrl-C meanwhile is the parent's and is not lost: it is handled when the block ends
    (``DeferredSignals``), after the children have started."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    # multiprocessing's resource tracker (the first spawned child starts it) is started before
    # the block: starting it unblocks SIGINT in this thread.
    resource_tracker.ensure_running()
    with DeferredSignals():
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            yield
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _exit_with_parent(poll: float = 1.0) -> None:
    """Exit this helper process within ``poll`` seconds of its parent's death.

    A parent killed without clean-up (SIGKILL, or a crash) cannot terminate its workers; without
    this they would go on simulating, orphaned, until their replicate ends.
    """
    parent = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(poll)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def _worker_init(threads: int) -> None:
    # Ctrl-C is the parent's to handle: it keeps what finished and stops the workers. (A Ctrl-C
    # held pending since the process started is dropped here.)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ[SIM_THREADS_ENV] = str(threads)
    _exit_with_parent()


def _manager_init() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _exit_with_parent()


def _execute_reporting(task: ReplicateTask, events: Any) -> ReplicateResult:
    def report(step: int, max_demos: int) -> None:
        events.put((task.key, step, max_demos))

    return execute(task, report if events is not None else None)


class LocalBackend(Backend):
    """A pool of local worker processes.

    Args:
        workers: Most processes (default: one per core of the thread budget); a run starts
            no more than it has replicates. The budget (``mjsuff.threads``: every core, or
            ``$MJSUFF_SIM_THREADS``) is shared among the processes started: MuJoCo rollouts in
            each get ``budget // processes started`` threads (at least one), so a single
            replicate gets all of it.
    """

    name = "local"

    def __init__(self, workers: int | None = None) -> None:
        cores = thread_budget()
        if workers is not None and workers < 1:
            raise BackendError(f"--workers: expected a positive number, got {workers}")
        self.cores = cores
        self.workers = workers or cores

    def describe(self) -> str:
        return f"local, {self.workers} worker process(es)"

    def run(
        self, tasks: list[ReplicateTask], on_step: TaskProgress | None = None
    ) -> Iterator[tuple[ReplicateTask, ReplicateResult]]:
        if not tasks:
            return
        workers = min(self.workers, len(tasks))
        context = multiprocessing.get_context("spawn")
        # Children inherit a blocked SIGINT from the moment they start (before their slow
        # imports): Ctrl-C is the parent's to handle.
        manager = None
        if on_step is not None:
            manager = SyncManager(ctx=context)
            try:
                with _sigint_held():
                    manager.start(_manager_init)
            except KeyboardInterrupt:  # held while it started: it has, and is not left running
                manager.shutdown()
                raise
        events = manager.Queue() if manager is not None else None
        by_key = {t.key: t for t in tasks}
        stop = threading.Event()

        def drain() -> None:
            if events is None or on_step is None:
                return
            while not stop.is_set():
                try:
                    key, step, max_demos = events.get(timeout=0.1)
                except (queue.Empty, EOFError, OSError):
                    continue
                on_step(by_key[key], step, max_demos)

        drainer = threading.Thread(target=drain, daemon=True) if events is not None else None
        pool = ProcessPoolExecutor(
            workers,
            mp_context=context,
            initializer=_worker_init,
            initargs=(shared_threads(self.cores, workers),),
        )
        try:
            if drainer is not None:
                drainer.start()
            with _sigint_held():  # worker processes start on the first submissions
                pending: dict[Future, ReplicateTask] = {
                    pool.submit(_execute_reporting, t, events): t for t in tasks
                }
            while pending:
                # A Ctrl-C inside wait() could leave futures' locks held, and the pool's shutdown
                # would then hang: it is handled when the (bounded) wait ends.
                with DeferredSignals():
                    done, _ = wait(pending, timeout=_POLL_SECONDS, return_when=FIRST_COMPLETED)
                for future in sorted(done, key=lambda f: pending[f].key):
                    yield pending.pop(future), future.result()
        except BaseException:
            # Interrupted or failed: unfinished replicates are abandoned, not waited for.
            for process in list(getattr(pool, "_processes", {}).values()):
                process.terminate()
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
            stop.set()
            if drainer is not None:
                drainer.join()
            if manager is not None:
                manager.shutdown()
