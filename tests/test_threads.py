"""The thread budget (``mjsuff.threads``): the variable when it is a positive integer, else the cores."""

import pytest

from mjsuff.threads import SIM_THREADS_ENV, thread_budget


@pytest.mark.parametrize(
    ("value", "budget"),
    [("3", 3), ("1", 1), (None, 6), ("", 6), ("0", 6), ("-2", 6), ("x", 6), ("²", 6), (" 2 ", 2)],
)
def test_budget_is_the_variable_when_positive_else_the_cores(monkeypatch, value, budget):
    monkeypatch.setattr("mjsuff.threads.os.cpu_count", lambda: 6)
    if value is None:
        monkeypatch.delenv(SIM_THREADS_ENV, raising=False)
    else:
        monkeypatch.setenv(SIM_THREADS_ENV, value)
    assert thread_budget() == budget


def test_budget_is_one_when_the_cores_are_unknown(monkeypatch):
    monkeypatch.setattr("mjsuff.threads.os.cpu_count", lambda: None)
    monkeypatch.delenv(SIM_THREADS_ENV, raising=False)
    assert thread_budget() == 1
