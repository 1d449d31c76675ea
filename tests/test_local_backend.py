"""LocalBackend's Ctrl-C: taken mid-run (the worker stopped), and while its processes start
(held until they have, never lost, never a child's traceback)."""

import multiprocessing
import os
import signal
import subprocess
import sys
import threading
from concurrent.futures import Future, ProcessPoolExecutor
from pathlib import Path

import pytest

from mjsuff.experiment.backend import ReplicateResult, ReplicateTask
from mjsuff.experiment.local_backend import LocalBackend, _sigint_held
from mjsuff.threads import SIM_THREADS_ENV
from tests.conftest import small_scenario

pytestmark = pytest.mark.usefixtures("usual_signal_handlers")

ROOT = Path(__file__).resolve().parents[1]


def test_local_backend_stops_on_a_ctrl_c_while_it_waits_on_its_worker():
    scenario = small_scenario(replicates=6)
    tasks = [ReplicateTask((0, r), scenario, r) for r in range(6)]
    # Half a second in, the backend is waiting on its worker (starting it alone takes longer).
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            for _ in LocalBackend(1).run(tasks):
                pass
    finally:
        timer.cancel()
    assert multiprocessing.active_children() == []  # the worker was stopped and joined
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def _sigint_blocked() -> bool:
    return signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, [])


def test_a_ctrl_c_while_children_start_is_held_until_they_have():
    reached = []
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        with pytest.raises(KeyboardInterrupt):
            with _sigint_held():
                future = pool.submit(_sigint_blocked)  # the worker process starts here
                signal.raise_signal(signal.SIGINT)  # held: nothing raised yet, and not lost
                reached.append(True)
        # The child started with SIGINT blocked: a Ctrl-C cannot end it during its imports.
        assert future.result(timeout=120) is True
    assert reached == [True]
    assert not _sigint_blocked()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


#: A fresh process (no multiprocessing helper running yet) sends a Ctrl-C to its own process
#: group 50 ms after its first child process is launched, while that child imports.
INTERRUPTED_WHILE_STARTING = """
import multiprocessing, os, signal, sys, threading
from concurrent.futures import ProcessPoolExecutor
from multiprocessing.managers import SyncManager

from mjsuff.experiment.backend import ReplicateTask
from mjsuff.experiment.local_backend import LocalBackend
from tests.conftest import small_scenario

def ctrl_c_soon_after(launch):
    sent = []

    def patched(self, *args, **kwargs):
        if not sent:
            sent.append(threading.Timer(0.05, os.killpg, (0, signal.SIGINT)))
            sent[0].start()
        return launch(self, *args, **kwargs)

    return patched

if __name__ == "__main__":
    with_progress = sys.argv[1] == "progress"
    if with_progress:  # the progress queue's manager process starts first
        SyncManager.start = ctrl_c_soon_after(SyncManager.start)
    else:
        ProcessPoolExecutor.submit = ctrl_c_soon_after(ProcessPoolExecutor.submit)
    tasks = [ReplicateTask((0, r), small_scenario(replicates=2), r) for r in range(2)]
    try:
        for _ in LocalBackend(2).run(tasks, (lambda *a: None) if with_progress else None):
            pass
        print("finished")
    except KeyboardInterrupt:
        print("interrupted; children left:", len(multiprocessing.active_children()))
"""


@pytest.mark.parametrize("progress", ["progress", "quiet"])
def test_a_ctrl_c_while_the_processes_start_ends_the_run_cleanly(tmp_path, progress):
    script = tmp_path / "interrupted_while_starting.py"
    script.write_text(INTERRUPTED_WHILE_STARTING)
    proc = subprocess.run(
        [sys.executable, str(script), progress],
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        timeout=300,
        start_new_session=True,  # the Ctrl-C goes to this process group alone
        # SIGINT back to its default: a test run started in the background inherits it ignored.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    # Not lost (the run would finish), and no child killed mid-import (its traceback, and the
    # parent's EOFError waiting for it).
    assert proc.stdout.strip() == "interrupted; children left: 0", proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr


#: How each _RecordingPool was made: (processes, the workers' initializer arguments).
_POOLS_MADE: list[tuple[int, tuple]] = []


class _RecordingPool:
    """Stands in for the process pool: records how it was made and runs each task's result."""

    def __init__(self, workers, mp_context, initializer, initargs):
        _POOLS_MADE.append((workers, initargs))

    def submit(self, fn, task, events):
        future = Future()
        future.set_result(ReplicateResult([{"replicate": task.replicate}]))
        return future

    def shutdown(self, wait, cancel_futures):
        pass


@pytest.mark.parametrize(
    ("cores", "budget", "workers", "replicates", "started", "threads"),
    [
        (2, None, None, 1, 1, 2),  # one replicate gets both cores (it got one before stop 61)
        (2, None, None, 3, 2, 1),
        (8, None, 2, 1, 1, 8),
        (8, None, None, 3, 3, 2),
        (8, None, 3, 5, 3, 2),
        (1, None, 4, 4, 4, 1),
        # A budget set in the environment (a user's cap, a test worker's share) is what is shared.
        (2, "1", None, 1, 1, 1),
        (8, "4", None, 8, 4, 1),
        (8, "4", 2, 3, 2, 2),
    ],
)
def test_rollout_threads_share_the_budget_among_the_processes_started(
    monkeypatch, cores, budget, workers, replicates, started, threads
):
    monkeypatch.setattr("mjsuff.threads.os.cpu_count", lambda: cores)
    if budget is None:
        monkeypatch.delenv(SIM_THREADS_ENV, raising=False)
    else:
        monkeypatch.setenv(SIM_THREADS_ENV, budget)
    monkeypatch.setattr("mjsuff.experiment.local_backend.ProcessPoolExecutor", _RecordingPool)
    _POOLS_MADE.clear()
    scenario = small_scenario(replicates=replicates)
    tasks = [ReplicateTask((0, r), scenario, r) for r in range(replicates)]
    done = [task.replicate for task, _ in LocalBackend(workers).run(tasks)]
    assert sorted(done) == list(range(replicates))
    assert _POOLS_MADE == [(started, (threads,))]
