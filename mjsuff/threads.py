"""The thread budget: how many cores this process may use for MuJoCo rollouts.

``$MJSUFF_SIM_THREADS`` when it is a positive integer, else every core. A parallel backend
shares its process's budget among the replicates it runs at once and sets each worker's
variable to its share (``mjsuff.experiment.backend.shared_threads``); a user may set it to cap
mjsuff. The budget never changes results, only how fast they come.
"""

from __future__ import annotations

import os

#: The environment variable that carries the budget to this process and its children.
SIM_THREADS_ENV = "MJSUFF_SIM_THREADS"


def thread_budget() -> int:
    """Cores this process may use: ``$MJSUFF_SIM_THREADS`` if set to a positive integer, else
    ``os.cpu_count()`` (at least 1)."""
    value = os.environ.get(SIM_THREADS_ENV, "").strip()
    if value.isascii() and value.isdigit() and int(value) > 0:
        return int(value)
    return os.cpu_count() or 1
