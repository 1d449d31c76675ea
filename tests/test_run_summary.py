"""What a run leaves: totals over its finished replicates (``mjsuff/experiment/run_summary.py``)."""

import pandas as pd
import pytest

from mjsuff.experiment.run_summary import truth_totals


def test_truth_totals_count_replicates_starts_and_the_largest_raise():
    # Every row of a replicate carries its end-of-replicate raise; replicate 1 was never raised.
    rows = [
        (0, 2, 0.03),
        (0, 2, 0.03),
        (1, 0, 0.0),
        (1, 0, 0.0),
        (2, 1, 0.01),
        (2, 1, 0.01),
    ]
    steps = pd.DataFrame(rows, columns=["replicate", "truth_raised_starts", "truth_raise"])
    totals = truth_totals(steps)
    assert totals == {"raised_replicates": 2, "raised_starts": 3, "largest_raise": pytest.approx(0.03)}


def test_truth_totals_of_a_run_without_the_columns_or_rows_are_zero():
    zero = {"raised_replicates": 0, "raised_starts": 0, "largest_raise": 0.0}
    assert truth_totals(pd.DataFrame()) == zero
    assert truth_totals(pd.DataFrame({"replicate": [0, 1]})) == zero
