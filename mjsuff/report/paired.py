"""One rule's F1 in two runs of the same instances (a setting changed, the seed kept), compared
replicate by replicate.

Each replicate is one decision in each run (``measures.replicate_outcomes``: its stop, and whether
the policy there was truly sufficient), so the comparison is paired:

* the F1 difference (Eq. 10, here − there) with a 95% percentile bootstrap CI whose resamples take
  the same replicates from both runs. A run whose F1 is perfect has a bootstrap interval of the
  single point 1.00 on its own; the paired interval of the difference does not collapse with it.
  Resamples where either F1 is undefined (no TP, FP or FN) are dropped.
* the replicates whose decision was right (TP or TN) in one run only, with an exact two-sided
  McNemar test (a binomial test on the discordant replicates).

One observation per replicate: the bootstrap resamples replicates, never steps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.stats import binomtest

from mjsuff.experiment.measures import f1_score

#: Bootstrap resamples of the replicates.
BOOTSTRAP = 2000


@dataclass(frozen=True)
class PairedF1:
    """One rule's F1 here and there over the replicates both runs have."""

    here: float
    there: float
    low: float  # the difference's 95% CI
    high: float
    right_here_only: int
    right_there_only: int
    mcnemar_p: float
    replicates: int

    @property
    def difference(self) -> float:
        return self.here - self.there


def paired_f1(here: pd.DataFrame, there: pd.DataFrame, rng: np.random.Generator) -> PairedF1 | None:
    """Compare one rule's decisions in two runs.

    Args:
        here, there: ``replicate_outcomes`` of the rule in each run (columns ``replicate``,
            ``stopped``, ``good``).
        rng: Draws the bootstrap's resamples.

    Returns:
        The comparison over the replicates both frames have; None when they share none.
    """
    a, b = here.set_index("replicate"), there.set_index("replicate")
    reps = a.index.intersection(b.index)
    if reps.empty:
        return None
    sa, ga = a.loc[reps, "stopped"].to_numpy(bool), a.loc[reps, "good"].to_numpy(bool)
    sb, gb = b.loc[reps, "stopped"].to_numpy(bool), b.loc[reps, "good"].to_numpy(bool)
    idx = rng.integers(0, len(reps), (BOOTSTRAP, len(reps)))
    diff = np.array([f1_score(sa[i], ga[i]) - f1_score(sb[i], gb[i]) for i in idx])
    diff = diff[np.isfinite(diff)]
    low, high = np.quantile(diff, [0.025, 0.975]) if diff.size else (math.nan, math.nan)
    right_a, right_b = sa == ga, sb == gb
    only_a, only_b = int(np.sum(right_a & ~right_b)), int(np.sum(~right_a & right_b))
    p = binomtest(only_a, only_a + only_b).pvalue if only_a + only_b else 1.0
    return PairedF1(
        f1_score(sa, ga), f1_score(sb, gb), float(low), float(high), only_a, only_b, float(p), len(reps)
    )
