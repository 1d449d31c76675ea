"""Paper Figure 2: accuracy and tightness of the nEVD bound on the 5x5 gridworld (10 worlds), as
shipped: the paper's world variant (world = "paper")."""

import pandas as pd
import pytest

from tests.paper import run

DEMOS = 10


@pytest.fixture(scope="module")
def alpha_runs(tmp_path_factory):
    """Figure 2: the nEVD bound alone, at three quantile levels."""
    return {
        alpha: run(
            tmp_path_factory,
            "gridworld",
            f"sufficiency.alpha={alpha}",
            f"demos.max_demos={DEMOS}",
            "rules.patience=[]",
            "rules.validation_intervals=[]",
            "rules.piob_thresholds=[]",
            "rules.nevd_thresholds=[0.1]",
        )
        for alpha in (0.90, 0.95, 0.99)
    }


@pytest.mark.parametrize("alpha", [0.90, 0.95, 0.99])
def test_figure_2_bounds_are_accurate_and_shrink(alpha_runs, alpha):
    _, steps, summary = alpha_runs[alpha]
    curve = pd.DataFrame(summary["nevd_bound_by_step"])
    nevd = steps[steps["rule"] == "nevd"]
    # Upper bound >= true nEVD in >= 90% of all (world, demo count) pairs, and at every demo
    # count in at least 8 of the 10 worlds.
    assert (nevd["bound"] >= nevd["true_nevd"]).mean() >= 0.9
    assert curve["bound_accuracy"].min() >= 0.8
    # The bound tightens with demos: after 10 demos the typical (median) world's bound is
    # below 0.1, and the mean bound is a small fraction of what it was after one demo.
    last = nevd[nevd["step"] == DEMOS]["bound"]
    assert last.median() < 0.1
    assert curve["mean_bound"].iloc[-1] < 0.25 * curve["mean_bound"].iloc[0]


def test_figure_2_higher_alpha_is_more_conservative(alpha_runs):
    means = [alpha_runs[a][1].query("rule == 'nevd'")["bound"].mean() for a in (0.90, 0.95, 0.99)]
    assert means[0] <= means[1] <= means[2] and means[0] < means[2]
