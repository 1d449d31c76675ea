"""Convergence baseline (§4.2): stop when π_MAP has not changed over ``p`` demonstrations."""

from __future__ import annotations

import math

from pydantic import validate_call

from mjsuff.domain import Policy
from mjsuff.stopping.base import Decision, Evidence, StoppingRule


class PatienceRule(StoppingRule):
    """Sufficient once π_MAP stayed the same (``Domain.same_policy``) for ``p`` new demos."""

    kind = "patience"

    @validate_call
    def __init__(self, patience: int) -> None:
        if patience < 1:
            raise ValueError(f"patience must be >= 1, got {patience}")
        self.param = patience
        self.reset()

    def reset(self) -> None:
        self._previous: Policy | None = None
        self._unchanged = 0

    def decide(self, evidence: Evidence) -> Decision:
        policy = evidence.map_policy
        if self._previous is not None and evidence.domain.same_policy(policy, self._previous):
            self._unchanged += 1
        else:
            self._unchanged = 0
        self._previous = policy
        return Decision(self._unchanged >= self.param, math.nan, policy)
