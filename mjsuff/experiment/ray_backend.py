"""``RayBackend(address)``: one Ray task per replicate, on a running cluster (``address``) or on a
local Ray instance; needs the ``ray`` extra (``pip install 'mjsuff[ray]'``). ``connect()`` finds a
cluster that cannot be used (down, wrong address, token refused) before any work starts and raises
``ClusterConnectionError`` saying which and what to set."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mjsuff.experiment.backend import (
    Backend,
    BackendError,
    ClusterConnectionError,
    ReplicateResult,
    ReplicateTask,
    TaskProgress,
    execute,
    shared_threads,
)
from mjsuff.threads import SIM_THREADS_ENV, thread_budget


class RayBackend(Backend):
    """One Ray task per replicate.

    Args:
        address: A running cluster's address (``ray start --head`` prints it), or None for a local
            Ray instance with ``num_cpus`` CPUs (default: the thread budget, ``mjsuff.threads``).
        num_cpus: CPUs of the local instance (ignored with ``address``).
        cpus_per_task: CPUs each replicate reserves; MuJoCo rollouts use as many threads.
            None: on a local instance (no address, or ``local``) the CPUs it has shared among
            the replicates (at least one each: a single replicate gets them all); one on a
            cluster.
    """

    name = "ray"

    def __init__(
        self, address: str | None = None, num_cpus: int | None = None, cpus_per_task: int | None = None
    ) -> None:
        try:
            import ray
        except ImportError:
            raise BackendError("--backend ray: Ray is not installed; pip install 'mjsuff[ray]'") from None
        if cpus_per_task is not None and cpus_per_task < 1:
            raise BackendError(f"--cpus-per-task: expected a positive number, got {cpus_per_task}")
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
            BackendError: the address is not one Ray accepts, or a replicate would reserve more
                CPUs (``cpus_per_task``) than the local instance has.
        """
        started = self.ray.is_initialized()
        if not started and not self.address:  # the instance this starts: its CPUs are known
            self._check_cpus_per_task(self.num_cpus or thread_budget())
        if not started:
            self._init()
        if self._local and self.cpus_per_task is not None:
            self._check_cpus_per_task(int(self.ray.cluster_resources().get("CPU", 1)))

    @property
    def _local(self) -> bool:
        """A local instance (no address, or ``local``: one on this machine), not a cluster."""
        return self.address in (None, "", "local")

    def _check_cpus_per_task(self, have: int) -> None:
        """``BackendError`` when a replicate would reserve more CPUs than the local instance's
        ``have`` (it would never be scheduled)."""
        if self.cpus_per_task is not None and self.cpus_per_task > have:
            workers = " (--workers sets them)" if self.num_cpus is not None and not self.address else ""
            raise BackendError(
                f"--cpus-per-task: the local Ray instance has {have} CPUs{workers}, so a replicate "
                f"reserving {self.cpus_per_task} would wait for ever (expected at most {have})"
            )

    def _init(self) -> None:
        options: dict[str, Any] = {
            "include_dashboard": False,
            "log_to_driver": False,
            "configure_logging": False,
        }
        if not self.address:
            with _sigterm_handler_kept():
                self.ray.init(num_cpus=self.num_cpus or thread_budget(), **options)
            return
        if self.address not in ("auto", "local"):
            host, port = _host_port(self.address)
            _check_reachable(self.address, host, port)
            if not self.address.startswith("ray://"):
                _check_gcs(self.ray, self.address, f"{host}:{port}")
        try:
            with _sigterm_handler_kept():
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
        cpus = self.task_cpus(len(tasks))
        remote = self.ray.remote(num_cpus=cpus)(_ray_execute)
        pending = {remote.remote(t, cpus): t for t in tasks}
        try:
            while pending:
                done, _ = self.ray.wait(list(pending), num_returns=1)
                for ref in done:
                    task = pending.pop(ref)
                    yield task, self.ray.get(ref)
        finally:
            for ref in pending:
                self.ray.cancel(ref, force=True)

    def task_cpus(self, tasks: int) -> int:
        """CPUs (and rollout threads) each of ``tasks`` ≥ 1 replicates reserves
        (``cpus_per_task``), once connected: a local instance's are the CPUs it has, which
        may be one the caller started (a task asking for more would wait for ever)."""
        if self.cpus_per_task is not None:
            return self.cpus_per_task
        if not self._local:
            return 1
        return shared_threads(max(1, int(self.ray.cluster_resources().get("CPU", 1))), tasks)

    def shutdown(self) -> None:
        if self.ray.is_initialized():
            self.ray.shutdown()


#: Where Ray reads the token when neither RAY_AUTH_TOKEN nor RAY_AUTH_TOKEN_PATH is set.
DEFAULT_TOKEN_FILE = "~/.ray/auth_token"
#: The time a cluster's address gets to accept a socket connection.
CONNECT_TIMEOUT = 10.0


@contextlib.contextmanager
def _sigterm_handler_kept() -> Iterator[None]:
    """Put back the caller's SIGTERM handler after the block: ``ray.init`` installs its own (to
    exit while it connects) and leaves it, where the caller's (e.g. ``mjsuff run``'s clean
    interrupt) is the one that should act afterwards."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.getsignal(signal.SIGTERM)
    try:
        yield
    finally:
        if previous is not None:  # None: set outside Python, cannot be put back
            signal.signal(signal.SIGTERM, previous)


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
