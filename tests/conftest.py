"""Shared fixtures: small, seeded scenarios that run in seconds."""

from __future__ import annotations

import signal
from typing import Any

import pytest

from mjsuff.experiment.scenario import Scenario, scenario_from_dict


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
