"""What a stopping rule sees after each demonstration, and what it answers."""

from __future__ import annotations

import abc
from collections.abc import Callable
from dataclasses import dataclass

from mjsuff.domain import Demo, Domain, Policy


@dataclass(frozen=True)
class Evidence:
    """The robot's state of knowledge after ``len(demos)`` demonstrations.

    Attributes:
        domain: The task (rules may only use the learner's side of it).
        demos: All demonstrations so far, in order.
        map_policy: π_MAP of the posterior given all demos.
        nevd_bound: Upper (1−δ) bound on the α-VaR of nEVD(π_MAP) over the posterior.
        piob_bound: Lower (1−δ) bound on the (1−α)-quantile of PIOB(π_MAP).
        map_policy_excluding: π_MAP of the posterior given all demos but those at these indices.
        converged: The sampler met its R̂ and ESS targets; when False the bounds do not have
            their stated confidence, and the bound rules do not stop on them.
    """

    domain: Domain
    demos: list[Demo]
    map_policy: Policy
    nevd_bound: float
    piob_bound: float
    map_policy_excluding: Callable[[frozenset[int]], Policy]
    converged: bool = True


@dataclass(frozen=True)
class Decision:
    """A rule's verdict: stop or not, the bound it used (NaN if none), the policy it would deploy."""

    sufficient: bool
    bound: float
    policy: Policy


class StoppingRule(abc.ABC):
    """Decides after each demonstration whether the robot has seen enough.

    Attributes:
        kind: Rule family (``nevd``, ``piob``, ``patience``, ``validation``).
        param: The family's hyperparameter (threshold, patience or held-out interval).
        measures_improvement: True when ground truth is PIOB (sufficient when ≥ threshold), False
            when it is nEVD (sufficient when ≤ threshold).
    """

    kind: str
    param: float
    measures_improvement: bool = False

    def reset(self) -> None:  # noqa: B027 - stateless rules need no reset
        """Forget everything; called before each replicate."""

    @abc.abstractmethod
    def decide(self, evidence: Evidence) -> Decision:
        """The verdict after the newest demonstration."""
