"""Our rule for improvement: stop when the PIOB lower bound reaches the threshold (§4.5.1)."""

from __future__ import annotations

from pydantic import validate_call

from mjsuff.stopping.base import Decision, Evidence, StoppingRule


class PiobBoundRule(StoppingRule):
    """Sufficient when the lower bound on the (1−α)-quantile of PIOB(π_MAP) is ≥ ``threshold``
    and the posterior it was computed from converged (``Evidence.converged``)."""

    kind = "piob"
    measures_improvement = True

    @validate_call
    def __init__(self, threshold: float) -> None:
        if threshold <= 0.0:
            raise ValueError(f"PIOB threshold must be > 0, got {threshold}")
        self.param = threshold

    def decide(self, evidence: Evidence) -> Decision:
        bound = evidence.piob_bound
        return Decision(evidence.converged and bound >= self.param, bound, evidence.map_policy)
