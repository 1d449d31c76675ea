"""Helpers for the paper-reproduction tests: seeded runs of the shipped scenarios on 10 worlds.

The runs use the paper's settings (beta = 10, N = 500 posterior samples, alpha = 0.95,
delta = 0.05, passive demos from a shuffled state order). Tolerances are for 10 worlds: one
world is 0.1 of any rate. The README shows the same measures on 20 worlds.

The shipped scenarios use the paper's own worlds (gridworld ``world = "paper"``, driving
``weight_ranges = "safe"``) and its non-pessimal PIOB baseline; ``paper_world_tests`` check them,
with the assertions that hold there (see their docstrings). The package's other variants (the
goal gridworld, the default driving weights, a random baseline) are checked per instance in
``tests/test_paper_variants.py``; their full runs are in the README (``benchmarks/paper_tables.py``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mjsuff.experiment.runner import run_scenario
from mjsuff.experiment.scenario import load_scenario

ROOT = Path(__file__).parent.parent
WORLDS = 10
THRESHOLDS = [0.1, 0.2, 0.3, 0.4, 0.5]


def run(tmp_path_factory, scenario: str, *sets: str) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """Run a shipped scenario on ``WORLDS`` worlds with overrides ``sets``."""
    s = load_scenario(ROOT / "scenarios" / f"{scenario}.toml", [f"replicates={WORLDS}", *sets])
    result = run_scenario(s, tmp_path_factory.mktemp(scenario) / "run")
    entries = pd.DataFrame(result.summary["entries"])
    steps = pd.read_parquet(result.directory / "steps.parquet")
    return entries, steps, result.summary


def rule(entries: pd.DataFrame, name: str) -> pd.DataFrame:
    return entries[entries["rule"] == name]


def check_figure_4(entries: pd.DataFrame) -> None:
    """nEVD rule: F1 >= 0.9 at every threshold; fewer demos than the validation-set baseline;
    the patience baseline no more accurate."""
    nevd = rule(entries, "nevd")
    assert list(nevd["param"]) == THRESHOLDS
    assert (nevd["f1"] >= 0.9).all(), nevd[["param", "f1"]]
    validation = rule(entries, "validation")
    assert nevd["demos_needed"].mean() < validation["demos_needed"].mean()
    assert rule(entries, "patience")["f1"].mean() <= nevd["f1"].mean()


ACTIVE = ("demos.selection=active", "rules.patience=[]", "rules.validation_intervals=[]")


def check_table_2_paper_world(entries: pd.DataFrame) -> None:
    """PIOB rule against the paper's non-pessimal baseline.

    * F1 as the paper's code computes it (every demo step a decision, FN read as 1) is at least
      0.95 at 20/40/60%, the lowest of its published 1.00 / 0.97 / 0.95.
    * Precision: at most one world of 10 stops with its true PIOB below the threshold (FP <= 1).
      Recall is not asserted: against a good baseline the truth can exceed 60% by a margin the
      bound does not certify within the demo pool (FN), and |V_base| near 0 makes PIOB large and
      its bound loose.
    * A stricter threshold never stops earlier: the first step with bound >= 0.6 is not before
      the first with bound >= 0.4 (a property of one bound against nested thresholds).
    """
    piob = rule(entries, "piob")
    assert list(piob["param"]) == [0.2, 0.4, 0.6]
    assert (piob["paper_f1_notebook"] >= 0.95).all(), piob[["param", "paper_f1_notebook"]]
    assert (piob["fp"] <= 1).all(), piob[["param", "tp", "fp", "fn", "tn"]]
    assert np.all(np.diff(piob["demos_needed"].to_numpy()) >= 0)


def check_table_3_paper_world(passive: pd.DataFrame, active: pd.DataFrame) -> None:
    """Active selection (Eq. 13) needs a smaller share of states for the nEVD rule, F1 within 0.1.

    Only the nEVD rule: Eq. 13 asks for the state with the largest per-state EVD bound, which is
    what the nEVD bound measures; against the non-pessimal baseline the PIOB rule's share did not
    fall on the gridworld (README).
    """
    p, a = rule(passive, "nevd"), rule(active, "nevd")
    assert a["fraction_of_states"].mean() < p["fraction_of_states"].mean()
    assert a["f1"].mean() >= p["f1"].mean() - 0.1


def paper_world_tests(domain: str) -> tuple:
    """Module-scoped fixtures and tests of Figure 4 and Tables 2-3 for ``domain`` as shipped (the
    paper's world variant and non-pessimal baseline). A test module binds them to module-level
    names (pytest collects the ``test_`` ones), so each domain's runs stay in one module (and one
    xdist worker)."""

    @pytest.fixture(scope="module")
    def passive(tmp_path_factory):
        return run(tmp_path_factory, domain)[0]

    @pytest.fixture(scope="module")
    def active(tmp_path_factory):
        return run(tmp_path_factory, domain, *ACTIVE)[0]

    def test_paper_world_figure_4_nevd_rule_is_accurate_and_efficient(passive):
        check_figure_4(passive)

    def test_paper_world_table_2_piob_rule_as_the_papers_code_scores_it(passive):
        check_table_2_paper_world(passive)

    def test_paper_world_table_3_active_nevd_needs_fewer_states_at_equal_f1(passive, active):
        check_table_3_paper_world(passive, active)

    return (
        passive,
        active,
        test_paper_world_figure_4_nevd_rule_is_accurate_and_efficient,
        test_paper_world_table_2_piob_rule_as_the_papers_code_scores_it,
        test_paper_world_table_3_active_nevd_needs_fewer_states_at_equal_f1,
    )
