"""Stopping rules on hand-made evidence (a stand-in domain with integer policies)."""

import math

import numpy as np
import pytest

from mjsuff.domain import Demo
from mjsuff.stopping import (
    Evidence,
    NevdBoundRule,
    PatienceRule,
    PiobBoundRule,
    ValidationSetRule,
)


class IntPolicyDomain:
    """Just enough of a Domain for the rules: policies are ints, a demo matches policy == action."""

    def same_policy(self, a, b):
        return a == b

    def agrees_with_demo(self, policy, demo):
        return policy == demo.action


def evidence(demos, map_policy=0, nevd=math.inf, piob=-math.inf, excluding=None):
    return Evidence(IntPolicyDomain(), demos, map_policy, nevd, piob, excluding or (lambda held: map_policy))


def test_nevd_rule_stops_at_or_below_its_threshold():
    rule = NevdBoundRule(0.2)
    assert rule.decide(evidence([], nevd=0.2)).sufficient
    assert not rule.decide(evidence([], nevd=0.2001)).sufficient
    with pytest.raises(ValueError):
        NevdBoundRule(1.5)


def test_piob_rule_stops_at_or_above_its_threshold():
    rule = PiobBoundRule(0.4)
    assert rule.decide(evidence([], piob=0.4)).sufficient
    assert not rule.decide(evidence([], piob=0.39)).sufficient


def test_patience_counts_consecutive_unchanged_policies():
    rule = PatienceRule(2)
    verdicts = [rule.decide(evidence([], map_policy=p)).sufficient for p in [1, 1, 2, 2, 2, 2]]
    assert verdicts == [False, False, False, False, True, True]
    rule.reset()
    assert not rule.decide(evidence([], map_policy=2)).sufficient


def test_validation_set_holds_out_every_ith_demo_and_learns_without_them():
    rule = ValidationSetRule(3, min_held_out=2)
    demos = [Demo(start=i, action=a) for i, a in enumerate([5, 5, 7, 5, 5, 7])]
    seen = []

    def excluding(held):
        seen.append(held)
        return 7

    assert rule.held_out(6) == frozenset({2, 5})
    assert rule.decide(evidence(demos[:2], excluding=excluding)).sufficient is False  # none held
    assert rule.decide(evidence(demos[:5], excluding=excluding)).sufficient is False  # one held
    assert rule.decide(evidence(demos, excluding=excluding)).sufficient is True
    assert seen[-1] == frozenset({2, 5})
    assert rule.decide(evidence(demos, excluding=lambda held: 5)).sufficient is False


def test_rules_validate_their_parameters():
    with pytest.raises(ValueError):
        PatienceRule(0)
    with pytest.raises(ValueError):
        ValidationSetRule(1)
    with pytest.raises(ValueError):
        PiobBoundRule(-0.1)
    assert np.isnan(PatienceRule(1).decide(evidence([], map_policy=1)).bound)
