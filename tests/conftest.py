"""Shared fixtures: small, seeded scenarios that run in seconds."""

from __future__ import annotations

import os
import signal
from typing import Any

import pytest

from mjsuff.experiment.scenario import Scenario, scenario_from_dict
from mjsuff.threads import SIM_THREADS_ENV, thread_budget


def pytest_configure(config: pytest.Config) -> None:
    """Under xdist, each worker's thread budget (``mjsuff.threads``) is its share of the run's
    budget (the cores, or a ``$MJSUFF_SIM_THREADS`` set before the run), so the workers' MuJoCo
    rollouts do not oversubscribe them (results do not depend on it). Two workers each running
    two rollout threads on two cores took ~11% longer on the lander's truth searches than one
    thread each (stop 62)."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0") or 0)
    if workers > 1:
        os.environ[SIM_THREADS_ENV] = str(max(1, thread_budget() // workers))


def small_scenario(**overrides: Any) -> Scenario:
    """A gridworld scenario small enough for unit tests (2 replicates, 4 demos, 100 samples)."""
    data: dict[str, Any] = {
        "name": "small",
        "seed": 3,
        "replicates": 2,
        "domain": {"name": "gridworld"},
        "demos": {"max_demos": 4},
        "posterior": {"num_samples": 100, "chains": 10, "burn_in": 30},
        "rules": {
            "nevd_thresholds": [0.2, 0.5],
            "piob_thresholds": [0.4],
            "patience": [1],
            "validation_intervals": [2],
        },
    }
    for key, value in overrides.items():
        node = data
        *path, last = key.split(".")
        for part in path:
            node = node.setdefault(part, {})
        node[last] = value
    return scenario_from_dict(data, "<test>")


@pytest.fixture
def small() -> Scenario:
    return small_scenario()


@pytest.fixture
def usual_signal_handlers():
    """Python's own SIGINT handler (a test run started in the background has SIGINT ignored) and
    SIGTERM's default action (earlier tests in this process may have set a handler)."""
    previous = {
        signal.SIGINT: signal.signal(signal.SIGINT, signal.default_int_handler),
        signal.SIGTERM: signal.signal(signal.SIGTERM, signal.SIG_DFL),
    }
    yield
    for signum, handler in previous.items():
        signal.signal(signum, handler)
