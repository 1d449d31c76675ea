"""Where replicates run: in this process, in local worker processes, or on a Ray cluster.

A replicate is a pure function of (scenario, replicate index, demo source): its randomness comes
from its own seed streams (``mjsuff.seeds``), so every backend gives the same rows for
the same seeds. A backend takes a list of ``ReplicateTask`` and yields ``(task, ReplicateResult)`` as each one
finishes, in whatever order they finish; the runner writes each to disk at once.

* ``SerialBackend`` — one at a time in this process, with per-step progress.
* ``LocalBackend(workers)`` — a pool of ``workers`` processes (``spawn``), per-step progress through
  a queue. MuJoCo's rollout threads are divided among the workers.
* ``RayBackend(address)`` — one Ray task per replicate, on a running cluster (``address``) or on a
  local Ray instance; needs the ``ray`` extra (``pip install 'mjsuff[ray]'``). ``connect()`` finds
  a cluster that cannot be used (down, wrong address, token refused) before any work starts and
  raises ``ClusterConnectionError`` saying which and what to set.
"""

from __future__ import annotations

import abc
import contextlib
import multiprocessing
import os
import queue
import signal
import socket
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from multiprocessing.managers import SyncManager
from pathlib import Path
from typing import Any

from threadpoolctl import threadpool_limits

from mjsuff.errors import MjsuffError
from mjsuff.experiment.replicate import DemoSource, StepCallback, run_replicate
from mjsuff.experiment.scenario import Scenario

#: Environment variable read by ``mjsuff.scenes.simulate.Simulator`` for its default thread count.
SIM_THREADS_ENV = "MJSUFF_SIM_THREADS"

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
        return ReplicateResult(rows, path.read_bytes())


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


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """Ignore SIGINT in this (main) thread while child processes start, so they inherit it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


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
    # Ctrl-C is the parent's to handle: it keeps what finished and stops the workers.
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
        workers: Number of processes (default: all cores). MuJoCo rollouts in each get
            ``cores // workers`` threads (at least one).
    """

    name = "local"

    def __init__(self, workers: int | None = None) -> None:
        cores = os.cpu_count() or 1
        if workers is not None and workers < 1:
            raise BackendError(f"--workers: expected a positive number, got {workers}")
        self.workers = workers or cores
        self.sim_threads = max(1, cores // self.workers)

    def describe(self) -> str:
        return f"local, {self.workers} worker process(es)"

    def run(
        self, tasks: list[ReplicateTask], on_step: TaskProgress | None = None
    ) -> Iterator[tuple[ReplicateTask, ReplicateResult]]:
        if not tasks:
            return
        workers = min(self.workers, len(tasks))
        context = multiprocessing.get_context("spawn")
        # Children inherit an ignored SIGINT from the moment they start (before their slow
        # imports): Ctrl-C is the parent's to handle.
        manager = None
        if on_step is not None:
            manager = SyncManager(ctx=context)
            with _sigint_ignored():
                manager.start(_manager_init)
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
            workers, mp_context=context, initializer=_worker_init, initargs=(self.sim_threads,)
        )
        try:
            if drainer is not None:
                drainer.start()
            with _sigint_ignored():  # worker processes start on the first submissions
                pending: dict[Future, ReplicateTask] = {
                    pool.submit(_execute_reporting, t, events): t for t in tasks
                }
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for future in sorted(done, key=lambda f: pending[f].key):
                    task = pending.pop(future)
                    yield task, future.result()
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


class RayBackend(Backend):
    """One Ray task per replicate.

    Args:
        address: A running cluster's address (``ray start --head`` prints it), or None for a local
            Ray instance with ``num_cpus`` CPUs (default: all cores).
        num_cpus: CPUs of the local instance (ignored with ``address``).
        cpus_per_task: CPUs each replicate reserves; MuJoCo rollouts use as many threads.
    """

    name = "ray"

    def __init__(
        self, address: str | None = None, num_cpus: int | None = None, cpus_per_task: int = 1
    ) -> None:
        try:
            import ray
        except ImportError:
            raise BackendError("--backend ray: Ray is not installed; pip install 'mjsuff[ray]'") from None
        if cpus_per_task < 1:
            raise BackendError(f"cpus_per_task: expected a positive number, got {cpus_per_task}")
        self.ray = ray
        self.address = address
        self.num_cpus = num_cpus
        self.cpus_per_task = cpus_per_task

    def describe(self) -> str:
        return f"ray ({self.address or 'local instance'})"

    def connect(self) -> None:
        """Connect to the cluster (or start the local instance) unless already connected.

        With an address, a socket connection and one authenticated request to the cluster's GCS
        come first: they fail in a second where ``ray.init`` would retry for minutes (nothing
        listening) or for 20 s while logging every attempt (token refused).

        Raises:
            ClusterConnectionError: the cluster cannot be reached or refused this client.
            BackendError: the address is not one Ray accepts.
        """
        if self.ray.is_initialized():
            return
        options: dict[str, Any] = {
            "include_dashboard": False,
            "log_to_driver": False,
            "configure_logging": False,
        }
        if not self.address:
            self.ray.init(num_cpus=self.num_cpus or os.cpu_count() or 1, **options)
            return
        if self.address not in ("auto", "local"):
            host, port = _host_port(self.address)
            _check_reachable(self.address, host, port)
            if not self.address.startswith("ray://"):
                _check_gcs(self.ray, self.address, f"{host}:{port}")
        try:
            self.ray.init(address=self.address, **options)
        except _auth_error(self.ray) as exc:
            raise ClusterConnectionError(_auth_refused(self.address, exc)) from None
        except ConnectionError as exc:
            hint = (
                ""
                if _auth_mode() == "token"
                else "; if the cluster uses token authentication, set RAY_AUTH_MODE=token here"
            )
            raise ClusterConnectionError(
                f"--address {self.address}: cannot connect to the Ray cluster ({exc}){hint}"
            ) from None

    def run(
        self, tasks: list[ReplicateTask], on_step: TaskProgress | None = None
    ) -> Iterator[tuple[ReplicateTask, ReplicateResult]]:
        if not tasks:
            return
        self.connect()
        remote = self.ray.remote(num_cpus=self.cpus_per_task)(_ray_execute)
        pending = {remote.remote(t, self.cpus_per_task): t for t in tasks}
        try:
            while pending:
                done, _ = self.ray.wait(list(pending), num_returns=1)
                for ref in done:
                    task = pending.pop(ref)
                    yield task, self.ray.get(ref)
        finally:
            for ref in pending:
                self.ray.cancel(ref, force=True)

    def shutdown(self) -> None:
        if self.ray.is_initialized():
            self.ray.shutdown()


#: Where Ray reads the token when neither RAY_AUTH_TOKEN nor RAY_AUTH_TOKEN_PATH is set.
DEFAULT_TOKEN_FILE = "~/.ray/auth_token"
#: The time a cluster's address gets to accept a socket connection.
CONNECT_TIMEOUT = 10.0


def _host_port(address: str) -> tuple[str, int]:
    """``HOST:PORT`` (or ``ray://HOST:PORT``, ``[IPv6]:PORT``) as its host and port."""
    host, _, port = address.removeprefix("ray://").rpartition(":")
    host = host.removeprefix("[").removesuffix("]")
    if not host or not port.isdigit():
        raise BackendError(
            f"--address {address}: expected HOST:PORT, the address `ray start "
            "--head` prints (e.g. 10.0.0.1:6379)"
        )
    return host, int(port)


def _check_reachable(address: str, host: str, port: int) -> None:
    """Something accepts connections at ``host:port`` (``ray.init`` would wait for minutes)."""
    try:
        socket.create_connection((host, port), timeout=CONNECT_TIMEOUT).close()
    except OSError as exc:
        reason = (
            (exc.strerror or str(exc))
            if not isinstance(exc, TimeoutError)
            else f"no answer in {CONNECT_TIMEOUT:g} s"
        )
        raise ClusterConnectionError(
            f"--address {address}: no Ray cluster answers there ({reason}); start one with "
            f"`ray start --head --port={port}` on {host} or pass the address it prints"
        ) from None


def _auth_mode() -> str:
    """``RAY_AUTH_MODE`` as Ray reads it (unset: ``""``)."""
    return os.environ.get("RAY_AUTH_MODE", "").strip().lower()


def _token_source() -> str | None:
    """Where Ray takes this process's token from (its order: ``RAY_AUTH_TOKEN``,
    ``RAY_AUTH_TOKEN_PATH``, ``~/.ray/auth_token``), or None when there is none."""
    if os.environ.get("RAY_AUTH_TOKEN"):
        return "RAY_AUTH_TOKEN"
    custom = os.environ.get("RAY_AUTH_TOKEN_PATH")
    path = Path(custom) if custom else Path(DEFAULT_TOKEN_FILE).expanduser()
    try:
        has_token = bool(path.read_text().strip())
    except (OSError, UnicodeDecodeError):
        has_token = False
    if not has_token:
        return None
    return f"RAY_AUTH_TOKEN_PATH={custom}" if custom else DEFAULT_TOKEN_FILE


def _auth_error(ray: Any) -> type[Exception] | tuple[()]:
    """Ray's ``AuthenticationError`` (Ray 2.52 and later; before, nothing to catch)."""
    return getattr(ray.exceptions, "AuthenticationError", ())


def _auth_refused(address: str, exc: Exception) -> str:
    """The one line for a connection refused for authentication: what to set."""
    detail = str(getattr(exc, "message", exc))  # str() appends a paragraph of help
    where = f"--address {address}"
    source = _token_source()
    give = (
        "give this machine the head node's token (`ray get-auth-token` there prints it) in "
        f"{DEFAULT_TOKEN_FILE}, RAY_AUTH_TOKEN_PATH or RAY_AUTH_TOKEN"
    )
    if _auth_mode() != "token":
        then = (
            f", and Ray sends the token in {source} (it must be the head node's; `ray "
            "get-auth-token` there prints it)"
            if source
            else f" and {give}"
        )
        return f"{where}: the cluster requires token authentication; set RAY_AUTH_MODE=token here{then}"
    if source is None:
        return f"{where}: RAY_AUTH_MODE=token, but no token is set here ({detail}); {give}"
    return f"{where}: the cluster refused the token in {source}; {give}"


@contextlib.contextmanager
def _stderr_silenced() -> Iterator[None]:
    """File descriptor 2 goes to /dev/null: Ray's C++ client logs each refused request there."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _check_gcs(ray: Any, address: str, gcs_address: str) -> None:
    """One request to the cluster's GCS, with this process's token settings: refused for
    authentication, or no GCS answering, is a ``ClusterConnectionError`` in about a second.

    Skipped where the probe cannot help or could harm: Ray's C++ client aborts the process in
    token mode without a token (``ray.init`` reports that itself), and an unknown mode is Ray's.
    """
    mode = _auth_mode()
    if mode not in ("", "disabled", "token") or (mode == "token" and _token_source() is None):
        return
    client_class = getattr(getattr(ray, "_raylet", None), "GcsClient", None)
    if client_class is None:  # the probe is an optimization; ray.init decides
        return
    try:
        with _stderr_silenced():
            client_class(address=gcs_address)
    except _auth_error(ray) as exc:
        raise ClusterConnectionError(_auth_refused(address, exc)) from None
    except getattr(ray.exceptions, "RpcError", ()) as exc:
        raise ClusterConnectionError(
            f"--address {address}: no Ray cluster answers there ({exc}); pass the address "
            "`ray start --head` printed"
        ) from None
    except Exception:  # anything else: ray.init tries and reports
        return


def _ray_execute(task: ReplicateTask, threads: int) -> ReplicateResult:
    os.environ[SIM_THREADS_ENV] = str(threads)
    return execute(task)


def make_backend(name: str, workers: int | None = None, address: str | None = None) -> Backend:
    """``serial``, ``local`` (``workers`` processes; one worker means serial) or ``ray``."""
    if name == "local":
        if workers == 1:
            return SerialBackend()
        return LocalBackend(workers)
    if name == "serial":
        return SerialBackend()
    if name == "ray":
        return RayBackend(address, num_cpus=workers)
    raise BackendError(f"--backend: expected one of local, serial, ray (got {name!r})")
