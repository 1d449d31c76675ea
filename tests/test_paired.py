"""A rule's F1 in two runs compared replicate by replicate (``mjsuff.report.paired``)."""

import math

import numpy as np
import pandas as pd
import pytest

from mjsuff.report.paired import paired_f1


def outcomes(stopped: list[bool], good: list[bool], first: int = 0) -> pd.DataFrame:
    return pd.DataFrame(
        {"replicate": np.arange(first, first + len(stopped)), "stopped": stopped, "good": good}
    )


def test_one_differing_replicate_against_a_perfect_run_does_not_exclude_zero():
    """Stop 65's case: 20 right stops there, one of them a false stop here. The perfect run's own
    bootstrap interval is the point 1.00, which 0.974 lies outside; the paired interval of the
    difference reaches 0 (a resample leaves the replicate out with probability 0.95^20 = 0.36)."""
    there = outcomes([True] * 20, [True] * 20)
    here = outcomes([True] * 20, [False] + [True] * 19)
    c = paired_f1(here, there, np.random.default_rng(0))
    assert c is not None
    assert c.here == pytest.approx(19 / 19.5) and c.there == 1.0
    assert c.difference == pytest.approx(19 / 19.5 - 1)
    assert c.low < 0 and c.high == 0.0
    assert (c.right_here_only, c.right_there_only, c.mcnemar_p, c.replicates) == (0, 1, 1.0, 20)


def test_six_false_stops_more_exclude_zero_and_reject():
    """Six replicates wrong here only: a resample without any of them has probability 0.7^20 =
    0.0008, so the interval lies below 0; McNemar's p is 2 × 0.5^6."""
    there = outcomes([True] * 20, [True] * 20)
    here = outcomes([True] * 20, [False] * 6 + [True] * 14)
    c = paired_f1(here, there, np.random.default_rng(0))
    assert c is not None
    assert c.high < 0
    assert c.mcnemar_p == pytest.approx(2 * 0.5**6)
    assert (c.right_here_only, c.right_there_only) == (0, 6)


def test_only_shared_replicates_count_and_none_shared_gives_none():
    there = outcomes([True] * 4, [True] * 4)
    here = outcomes([True, False, True, True, True, True], [True, True, True, True, False, False])
    c = paired_f1(here, there, np.random.default_rng(0))
    assert c is not None and c.replicates == 4
    assert (c.right_here_only, c.right_there_only) == (0, 1)  # replicate 1: an FN here
    assert paired_f1(outcomes([True], [True], first=10), there, np.random.default_rng(0)) is None


def test_undefined_f1_everywhere_gives_a_nan_interval():
    """Only TNs: no F1 in either run, in any resample."""
    tn = outcomes([False] * 5, [False] * 5)
    c = paired_f1(tn, tn, np.random.default_rng(0))
    assert c is not None
    assert math.isnan(c.here) and math.isnan(c.low) and math.isnan(c.high)
    assert c.mcnemar_p == 1.0
