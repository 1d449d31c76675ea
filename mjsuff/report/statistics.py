"""The paper's tests between stopping rules (§4.4): Kruskal-Wallis, then Dunn post-hoc tests with
the Bonferroni correction (``scikit_posthocs.posthoc_dunn``), with the medians compared.

* H1 (F1): one observation per rule parameter and threshold ε — the F1 of that rule at ε.
* H2 (sample efficiency): the demos each replicate needed — one observation per replicate and
  rule parameter (for the nEVD rule its parameter is ε; a baseline stops where it stops whatever
  ε is, so it is not repeated per ε).

The bound rules and the baselines form the groups (``nevd``, ``patience`` i.e. convergence,
``validation``); the PIOB rule answers a different question and is left out, as in the paper.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
import scikit_posthocs
from scipy import stats

from mjsuff.experiment.measures import evaluated_rows, measure_group

RULES = ("nevd", "patience", "validation")


@dataclass(frozen=True)
class RuleComparison:
    """Kruskal-Wallis over the rule groups and Dunn's pairwise p-values (Bonferroni)."""

    measure: str
    groups: dict[str, np.ndarray]
    h: float
    p: float
    dunn: pd.DataFrame  # rule x rule adjusted p-values

    def medians(self) -> dict[str, float]:
        return {k: float(np.median(v)) for k, v in self.groups.items()}


def observations(steps: pd.DataFrame, thresholds: list[float]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(F1 per rule, param and ε), (demos needed per rule, param and replicate)."""
    f1_rows, demo_rows = [], []
    for (rule, param), group in steps[steps["rule"].isin(RULES)].groupby(["rule", "param"]):
        for eps in [float(param)] if rule == "nevd" else thresholds:
            f1 = measure_group(group, False, eps)["f1"]
            f1_rows.append({"rule": rule, "param": param, "epsilon": eps, "f1": f1})
        rows = evaluated_rows(group)
        demo_rows += [{"rule": rule, "param": param, "replicate": r, "demos": int(n)}
                      for r, n in zip(rows["replicate"], rows["step"], strict=True)]
    return pd.DataFrame(f1_rows), pd.DataFrame(demo_rows)


def compare_rules(values: pd.DataFrame, column: str) -> RuleComparison | None:
    """Kruskal-Wallis and Dunn-Bonferroni between the rules on ``column``; None when fewer than
    two rules have data or every value is the same (the tests are undefined)."""
    values = values[np.isfinite(values[column].astype(float))]
    groups = {r: values.loc[values["rule"] == r, column].to_numpy(float) for r in RULES}
    groups = {r: v for r, v in groups.items() if v.size}
    pooled = np.concatenate(list(groups.values())) if groups else np.array([])
    if len(groups) < 2 or np.ptp(pooled) == 0:
        return None
    h, p = stats.kruskal(*groups.values())
    dunn = scikit_posthocs.posthoc_dunn(values, val_col=column, group_col="rule",
                                        p_adjust="bonferroni")
    return RuleComparison(column, groups, float(h), float(p) if not math.isnan(p) else 1.0, dunn)
