"""Where replicates run: in this process, in local worker processes, or on a Ray cluster.

* ``SerialBackend`` (``mjsuff.experiment.backend``) — one at a time in this process, with
  per-step progress.
* ``LocalBackend`` (``mjsuff.experiment.local_backend``) — a pool of local worker processes.
* ``RayBackend`` (``mjsuff.experiment.ray_backend``) — one Ray task per replicate.

``make_backend`` picks one by the name ``mjsuff run --backend`` takes.
"""

from __future__ import annotations

from mjsuff.experiment.backend import (
    Backend,
    BackendError,
    ClusterConnectionError,
    ReplicateResult,
    ReplicateTask,
    SerialBackend,
    execute,
)
from mjsuff.experiment.local_backend import LocalBackend
from mjsuff.experiment.ray_backend import RayBackend

__all__ = [
    "Backend",
    "BackendError",
    "ClusterConnectionError",
    "LocalBackend",
    "RayBackend",
    "ReplicateResult",
    "ReplicateTask",
    "SerialBackend",
    "execute",
    "make_backend",
]


def make_backend(
    name: str, workers: int | None = None, address: str | None = None, cpus_per_task: int | None = None
) -> Backend:
    """``serial``, ``local`` (``workers`` processes; one worker means serial) or ``ray`` (each
    replicate reserving ``cpus_per_task`` CPUs, as many rollout threads; ``None``: the default)."""
    if cpus_per_task is not None and name != "ray":
        raise BackendError(f"--cpus-per-task: only with --backend ray (got --backend {name})")
    if name == "local":
        if workers == 1:
            return SerialBackend()
        return LocalBackend(workers)
    if name == "serial":
        return SerialBackend()
    if name == "ray":
        return RayBackend(address, num_cpus=workers, cpus_per_task=cpus_per_task)
    raise BackendError(f"--backend: expected one of local, serial, ray (got {name!r})")
