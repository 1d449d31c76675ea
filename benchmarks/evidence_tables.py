"""The README's evidence tables for a run, with 95% bootstrap CIs over replicates (issue #17).

    python benchmarks/evidence_tables.py RUN_DIR [--paired OTHER_RUN_DIR] [--epsilon 0.2]

Printed as markdown: π_MAP's true nEVD by demos (Figure 2's curve: mean, CI, median; the bound's
mean and how often it is at least the truth; with poor demos, that split at each replicate's first
poor demo); every rule's F1 and demos needed (the baselines at ``--epsilon``) with CIs and the
bound rules' accuracy at their stop; how often the end-of-replicate truth was raised. With
``--paired``, the demos needed by each rule in RUN_DIR minus OTHER_RUN_DIR, replicate by replicate
(the same instances when both runs share the seed: it checks that every shared check had the
same pool start and poor flag), with a CI; each rule's F1 here and there with a paired bootstrap
CI of the difference, and the replicates whose stop was right in one run only (exact McNemar
test); the nEVD bound and π_MAP's true nEVD here minus there
at each shared check (per count of demos, and per replicate); and the share of each replicate's
checks whose nEVD bound is at least the truth, this run against OTHER_RUN_DIR (Wilcoxon
signed-rank test over replicates), and, per nEVD threshold, whether the bound held at the rule's
stop (exact McNemar test on the replicates where the runs disagree).

One observation per replicate: the bootstrap resamples replicates, never steps.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import binomtest, wilcoxon

from mjsuff.domain import TRUTH_SETTLED
from mjsuff.experiment.measures import evaluated_rows, f1_score, measure_group, replicate_outcomes
from mjsuff.experiment.run_summary import truth_totals
from mjsuff.report.paired import paired_f1 as paired_f1_of

BOOTSTRAP = 2000
RULE_NAMES = {
    "nevd": "nEVD bound",
    "piob": "PIOB bound",
    "patience": "convergence (patience {p})",
    "validation": "validation set (interval {p})",
}


def load(run: Path) -> pd.DataFrame:
    """A run's steps.parquet, or its finished replicates' parts while it is still running."""
    if (run / "steps.parquet").is_file():
        return pd.read_parquet(run / "steps.parquet")
    return pd.concat([pd.read_parquet(p) for p in sorted((run / "replicates").glob("*.parquet"))])


def ci(values: np.ndarray, stat=np.mean, rng: np.random.Generator | None = None) -> tuple[float, float]:
    """95% percentile-bootstrap CI of ``stat`` over the rows of ``values``."""
    rng = rng or np.random.default_rng(0)
    idx = rng.integers(0, len(values), (BOOTSTRAP, len(values)))
    boot = np.array([stat(values[i]) for i in idx])
    boot = boot[np.isfinite(boot)]
    if not boot.size:
        return float("nan"), float("nan")
    return float(np.quantile(boot, 0.025)), float(np.quantile(boot, 0.975))


def nevd_checks(steps: pd.DataFrame) -> pd.DataFrame:
    """The nEVD rule's rows at its first threshold: one per replicate and check."""
    nevd = steps[steps["rule"] == "nevd"]
    return nevd[nevd["param"] == nevd["param"].min()]


def curve(steps: pd.DataFrame) -> str:
    first = nevd_checks(steps)
    lines = {"mean": [], "ci": [], "median": [], "bound": [], "covered": []}
    demos = sorted(first["step"].unique())
    for step in demos:
        g = first[first["step"] == step].sort_values("replicate")
        truth = g["true_nevd"].to_numpy(float)
        low, high = ci(truth)
        lines["mean"].append(f"{truth.mean():.3f}")
        lines["ci"].append(f"{low:.2f}–{high:.2f}")
        lines["median"].append(f"{np.median(truth):.3f}")
        lines["bound"].append(f"{g['bound'].mean():.3f}")
        lines["covered"].append(f"{(g['bound'] >= g['true_nevd']).mean():.2f}")
    covered = (first["bound"] >= first["true_nevd"]).to_numpy()
    head = "| demos | " + " | ".join(str(d) for d in demos) + " |\n"
    head += "| --- |" + " --- |" * len(demos) + "\n"
    names = {
        "mean": "true nEVD of π_MAP, mean",
        "ci": "… 95% CI",
        "median": "… median",
        "bound": "nEVD bound, mean",
        "covered": "bound ≥ true nEVD",
    }
    body = "".join(f"| {names[k]} | " + " | ".join(v) + " |\n" for k, v in lines.items())
    return (
        head + body + f"\nBound ≥ true nEVD in {covered.sum()} of {covered.size} checks "
        f"({covered.mean():.2f}).\n"
    )


def coverage_by_poor_demos(steps: pd.DataFrame) -> str:
    """Bound ≥ truth split at each replicate's first poor demo (empty if none was shown)."""
    first = nevd_checks(steps).sort_values(["replicate", "step"])
    if not first["poor_demo"].any():
        return ""
    after = first.groupby("replicate")["poor_demo"].cumsum().to_numpy() > 0
    covered = (first["bound"] >= first["true_nevd"]).to_numpy()
    shown = first.groupby("replicate")["poor_demo"].any()
    return (
        f"Poor demos shown in {shown.sum()} of {shown.size} replicates. Bound ≥ true nEVD before a "
        f"replicate's first poor demo in {covered[~after].sum()} of {(~after).sum()} checks; from it "
        f"on, in {covered[after].sum()} of {after.sum()}.\n"
    )


def rule_rows(steps: pd.DataFrame, epsilon: float) -> list[tuple[str, float, pd.DataFrame, bool]]:
    out = []
    for (rule, param), group in steps.groupby(["rule", "param"], sort=False):
        label = RULE_NAMES[rule].format(p=int(param))
        if rule == "nevd":
            out.append((label, float(param), group, False))
        elif rule == "piob":
            out.append((label, float(param), group, True))
        else:
            out.append((label, epsilon, group, False))
    return out


def rules(steps: pd.DataFrame, epsilon: float) -> str:
    text = "| rule | ε | F1 | demos needed | bound accuracy |\n| --- | --- | --- | --- | --- |\n"
    for label, eps, group, improvement in rule_rows(steps, epsilon):
        m = measure_group(group, improvement, eps)
        outcomes = replicate_outcomes(group, improvement, eps)[["stopped", "good"]].to_numpy(bool)
        f_low, f_high = ci(outcomes, lambda rows: f1_score(rows[:, 0], rows[:, 1]))
        needed = evaluated_rows(group)["step"].to_numpy(float)
        d_low, d_high = ci(needed)
        acc = "–" if np.isnan(m["accuracy"]) else f"{m['accuracy']:.2f}"
        text += (
            f"| {label} | {eps:g} | {m['f1']:.2f} ({f_low:.2f}–{f_high:.2f}) | "
            f"{m['demos_needed']:.1f} ({d_low:.1f}–{d_high:.1f}) | {acc} |\n"
        )
    return text


def truth_raised(steps: pd.DataFrame) -> str:
    """How the replicates' ends raised the truth and, with ``planning.truth_passes``, how its
    searches again went (``run_summary.truth_totals``)."""
    per_rep = steps.groupby("replicate")[["truth_raised_starts", "truth_raise"]].max()
    raised = per_rep[per_rep["truth_raised_starts"] > 0]
    if raised.empty:
        return f"Truth raised at the end of 0 of {len(per_rep)} replicates.\n"
    text = (
        f"Truth raised at the end of {len(raised)} of {len(per_rep)} replicates "
        f"(by {raised['truth_raise'].min():.3f}–{raised['truth_raise'].max():.3f} of "
        f"V* − V_rand; {int(raised['truth_raised_starts'].sum())} evaluation starts in all; "
        f"by more than {TRUTH_SETTLED:g} in {int((raised['truth_raise'] > TRUTH_SETTLED).sum())}).\n"
    )
    totals = truth_totals(steps)
    if totals["searches"]:
        text += (
            f"Searched again {totals['searches']} times in all; still rising at the last search "
            f"in {totals['unsettled_replicates']} of {len(per_rep)} replicates.\n"
        )
    return text


def shared_checks(
    steps: pd.DataFrame, other: pd.DataFrame, columns: list[str]
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``columns`` of the nEVD checks both runs ran, indexed alike by (replicate, step)."""
    keys = ["replicate", "step"]
    a = nevd_checks(steps).set_index(keys)[columns]
    b = nevd_checks(other).set_index(keys)[columns]
    both = a.index.intersection(b.index)
    return a.loc[both], b.loc[both]


def same_schedule(steps: pd.DataFrame, other: pd.DataFrame) -> str:
    """Whether the two runs saw the same demos: per replicate both runs share, the pool start and
    the poor flag of every check both ran (the nEVD rule's first threshold runs every check)."""
    a, b = shared_checks(steps, other, ["start", "poor_demo"])
    both = a.index
    differs = (a != b).any(axis=1)
    reps = both.get_level_values("replicate").unique()
    bad = sorted(set(differs[differs].index.get_level_values("replicate")))
    return (
        f"Same demo schedule (pool start and poor flag at every shared check): "
        f"{len(reps) - len(bad)} of {len(reps)} shared replicates, {len(both)} checks"
        + (f"; differs in replicates {bad}" if bad else "")
        + ".\n"
    )


def paired(steps: pd.DataFrame, other: pd.DataFrame, epsilon: float) -> str:
    text = (
        "| rule | ε | demos needed, this − other (mean, 95% CI) | replicates |\n| --- | --- | --- | --- |\n"
    )
    theirs = {(label, eps): g for label, eps, g, _ in rule_rows(other, epsilon)}
    for label, eps, group, _ in rule_rows(steps, epsilon):
        if (label, eps) not in theirs:
            continue
        a = evaluated_rows(group).set_index("replicate")["step"]
        b = evaluated_rows(theirs[label, eps]).set_index("replicate")["step"]
        both = a.index.intersection(b.index)
        diff = (a[both] - b[both]).to_numpy(float)
        low, high = ci(diff)
        text += f"| {label} | {eps:g} | {diff.mean():+.2f} ({low:+.2f} to {high:+.2f}) | {len(both)} |\n"
    return text


def paired_f1(steps: pd.DataFrame, other: pd.DataFrame, epsilon: float) -> str:
    """Per rule, its F1 here and there with a paired bootstrap CI of the difference, and the
    replicates whose stop was right in one run only (``mjsuff.report.paired``)."""
    text = (
        "| rule | ε | F1 here | there | here − there (paired 95% CI) | right here only | there only "
        "| McNemar p | replicates |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n"
    )
    theirs = {(label, eps): g for label, eps, g, _ in rule_rows(other, epsilon)}
    for label, eps, group, improvement in rule_rows(steps, epsilon):
        if (label, eps) not in theirs:
            continue
        here = replicate_outcomes(group, improvement, eps)
        there = replicate_outcomes(theirs[label, eps], improvement, eps)
        c = paired_f1_of(here, there, np.random.default_rng(0))
        if c is None:
            continue
        text += (
            f"| {label} | {eps:g} | {c.here:.3f} | {c.there:.3f} | {c.difference:+.3f} ({c.low:+.3f} to "
            f"{c.high:+.3f}) | {c.right_here_only} | {c.right_there_only} | {c.mcnemar_p:.2g} | "
            f"{c.replicates} |\n"
        )
    return text


def paired_bound(steps: pd.DataFrame, other: pd.DataFrame) -> str:
    """Per count of demos, the nEVD bound and π_MAP's true nEVD here minus there at the same
    check (the same replicate and demo count; a CI over replicates); then each replicate's mean
    difference over the checks both ran, one observation per replicate."""
    a, b = shared_checks(steps, other, ["bound", "true_nevd"])
    diff = (a - b).reset_index()
    text = (
        "| demos | bound, here − there (mean, 95% CI) | true nEVD of π_MAP, here − there | replicates |\n"
        "| --- | --- | --- | --- |\n"
    )
    for step, g in diff.groupby("step"):
        bound, truth = g["bound"].to_numpy(float), g["true_nevd"].to_numpy(float)
        (bl, bh), (tl, th) = ci(bound), ci(truth)
        text += (
            f"| {step} | {bound.mean():+.4f} ({bl:+.4f} to {bh:+.4f}) | "
            f"{truth.mean():+.4f} ({tl:+.4f} to {th:+.4f}) | {len(g)} |\n"
        )
    per_rep = diff.groupby("replicate")[["bound", "true_nevd"]].mean()
    bound, truth = per_rep["bound"].to_numpy(float), per_rep["true_nevd"].to_numpy(float)
    (bl, bh), (tl, th) = ci(bound), ci(truth)
    higher = int(np.sum(diff["bound"] > 0))
    lower = int(np.sum(diff["bound"] < 0))
    return text + (
        f"\nPer replicate (mean over its checks): bound {bound.mean():+.4f} ({bl:+.4f} to {bh:+.4f}), "
        f"true nEVD {truth.mean():+.4f} ({tl:+.4f} to {th:+.4f}) over {len(per_rep)} replicates; "
        f"the bound higher here at {higher} of {len(diff)} checks, lower at {lower}.\n"
    )


def paired_coverage(steps: pd.DataFrame, other: pd.DataFrame) -> str:
    """Per replicate, the share of its nEVD checks with bound ≥ truth, this run against ``other``;
    and per nEVD threshold, bound ≥ truth at the rule's stop (one observation per replicate)."""

    def shares(frame: pd.DataFrame) -> pd.Series:
        first = nevd_checks(frame)
        return (first["bound"] >= first["true_nevd"]).groupby(first["replicate"]).mean()

    a, b = shares(steps), shares(other)
    both = a.index.intersection(b.index)
    diff = (a[both] - b[both]).to_numpy(float)
    low, high = ci(diff)
    p = wilcoxon(diff).pvalue if np.any(diff != 0) else 1.0
    text = (
        f"Share of a replicate's checks with bound ≥ true nEVD: {a[both].mean():.2f} here, "
        f"{b[both].mean():.2f} there; difference {diff.mean():+.2f} ({low:+.2f} to {high:+.2f}), "
        f"Wilcoxon signed-rank p = {p:.2g} over {len(both)} replicates.\n\n"
        "| nEVD threshold | bound ≥ truth at the stop, here | there | here only | there only | McNemar p |\n"
        "| --- | --- | --- | --- | --- | --- |\n"
    )
    nevd, theirs = steps[steps["rule"] == "nevd"], other[other["rule"] == "nevd"]
    for param, group in nevd.groupby("param"):
        here = evaluated_rows(group).set_index("replicate")
        there = evaluated_rows(theirs[theirs["param"] == param]).set_index("replicate")
        reps = here.index.intersection(there.index)
        x = (here.loc[reps, "bound"] >= here.loc[reps, "true_nevd"]).to_numpy()
        y = (there.loc[reps, "bound"] >= there.loc[reps, "true_nevd"]).to_numpy()
        only_x, only_y = int(np.sum(x & ~y)), int(np.sum(~x & y))
        mcnemar = binomtest(only_x, only_x + only_y).pvalue if only_x + only_y else 1.0
        text += f"| {param:g} | {x.mean():.2f} | {y.mean():.2f} | {only_x} | {only_y} | {mcnemar:.2g} |\n"
    return text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("--paired", type=Path)
    parser.add_argument(
        "--epsilon", type=float, default=0.2, help="the ε the baselines are scored at (default 0.2)"
    )
    args = parser.parse_args()
    steps = load(args.run)
    print(f"{args.run}: {steps['replicate'].nunique()} replicates\n")
    print(curve(steps))
    if poor := coverage_by_poor_demos(steps):
        print(poor)
    print(rules(steps, args.epsilon))
    print(truth_raised(steps))
    if args.paired:
        other = load(args.paired)
        print(same_schedule(steps, other))
        print(paired(steps, other, args.epsilon))
        print(paired_f1(steps, other, args.epsilon))
        print(paired_bound(steps, other))
        print(paired_coverage(steps, other))


if __name__ == "__main__":
    main()
