"""Measures on a hand-made steps table whose answers are known."""

import math

import pandas as pd
import pytest

from mjsuff.experiment.measures import measure_group, summarize


def rows(replicate, decisions, nevds, bounds, pool_size=10, rule="nevd", param=0.2):
    return [{"replicate": replicate, "rule": rule, "param": param, "step": i + 1,
             "decision": d, "true_nevd": n, "true_piob": 0.0, "true_value": n, "bound": b,
             "policy_optimality": 1.0 - n, "pool_size": pool_size}
            for i, (d, n, b) in enumerate(zip(decisions, nevds, bounds, strict=True))]


def test_stop_decisions_give_the_confusion_counts_and_f1():
    frame = pd.DataFrame(
        rows(0, [False, True, True], [0.5, 0.1, 0.0], [0.9, 0.15, 0.05])     # TP at step 2
        + rows(1, [True, True, True], [0.4, 0.3, 0.0], [0.1, 0.1, 0.1])      # FP at step 1
        + rows(2, [False, False, False], [0.5, 0.3, 0.1], [0.9, 0.8, 0.7])   # FN (final 0.1)
        + rows(3, [False, False, False], [0.5, 0.4, 0.3], [0.9, 0.8, 0.7]))  # TN
    m = measure_group(frame, improvement=False, threshold=0.2)
    assert (m["tp"], m["fp"], m["fn"], m["tn"]) == (1, 1, 1, 1)
    assert m["f1"] == pytest.approx(1 / (1 + 0.5 * 2))
    assert m["demos_needed"] == pytest.approx((2 + 1 + 3 + 3) / 4)
    assert m["fraction_of_states"] == pytest.approx(m["demos_needed"] / 10)
    # Bound accuracy at the evaluated step: 0.15>=0.1 yes, 0.1>=0.4 no, 0.7>=0.1 yes, 0.7>=0.3 yes
    assert m["accuracy"] == pytest.approx(0.75)
    assert m["bound_error"] == pytest.approx(((0.15 - 0.1) + (0.1 - 0.4) + 0.6 + 0.4) / 4)
    assert m["stopped_fraction"] == 0.5


def test_baselines_are_scored_at_every_nevd_threshold():
    frame = pd.DataFrame(rows(0, [True, True], [0.3, 0.0], [math.nan] * 2,
                              rule="patience", param=1.0)
                         + rows(0, [False, True], [0.3, 0.0], [0.5, 0.1]))
    summary = summarize(frame, nevd_thresholds=[0.1, 0.5])
    patience = [e for e in summary["entries"] if e["rule"] == "patience"]
    assert [e["epsilon"] for e in patience] == [0.1, 0.5]
    assert [e["f1"] for e in patience] == [0.0, 1.0]
    assert math.isnan(patience[0]["accuracy"])
    assert summary["nevd_bound_by_step"][0]["bound_accuracy"] == 1.0
