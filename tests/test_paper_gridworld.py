"""Paper Figure 4, Tables 2 and 3 on Gridworld (10 seeded worlds, every state once)."""

import pytest

from tests.paper import ACTIVE, check_figure_4, check_table_2, check_table_3, run


@pytest.fixture(scope="module")
def passive(tmp_path_factory):
    return run(tmp_path_factory, "gridworld")[0]


@pytest.fixture(scope="module")
def active(tmp_path_factory):
    return run(tmp_path_factory, "gridworld", *ACTIVE)[0]


def test_figure_4_nevd_rule_is_accurate_and_efficient(passive):
    check_figure_4(passive)


def test_table_2_piob_rule(passive):
    check_table_2(passive)


def test_table_3_active_needs_fewer_states_at_equal_f1(passive, active):
    check_table_3(passive, active)
