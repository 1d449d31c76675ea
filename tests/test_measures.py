"""Measures on a hand-made steps table whose answers are known."""

import math

import pandas as pd
import pytest

from mjsuff.experiment.measures import f1_score, measure_group, replicate_outcomes, summarize


def rows(replicate, decisions, nevds, bounds, pool_size=10, rule="nevd", param=0.2):
    return [
        {
            "replicate": replicate,
            "rule": rule,
            "param": param,
            "step": i + 1,
            "decision": d,
            "true_nevd": n,
            "true_piob": 0.0,
            "true_value": n,
            "bound": b,
            "policy_optimality": 1.0 - n,
            "pool_size": pool_size,
        }
        for i, (d, n, b) in enumerate(zip(decisions, nevds, bounds, strict=True))
    ]


def test_stop_decisions_give_the_confusion_counts_and_f1():
    frame = pd.DataFrame(
        rows(0, [False, True, True], [0.5, 0.1, 0.0], [0.9, 0.15, 0.05])  # TP at step 2
        + rows(1, [True, True, True], [0.4, 0.3, 0.0], [0.1, 0.1, 0.1])  # FP at step 1
        + rows(2, [False, False, False], [0.5, 0.3, 0.1], [0.9, 0.8, 0.7])  # FN (final 0.1)
        + rows(3, [False, False, False], [0.5, 0.4, 0.3], [0.9, 0.8, 0.7])
    )  # TN
    m = measure_group(frame, improvement=False, threshold=0.2)
    assert (m["tp"], m["fp"], m["fn"], m["tn"]) == (1, 1, 1, 1)
    assert m["f1"] == pytest.approx(1 / (1 + 0.5 * 2))
    assert m["demos_needed"] == pytest.approx((2 + 1 + 3 + 3) / 4)
    assert m["fraction_of_states"] == pytest.approx(m["demos_needed"] / 10)
    # Bound accuracy at the evaluated step: 0.15>=0.1 yes, 0.1>=0.4 no, 0.7>=0.1 yes, 0.7>=0.3 yes
    assert m["accuracy"] == pytest.approx(0.75)
    assert m["bound_error"] == pytest.approx(((0.15 - 0.1) + (0.1 - 0.4) + 0.6 + 0.4) / 4)
    assert m["stopped_fraction"] == 0.5


def test_replicate_outcomes_are_the_rows_f1_counts():
    """One row per replicate with its stop and whether it was truly sufficient: the TP, FP, FN and
    TN of the test above, and ``f1_score`` of them is ``measure_group``'s F1 (``mjsuff.report.paired``
    is built on these)."""
    frame = pd.DataFrame(
        rows(0, [False, True, True], [0.5, 0.1, 0.0], [0.9, 0.15, 0.05])
        + rows(1, [True, True, True], [0.4, 0.3, 0.0], [0.1, 0.1, 0.1])
        + rows(2, [False, False, False], [0.5, 0.3, 0.1], [0.9, 0.8, 0.7])
        + rows(3, [False, False, False], [0.5, 0.4, 0.3], [0.9, 0.8, 0.7])
    )
    out = replicate_outcomes(frame.sample(frac=1.0, random_state=1), improvement=False, threshold=0.2)
    assert out["replicate"].tolist() == [0, 1, 2, 3]
    assert out["step"].tolist() == [2, 1, 3, 3]
    assert out["stopped"].tolist() == [True, True, False, False]
    assert out["good"].tolist() == [True, False, True, False]  # TP, FP, FN, TN
    stopped, good = out["stopped"].to_numpy(), out["good"].to_numpy()
    assert f1_score(stopped, good) == measure_group(frame, False, 0.2)["f1"] == pytest.approx(0.5)
    assert f1_score(stopped[[0]], good[[0]]) == 1.0
    assert math.isnan(f1_score(stopped[[3]], good[[3]]))  # a lone TN has no F1
    # Improvement truth: true PIOB ≥ the threshold (0.0 in every row here).
    assert replicate_outcomes(frame, improvement=True, threshold=0.0)["good"].all()
    assert not replicate_outcomes(frame, improvement=True, threshold=0.1)["good"].any()


def test_baselines_are_scored_at_every_nevd_threshold():
    frame = pd.DataFrame(
        rows(0, [True, True], [0.3, 0.0], [math.nan] * 2, rule="patience", param=1.0)
        + rows(0, [False, True], [0.3, 0.0], [0.5, 0.1])
    )
    summary = summarize(frame, nevd_thresholds=[0.1, 0.5])
    patience = [e for e in summary["entries"] if e["rule"] == "patience"]
    assert [e["epsilon"] for e in patience] == [0.1, 0.5]
    assert [e["f1"] for e in patience] == [0.0, 1.0]
    assert math.isnan(patience[0]["accuracy"])
    assert summary["nevd_bound_by_step"][0]["bound_accuracy"] == 1.0


def paper_frame():
    """Every step a decision (eps = 0.2): TP 2, FP 2, FN 4, TN 1; sufficient at steps 2, 3
    (pool 10) and 1, 2 (pool 4)."""
    return pd.DataFrame(
        rows(0, [False, True, True], [0.5, 0.1, 0.0], [0.9, 0.1, 0.1])  # TN TP TP
        + rows(1, [True, True, False], [0.4, 0.3, 0.1], [0.1, 0.1, 0.9], pool_size=4)  # FP FP FN
        + rows(2, [False, False, False], [0.1, 0.1, 0.1], [0.9, 0.9, 0.9])
    )  # FN FN FN


def test_paper_measures_count_every_step_and_read_fn_as_one():
    m = measure_group(paper_frame(), improvement=False, threshold=0.2)
    assert (m["paper_tp"], m["paper_fp"], m["paper_fn"], m["paper_tn"]) == (2, 2, 4, 1)
    assert m["paper_f1_notebook"] == pytest.approx(2 / (2 + 0.5 * (2 + 1)))
    assert m["paper_f1_per_step"] == pytest.approx(2 / (2 + 0.5 * (2 + 4)))
    # Every sufficient step, not the first stop: steps 2, 3, 1, 2; shares 0.2, 0.3, 0.25, 0.5.
    assert m["paper_demos"] == pytest.approx(2.0)
    assert m["paper_pct_states"] == pytest.approx((0.2 + 0.3 + 0.25 + 0.5) / 4)
    # Ours, one decision per replicate: TP (stop at 2), FP (stop at 1), FN (never, final 0.1).
    assert (m["tp"], m["fp"], m["fn"], m["tn"]) == (1, 1, 1, 0)
    assert m["f1"] == pytest.approx(0.5) and m["demos_needed"] == pytest.approx(2.0)


def test_paper_measures_of_a_rule_never_sufficient():
    frame = pd.DataFrame(rows(0, [False, False], [0.1, 0.0], [0.9, 0.9]))
    m = measure_group(frame, improvement=False, threshold=0.2)
    assert m["paper_f1_notebook"] == 0.0 and m["paper_f1_per_step"] == 0.0
    assert math.isnan(m["paper_demos"]) and math.isnan(m["paper_pct_states"])


def test_paper_measures_of_the_piob_rule_use_improvement_truth():
    frame = pd.DataFrame(rows(0, [True, True, False], [0.0] * 3, [0.5] * 3, rule="piob", param=0.4))
    frame["true_piob"] = [0.2, 0.6, 0.6]  # FP, TP, FN
    m = measure_group(frame, improvement=True, threshold=0.4)
    assert (m["paper_tp"], m["paper_fp"], m["paper_fn"], m["paper_tn"]) == (1, 1, 1, 0)
    assert m["paper_f1_notebook"] == pytest.approx(1 / (1 + 0.5 * 2))
    assert m["paper_demos"] == pytest.approx(1.5)


def test_summary_entries_carry_the_paper_measures_for_baselines_at_every_threshold():
    frame = pd.DataFrame(
        rows(0, [False, True, True], [0.3, 0.15, 0.0], [math.nan] * 3, rule="patience", param=1.0)
    )
    entries = summarize(frame, nevd_thresholds=[0.1, 0.2])["entries"]
    assert [e["epsilon"] for e in entries] == [0.1, 0.2]
    # eps 0.1: steps 2 (0.15, FP) and 3 (TP); eps 0.2: both TP.
    assert [(e["paper_tp"], e["paper_fp"]) for e in entries] == [(1, 1), (2, 0)]
    assert all(e["paper_demos"] == pytest.approx(2.5) for e in entries)
