"""The paper's tests between stopping rules (§4.4): Kruskal-Wallis, then Dunn post-hoc tests with
the Bonferroni correction (``scikit_posthocs.posthoc_dunn``), with the medians compared.

Each replicate (one random world) gives exactly one observation per rule, so the observations of
a rule are independent and every rule has as many as there are replicates; a rule's parameters
are averaged within the replicate, never entered as separate observations (which would count one
world several times: pseudo-replication).

* H1 (decision quality): per replicate and rule, the share of its stop decisions that were
  correct, over the rule's parameters × thresholds ε (nEVD: each ε with its own parameter;
  convergence and validation baselines: every p or interval at every ε). A decision is the one
  the per-replicate F1 counts (Eq. 10: the rule's first sufficient step, else its last): correct
  when it stopped with true nEVD ≤ ε (TP) or never stopped and the final policy was not within ε
  (TN). F1 cannot be the per-replicate measure: a replicate whose decisions are all TN has no F1,
  and dropping those worlds would bias the comparison, while the share of correct decisions is
  defined for every replicate (F1 pooled over replicates is in ``summary.json``).
* H2 (sample efficiency): per replicate and rule, the demos needed (the evaluated step) averaged
  over the rule's parameters (nEVD: over ε; convergence: over p; validation: over intervals). A
  baseline stops where it stops whatever ε is, so ε does not enter.

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

from mjsuff.experiment.measures import evaluated_rows

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
    """One row per rule and replicate: (share of correct decisions, column ``correct``), (demos
    needed averaged over the rule's parameters, column ``demos``); see the module docstring."""
    correct, demos = [], []
    for (rule, param), group in steps[steps["rule"].isin(RULES)].groupby(["rule", "param"]):
        rows = evaluated_rows(group)
        replicate, stopped = rows["replicate"].to_numpy(), rows["stopped"].to_numpy(bool)
        for eps in [float(param)] if rule == "nevd" else thresholds:
            good = rows["true_nevd"].to_numpy(float) <= eps
            right = (stopped == good).astype(float)
            correct.append(pd.DataFrame({"rule": rule, "replicate": replicate, "correct": right}))
        needed = rows["step"].to_numpy(float)
        demos.append(pd.DataFrame({"rule": rule, "replicate": replicate, "demos": needed}))

    def per_replicate(parts: list[pd.DataFrame], column: str) -> pd.DataFrame:
        if not parts:
            return pd.DataFrame(columns=["rule", "replicate", column])
        frame = pd.concat(parts, ignore_index=True)
        return frame.groupby(["rule", "replicate"], sort=True)[column].mean().reset_index()

    return per_replicate(correct, "correct"), per_replicate(demos, "demos")


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
    dunn = scikit_posthocs.posthoc_dunn(values, val_col=column, group_col="rule", p_adjust="bonferroni")
    return RuleComparison(column, groups, float(h), float(p) if not math.isnan(p) else 1.0, dunn)
