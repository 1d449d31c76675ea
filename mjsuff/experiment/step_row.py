"""One row of ``steps.parquet``: the single definition of its columns, their types and meaning.

The experiment loop (``mjsuff.experiment.replicate``) builds each row as a ``StepRow``; the report
(``mjsuff.report.results``) and the README's table read the columns from here (a test keeps the
README's table equal to them). One row per replicate × rule × rule parameter × demo step.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any


def _column(meaning: str) -> Any:
    return field(metadata={"meaning": meaning})


@dataclass
class StepRow:
    """A rule's decision after one demo, with the ground truth of the policy it would deploy and
    the posterior's diagnostics. Field order is column order."""

    replicate: int = _column(
        "replicate index (its instance and all its randomness derive from seed and this)"
    )
    rule: str = _column("`nevd` (ε), `piob` (threshold), `patience` (p), `validation` (interval)")
    param: float = _column("the rule's parameter (ε, threshold, p or interval)")
    step: int = _column("demos so far")
    start: int = _column("the pool index the newest demo came from")
    pool_size: int = _column("the demo pool's size")
    poor_demo: bool = _column("whether the newest demo was deliberately poor")
    bound: float = _column("the rule's bound (nEVD upper / PIOB lower bound; NaN for baselines)")
    true_value: float = _column("ground truth of the policy the rule would deploy: nEVD, or PIOB for `piob`")
    true_nevd: float = _column("true nEVD of that policy under the hidden w*")
    true_piob: float = _column("true PIOB of that policy under the hidden w*")
    decision: bool = _column("the rule declares sufficiency now")
    policy_optimality: float = _column(
        "share of demonstrable states (scenes: evaluation starts) where that policy is optimal under w*"
    )
    map_log_likelihood: float = _column("the MAP's log-likelihood")
    acceptance_rate: float = _column("the share of the sampler's jumps that moved a chain")
    rhat: float = _column("rank-normalized split-R̂ of the sampler's final window (worst coordinate)")
    ess_bulk: float = _column("bulk-ESS of the kept draws (smallest coordinate)")
    ess_tail: float = _column("tail-ESS of the kept draws (smallest coordinate)")
    bound_ess: float = _column(
        "the effective size the nEVD bound's order statistic was chosen for (the quantile ESS of "
        "the samples' nEVD, at most N)"
    )
    mcmc_steps: int = _column("steps per chain the sampler ran")
    converged: bool = _column(
        "whether the sampler met `rhat_target` and `min_ess` before `max_steps` (if not, the bound "
        "rules did not stop at this step)"
    )
    simulated_steps: int = _column(
        "MuJoCo scenes: steps simulated so far in this replicate (expert, planner, V*, truth; the "
        "last step's rows: all of the replicate's, its scoring and the truth's searches at the end "
        "included); 0 for tabular domains"
    )
    diverged_rollouts: int = _column("MuJoCo scenes: rollouts detected as diverged and never scored so far")
    truth_raised_starts: int = _column(
        "evaluation starts whose true V* the replicate raised at its end to a better trajectory it "
        "simulated under w* or its truth found searching again (the same for every row of a replicate)"
    )
    truth_raise: float = _column("the largest such raise, as a share of V* − V_rand at that start")
    truth_passes: int = _column(
        "MuJoCo scenes: searches ground truth ran again at the replicate's end, from its own plans "
        "and every plan the learner made from the evaluation starts (`planning.truth_passes`; 0: none)"
    )
    truth_last_gain: float = _column(
        "the last of those searches' largest raise, a share of the start's value before it minus "
        "V_rand (at most 0.001: the truth settled; 0 without searches)"
    )

    def as_dict(self) -> dict[str, Any]:
        """The row as ``{column: value}``, in column order (one record of the parquet file)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


#: The columns a domain's ``simulation_stats`` fills, running counts per replicate (0 where it has
#: none). The MuJoCo scenes are the only domains that simulate; the names stay as v0.1 wrote them,
#: since renaming them would change every ``steps.parquet``.
SIMULATION_COUNTERS: tuple[str, ...] = ("simulated_steps", "diverged_rollouts")
#: The columns of ``steps.parquet``, in order.
STEP_COLUMNS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(StepRow))
#: What each column means (the README's table).
COLUMN_MEANINGS: dict[str, str] = {f.name: f.metadata["meaning"] for f in dataclasses.fields(StepRow)}


def markdown_table() -> str:
    """The columns as the README's Markdown table (``tests/test_step_row.py`` keeps them equal)."""
    lines = ["| column | type | meaning |", "| --- | --- | --- |"]
    for f in dataclasses.fields(StepRow):
        lines.append(f"| `{f.name}` | {f.type} | {f.metadata['meaning']} |")
    return "\n".join(lines) + "\n"
