"""Stopping rules: ours (nEVD and PIOB bounds) and the paper's baselines (§4.2)."""

from mjsuff.stopping.base import Decision, Evidence, StoppingRule
from mjsuff.stopping.nevd_bound import NevdBoundRule
from mjsuff.stopping.patience import PatienceRule
from mjsuff.stopping.piob_bound import PiobBoundRule
from mjsuff.stopping.validation_set import ValidationSetRule

__all__ = [
    "Decision",
    "Evidence",
    "NevdBoundRule",
    "PatienceRule",
    "PiobBoundRule",
    "StoppingRule",
    "ValidationSetRule",
]
