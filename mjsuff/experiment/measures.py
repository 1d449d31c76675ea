"""Dependent measures (paper §4.3 and Appendix E) computed from the per-step table.

A rule *stops* at the first step at which it declares sufficiency; a replicate that never stops
is evaluated at its last step. With ground truth "sufficient" meaning true nEVD ≤ ε (or true
PIOB ≥ the threshold), each replicate is one decision:

* TP — stopped and truly sufficient; FP — stopped but not; FN — never stopped though the final
  policy was sufficient; TN — never stopped and never sufficient. F1 = TP / (TP + ½(FP + FN)) (Eq. 10).
* accuracy — for bound rules, the share of replicates whose bound at the evaluated step is on the
  right side of the truth (bound ≥ true nEVD; bound ≤ true PIOB); NaN for baselines.
* bound_error — mean (bound − truth) at the evaluated step.
* demos_needed — mean evaluated step; fraction_of_states — its mean share of the demo pool
  (the states a demonstration can be asked from).
* TPR/FPR — over every (replicate, step) decision, as rates of the per-step confusion matrix.
* policy_optimality — mean share of optimal actions of the deployed policy at the evaluated step.

Baselines have no threshold of their own: they are scored at every nEVD threshold ε.

The paper's measures, as its published code computes them (``sufficiency.py`` and the notebook
``organized_plotting.ipynb``), beside ours. There a rule does not stop: every demo step of every
replicate is a decision, sufficient or not, scored against the truth at that step:

* ``paper_tp``, ``paper_fp``, ``paper_fn``, ``paper_tn`` — that per-step confusion matrix (the
  counts behind ``tpr`` and ``fpr``).
* ``paper_f1_notebook`` — the F1 the notebook reports: its ``calc_F1`` reads FN as the constant 1
  (``FN = [1][0]``), so F1 = TP / (TP + ½(FP + 1)) whatever the real FN.
* ``paper_f1_per_step`` — the same per-step F1 with the real FN: TP / (TP + ½(FP + FN)).
* ``paper_demos`` — the mean demo count over every step at which the rule was sufficient (not the
  first stop), pooled over replicates; ``paper_pct_states`` the mean share of the demo pool over
  those steps. NaN when the rule was never sufficient (the notebook's ``mean`` would show 0). The
  paper divides by rows·cols, which in the gridworld counts the terminal cell (25 cells, 24 in
  the pool), so its share there is 24/25 of ``paper_pct_states``.

Ground truth is the same as ours (true nEVD ≤ ε, true PIOB ≥ the threshold; the paper's strict
inequalities differ only at exact equality). Baselines are scored at every ε, as above.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd


def _f1(tp: int, fp: int, fn: int) -> float:
    den = tp + 0.5 * (fp + fn)
    return tp / den if den else math.nan


def _rate(num: int, den: int) -> float:
    return num / den if den else math.nan


def _sem(x: np.ndarray) -> float:
    return float(x.std(ddof=1) / math.sqrt(x.size)) if x.size > 1 else math.nan


def _truth(frame: pd.DataFrame, improvement: bool, threshold: float) -> np.ndarray:
    if improvement:
        return frame["true_piob"].to_numpy() >= threshold
    return frame["true_nevd"].to_numpy() <= threshold


def evaluated_rows(frame: pd.DataFrame) -> pd.DataFrame:
    """One rule's row per replicate at which it is evaluated: its first step declaring
    sufficiency, else its last step; ``stopped`` says which (sorted by replicate)."""
    frame = frame.sort_values(["replicate", "step"])
    first = frame[frame["decision"].to_numpy(bool)].groupby("replicate", sort=True).head(1)
    last = frame.groupby("replicate", sort=True).tail(1)
    rows = pd.concat([first, last[~last["replicate"].isin(first["replicate"])]])
    rows = rows.assign(stopped=rows["replicate"].isin(first["replicate"]))
    return rows.sort_values("replicate", kind="stable")


def replicate_outcomes(frame: pd.DataFrame, improvement: bool, threshold: float) -> pd.DataFrame:
    """One rule's evaluated row per replicate (``evaluated_rows``) with ``good``: its policy
    truly sufficient there (true nEVD ≤ ``threshold``, or true PIOB ≥ it). ``stopped & good``
    is a TP, ``stopped & ~good`` an FP, ``~stopped & good`` an FN (module docstring)."""
    rows = evaluated_rows(frame)
    return rows.assign(good=_truth(rows, improvement, threshold))


def f1_score(stopped: np.ndarray, good: np.ndarray) -> float:
    """F1 (Eq. 10) of replicate decisions, one of each per replicate (read as booleans); NaN
    without a TP, FP or FN."""
    stopped, good = np.asarray(stopped, bool), np.asarray(good, bool)
    tp = int(np.sum(stopped & good))
    return _f1(tp, int(np.sum(stopped & ~good)), int(np.sum(~stopped & good)))


def measure_group(frame: pd.DataFrame, improvement: bool, threshold: float) -> dict[str, Any]:
    """All measures for one rule and parameter, against the truth threshold ``threshold``."""
    frame = frame.sort_values(["replicate", "step"])
    truth = _truth(frame, improvement, threshold)
    decision = frame["decision"].to_numpy()
    step_tp = int((decision & truth).sum())
    step_fp = int((decision & ~truth).sum())
    step_fn = int((~decision & truth).sum())
    step_tn = int((~decision & ~truth).sum())

    rows = replicate_outcomes(frame, improvement, threshold)
    good = rows["good"].to_numpy(bool)
    stopped = rows["stopped"].to_numpy(bool)
    tp, fp = int((stopped & good).sum()), int((stopped & ~good).sum())
    fn, tn = int((~stopped & good).sum()), int((~stopped & ~good).sum())
    needed = rows["step"].to_numpy(int)
    fractions = needed / rows["pool_size"].to_numpy(int)
    optimality = rows["policy_optimality"].to_numpy(float)
    bound, true = rows["bound"].to_numpy(float), rows["true_value"].to_numpy(float)
    known = ~np.isnan(bound)
    accurate = (bound <= true if improvement else bound >= true)[known]
    errors = (bound - true)[known]
    needed_arr = np.array(needed, dtype=float)
    sufficient = frame[decision.astype(bool)]
    paper_steps = sufficient["step"].to_numpy(float)
    paper_shares = paper_steps / sufficient["pool_size"].to_numpy(float)
    return {
        "replicates": len(needed),
        "f1": _f1(tp, fp, fn),
        "accuracy": float(np.mean(accurate)) if accurate.size else math.nan,
        "bound_error": float(np.mean(errors)) if errors.size else math.nan,
        "demos_needed": float(needed_arr.mean()),
        "demos_needed_sem": _sem(needed_arr),
        "fraction_of_states": float(np.mean(fractions)),
        "stopped_fraction": float(np.mean(stopped)),
        "tpr": _rate(step_tp, step_tp + step_fn),
        "fpr": _rate(step_fp, step_fp + step_tn),
        "policy_optimality": float(np.mean(optimality)),
        "tp": tp,
        "fp": fp,
        "fn": fn,
        "tn": tn,
        **paper_measures(step_tp, step_fp, step_fn, step_tn, paper_steps, paper_shares),
    }


def paper_measures(
    tp: int, fp: int, fn: int, tn: int, steps: np.ndarray, shares: np.ndarray
) -> dict[str, Any]:
    """The paper's measures from the per-step confusion counts and the demo counts ``steps`` and
    pool shares ``shares`` of every step at which the rule was sufficient (module docstring)."""
    return {
        "paper_f1_notebook": tp / (tp + 0.5 * (fp + 1)),
        "paper_f1_per_step": _f1(tp, fp, fn),
        "paper_demos": float(steps.mean()) if steps.size else math.nan,
        "paper_pct_states": float(shares.mean()) if shares.size else math.nan,
        "paper_tp": tp,
        "paper_fp": fp,
        "paper_fn": fn,
        "paper_tn": tn,
    }


def sampler_diagnostics(rows: pd.DataFrame) -> dict[str, Any]:
    """The posteriors behind ``rows`` (one row per replicate and step): mean and worst R̂, mean
    and smallest ESS (the smaller of bulk and tail), the share that converged, and the mean
    effective size the nEVD bound's index used. Empty for runs without these columns."""
    if "converged" not in rows:
        return {}
    ess = rows[["ess_bulk", "ess_tail"]].min(axis=1)
    return {
        "mean_rhat": float(rows["rhat"].mean()),
        "max_rhat": float(rows["rhat"].max()),
        "mean_ess": float(ess.mean()),
        "min_ess": float(ess.min()),
        "converged": float(rows["converged"].astype(bool).mean()),
        "mean_bound_ess": float(rows["bound_ess"].mean()),
        "mean_mcmc_steps": float(rows["mcmc_steps"].mean()),
    }


def summarize(steps: pd.DataFrame, nevd_thresholds: list[float]) -> dict[str, Any]:
    """``summary.json`` content: one entry per rule × parameter (× ε for baselines), plus the
    per-step nEVD bound curve (Figure 2)."""
    entries: list[dict[str, Any]] = []
    for (rule, param), group in steps.groupby(["rule", "param"], sort=False):
        if rule in ("nevd", "piob"):
            thresholds = [float(param)]
        else:
            thresholds = [float(t) for t in nevd_thresholds]
        for eps in thresholds:
            entry = {"rule": rule, "param": float(param), "epsilon": eps}
            entry.update(measure_group(group, rule == "piob", eps))
            entries.append(entry)
    curve: list[dict[str, Any]] = []
    nevd = steps[steps["rule"] == "nevd"]
    if not nevd.empty:
        first = nevd[nevd["param"] == nevd["param"].iloc[0]]
        for step, g in first.groupby("step", sort=True):
            curve.append(
                {
                    "step": int(step),
                    "replicates": len(g),
                    "mean_bound": float(g["bound"].mean()),
                    "mean_true_nevd": float(g["true_nevd"].mean()),
                    "bound_accuracy": float((g["bound"] >= g["true_nevd"]).mean()),
                    **sampler_diagnostics(g),
                }
            )
    return {"entries": entries, "nevd_bound_by_step": curve}
