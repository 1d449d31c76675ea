"""Our rule: stop when the high-confidence α-VaR bound on nEVD is within the threshold (Eq. 6)."""

from __future__ import annotations

from pydantic import validate_call

from mjsuff.stopping.base import Decision, Evidence, StoppingRule


class NevdBoundRule(StoppingRule):
    """Sufficient when the upper bound on the α-VaR of nEVD(π_MAP) is ≤ ``threshold`` and the
    posterior it was computed from converged (``Evidence.converged``)."""

    kind = "nevd"

    @validate_call
    def __init__(self, threshold: float) -> None:
        if not 0.0 < threshold <= 1.0:
            raise ValueError(f"nEVD threshold must be in (0, 1], got {threshold}")
        self.param = threshold

    def decide(self, evidence: Evidence) -> Decision:
        bound = evidence.nevd_bound
        return Decision(evidence.converged and bound <= self.param, bound, evidence.map_policy)
