"""What a run leaves: totals over its finished replicates (``mjsuff/experiment/run_summary.py``)."""

import pandas as pd
import pytest

from mjsuff.cli.run import truth_line
from mjsuff.experiment.run_summary import machine_info, truth_totals

NONE_SEARCHED = {"searches": 0, "unsettled_replicates": 0}


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
    totals = truth_totals(steps)  # a run from before the searches again: none counted
    raised = {"raised_replicates": 2, "raised_starts": 3, "largest_raise": pytest.approx(0.03)}
    assert totals == raised | NONE_SEARCHED


def test_truth_totals_count_the_searches_again_and_the_unsettled_replicates():
    # Replicate 0 settled after 2 searches; 1 still rose at its 3rd and last; 2 was never searched
    # (a gain without searches cannot be unsettled).
    rows = [(0, 1, 0.02, 2, 0.0004), (1, 3, 0.05, 3, 0.004), (2, 0, 0.0, 0, 0.5)]
    columns = ["replicate", "truth_raised_starts", "truth_raise", "truth_passes", "truth_last_gain"]
    totals = truth_totals(pd.DataFrame(rows, columns=columns))
    assert totals["searches"] == 5 and totals["unsettled_replicates"] == 1
    line = truth_line(totals, 3)
    assert "raised at the end of 2 of 3 replicates (4 evaluation starts" in line
    assert line.endswith("searched again 5 times, still rising at the last search in 1 of 3 replicates")
    settled = truth_line(totals | {"unsettled_replicates": 0}, 3)
    assert settled.endswith("settled in every replicate")


def test_truth_totals_of_a_run_without_the_columns_or_rows_are_zero():
    zero = {"raised_replicates": 0, "raised_starts": 0, "largest_raise": 0.0} | NONE_SEARCHED
    assert truth_totals(pd.DataFrame()) == zero
    assert truth_totals(pd.DataFrame({"replicate": [0, 1]})) == zero
    assert truth_line(zero, 2).startswith("Ground truth: never raised")


def test_machine_info_names_the_cpu_the_blas_kernels_and_mujoco():
    info = machine_info()
    assert set(info) == {"cpu", "blas", "mujoco"} and all(isinstance(v, str) and v for v in info.values())
    assert "(" in info["blas"]  # each library with the kernel it chose
    assert info["mujoco"][0].isdigit()
