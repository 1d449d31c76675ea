"""Shared fixtures: small, seeded scenarios that run in seconds."""

from __future__ import annotations

import signal
from typing import Any

import pytest

from mjsuff.experiment.scenario import Scenario, scenario_from_dict

#: The test modules that take longest (one worker's seconds in stop 62's `--durations=0` run on
#: the Intel: 437, 257, 188, 152, 102, 83), run first. xdist (``--dist loadfile
#: --no-loadscope-reorder``) hands out whole files in collection order, two to each worker to
#: start with and the rest to whichever is free: longest first, the shorter ones fill in and
#: the two workers finish together (before, the longest came late and one worker ran on alone
#: for ~110 s at the end). Refresh the list from the ``--durations`` table the suite prints.
LONGEST_FIRST = (
    "test_scene_domain.py",
    "test_scene_runs.py",
    "test_golden.py",
    "test_planner.py",
    "test_paper_gridworld_paper_world.py",
    "test_paper_driving_paper_world.py",
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The modules of ``LONGEST_FIRST`` first, in its order; the rest as collected (a stable
    sort: each module's tests stay together and in order)."""
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


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
