"""Bounds: per-sample regret/improvement, α-VaR confidence bounds, and Hoeffding baselines."""

from mjsuff.bounds.hoeffding import abbeel_ng_demos, syed_schapire_demos
from mjsuff.bounds.regret import normalized_evd, percent_improvement, policy_values
from mjsuff.bounds.var_bound import (
    QuantileMethod,
    bound_is_valid,
    least_effective_size,
    lower_var_bound,
    upper_var_bound,
    var_bound_index,
)

__all__ = [
    "QuantileMethod",
    "abbeel_ng_demos",
    "bound_is_valid",
    "least_effective_size",
    "lower_var_bound",
    "normalized_evd",
    "percent_improvement",
    "policy_values",
    "syed_schapire_demos",
    "upper_var_bound",
    "var_bound_index",
]
