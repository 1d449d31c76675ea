"""Held-out validation baseline (§4.2): every i-th demo is held out; stop when π_MAP matches them.

The robot learns only from the demos it does not hold out, so its π_MAP comes from a posterior
without them; it stops when that policy agrees with every held-out demo
(``Domain.agrees_with_demo``) and at least ``min_held_out`` demos are held out (3 by default, as
in the paper's published code: one matching demo is weak evidence).
"""

from __future__ import annotations

import math

from pydantic import validate_call

from mjsuff.stopping.base import Decision, Evidence, StoppingRule


class ValidationSetRule(StoppingRule):
    """Hold out demos ``i−1, 2i−1, …`` (0-based); sufficient when π_MAP matches all of them."""

    kind = "validation"

    @validate_call
    def __init__(self, interval: int, min_held_out: int = 3) -> None:
        if interval < 2:
            raise ValueError(f"validation interval must be >= 2, got {interval}")
        if min_held_out < 1:
            raise ValueError(f"min_held_out must be >= 1, got {min_held_out}")
        self.param = interval
        self.interval = interval
        self.min_held_out = min_held_out

    def held_out(self, num_demos: int) -> frozenset[int]:
        """Indices of the held-out demos among the first ``num_demos``."""
        return frozenset(range(self.interval - 1, num_demos, self.interval))

    def decide(self, evidence: Evidence) -> Decision:
        held = self.held_out(len(evidence.demos))
        policy = evidence.map_policy_excluding(held)
        ok = len(held) >= self.min_held_out and all(
            evidence.domain.agrees_with_demo(policy, evidence.demos[j]) for j in sorted(held)
        )
        return Decision(ok, math.nan, policy)
