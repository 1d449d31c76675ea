"""The paper's figures from run results, with matplotlib (Agg; PNG files).

* ``f1_and_demos`` — F1 and demos needed vs. the threshold ε per rule (paper Fig. 4), with
  standard-error bands: bootstrap over replicates for F1, the SEM for demos.
* ``bound_vs_demos`` — the α-VaR nEVD bound and the true nEVD of π_MAP vs. the number of demos
  (paper Fig. 2), mean ± SEM over replicates.
* ``noise_ablation`` — the nEVD rule's accuracy, TPR and FPR vs. the share of poor demos, a line
  per ε and per value of the cells' other labels (e.g. the likelihood's lapse rate).
"""

from __future__ import annotations

import itertools
import math
import textwrap
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from mjsuff.atomic import atomic_write
from mjsuff.experiment.measures import evaluated_rows, measure_group
from mjsuff.report.results import ReportCell, label_texts

COLOURS = {"nevd": "#1f77b4", "patience": "#d62728", "validation": "#2ca02c", "piob": "#9467bd"}
SHADES = {"patience": "Reds", "validation": "Greens"}
NAMES = {"nevd": "nEVD bound (ours)", "patience": "Convergence", "validation": "Validation set"}
BOOTSTRAP = 200

plt.rcParams.update(
    {
        "font.size": 10,
        "axes.spines.top": False,
        "axes.spines.right": False,
        "axes.grid": True,
        "grid.alpha": 0.3,
        "legend.frameon": False,
        "savefig.dpi": 150,
    }
)


def replicate_outcomes(group: pd.DataFrame, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """Per replicate: outcome code (0 TP, 1 FP, 2 FN, 3 TN) at ε and demos needed."""
    rows = evaluated_rows(group)
    good = rows["true_nevd"].to_numpy(float) <= eps
    codes = np.where(rows["stopped"].to_numpy(bool), np.where(good, 0, 1), np.where(good, 2, 3))
    return codes, rows["step"].to_numpy(float)


def f1_with_se(codes: np.ndarray, rng: np.random.Generator) -> tuple[float, float]:
    """F1 (Eq. 10) and its bootstrap standard error over replicates."""

    def f1(c: np.ndarray) -> float:
        tp, fp, fn = (c == 0).sum(), (c == 1).sum(), (c == 2).sum()
        den = tp + 0.5 * (fp + fn)
        return tp / den if den else math.nan

    draws = [f1(codes[rng.integers(0, codes.size, codes.size)]) for _ in range(BOOTSTRAP)]
    boot = np.array([b for b in draws if not math.isnan(b)])
    return f1(codes), float(boot.std(ddof=1)) if boot.size > 1 else math.nan


def rule_curves(cell: ReportCell, seed: int = 0) -> pd.DataFrame:
    """Per rule, param and ε: F1 ± SE, demos needed ± SEM (bound rules at their own ε)."""
    rng = np.random.default_rng(seed)
    rows = []
    steps = cell.steps[cell.steps["rule"].isin(NAMES)]
    for (rule, param), group in steps.groupby(["rule", "param"], sort=False):
        for eps in [float(param)] if rule == "nevd" else cell.thresholds:
            codes, needed = replicate_outcomes(group, eps)
            f1, se = f1_with_se(codes, rng)
            sem = needed.std(ddof=1) / math.sqrt(needed.size) if needed.size > 1 else math.nan
            rows.append(
                {
                    "rule": rule,
                    "param": float(param),
                    "epsilon": eps,
                    "f1": f1,
                    "f1_se": se,
                    "demos": needed.mean(),
                    "demos_sem": sem,
                    "replicates": needed.size,
                }
            )
    return pd.DataFrame(rows)


def _band(ax: plt.Axes, x: Any, y: Any, se: Any, colour: Any, label: str, style: str = "-") -> None:
    """A line with markers and a ±``se`` band."""
    x, y, se = np.asarray(x), np.asarray(y, float), np.nan_to_num(np.asarray(se, float))
    ax.plot(x, y, style, color=colour, marker="o", markersize=3, label=label)
    ax.fill_between(x, y - se, y + se, color=colour, alpha=0.15, linewidth=0)


def f1_and_demos(cell: ReportCell, path: Path) -> Path:
    """Paper Fig. 4: F1 and demos needed vs. ε, one line per rule parameter."""
    curves = rule_curves(cell)
    fig, (ax_f1, ax_demos) = plt.subplots(1, 2, figsize=(9, 3.4))
    styles = ["-", "--", ":", "-."]
    for rule in NAMES:
        sub = curves[curves["rule"] == rule]
        if sub.empty:
            continue
        if rule == "nevd":
            sub = sub.sort_values("epsilon")
            _band(ax_f1, sub["epsilon"], sub["f1"], sub["f1_se"], COLOURS[rule], NAMES[rule])
            _band(ax_demos, sub["epsilon"], sub["demos"], sub["demos_sem"], COLOURS[rule], NAMES[rule])
            continue
        params = sorted(sub["param"].unique())
        shades = plt.get_cmap(SHADES[rule])(np.linspace(0.45, 0.9, len(params)))
        for i, param in enumerate(params):
            line = sub[sub["param"] == param].sort_values("epsilon")
            label = f"{NAMES[rule]} ({'p' if rule == 'patience' else 'i'} = {param:g})"
            style = styles[i % len(styles)]
            _band(ax_f1, line["epsilon"], line["f1"], line["f1_se"], shades[i], label, style)
            _band(ax_demos, line["epsilon"], line["demos"], line["demos_sem"], shades[i], label, style)
    ax_f1.set(xlabel="nEVD threshold ε", ylabel="F1", ylim=(-0.02, 1.05), title="F1 score")
    ax_demos.set(xlabel="nEVD threshold ε", ylabel="demos", title="Demonstrations needed")
    ax_demos.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
    fig.suptitle(cell.title, fontsize=10)
    fig.tight_layout()
    _save(fig, path)
    return path


def bound_curve(cell: ReportCell) -> pd.DataFrame:
    """Per demo count: mean and SEM of the nEVD bound and of π_MAP's true nEVD."""
    nevd = cell.steps[cell.steps["rule"] == "nevd"]
    nevd = nevd[nevd["param"] == nevd["param"].min()]
    out = (
        nevd.groupby("step")
        .agg(
            bound=("bound", "mean"),
            bound_sd=("bound", "std"),
            truth=("true_nevd", "mean"),
            truth_sd=("true_nevd", "std"),
            n=("bound", "size"),
        )
        .reset_index()
    )
    out["bound_sem"] = out["bound_sd"] / np.sqrt(out["n"])
    out["truth_sem"] = out["truth_sd"] / np.sqrt(out["n"])
    return out


def bound_vs_demos(cells: list[ReportCell], path: Path) -> Path:
    """Paper Fig. 2: the nEVD bound and the true nEVD vs. demos, one panel per cell."""
    n = len(cells)
    cols = min(n, 3)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.2 * rows), squeeze=False)
    for ax, cell in zip(axes.flat, cells, strict=False):
        c = bound_curve(cell)
        _band(ax, c["step"], c["bound"], c["bound_sem"], COLOURS["nevd"], "α-VaR bound")
        _band(ax, c["step"], c["truth"], c["truth_sem"], "black", "true nEVD of π_MAP", "--")
        ax.set(xlabel="demonstrations", ylabel="nEVD", ylim=(0, None))
        ax.set_title(textwrap.fill(cell.title, 44), fontsize=10)  # fits a 4-inch panel
        ax.legend(fontsize=8)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    fig.tight_layout()
    _save(fig, path)
    return path


NOISE_KEY = "demos.noise_fraction"


def _series_name(labels: dict[str, Any]) -> str:
    """A cell's labels other than the noise fraction, as text ("" when it has none)."""
    return ", ".join(label_texts({k: v for k, v in labels.items() if k != NOISE_KEY}))


def noise_table(cells: list[ReportCell]) -> pd.DataFrame:
    """The nEVD rule's accuracy, TPR, FPR, F1 per noise fraction and ε, one series per value of
    the cells' other labels (in a noise × lapse sweep: a noise series per lapse rate; the column
    ``series`` names it when there is more than one)."""
    rows = []
    for cell in (c for c in cells if NOISE_KEY in c.labels):
        nevd = cell.steps[cell.steps["rule"] == "nevd"]
        for eps, group in nevd.groupby("param"):
            m = measure_group(group, False, float(eps))
            rows.append(
                {
                    "series": _series_name(cell.labels),
                    "noise": float(cell.labels[NOISE_KEY]),
                    "epsilon": float(eps),
                    **{k: m[k] for k in ("accuracy", "tpr", "fpr", "f1", "demos_needed", "replicates")},
                }
            )
    if not rows:
        return pd.DataFrame()
    table = pd.DataFrame(rows).sort_values(["series", "epsilon", "noise"], kind="stable")
    return table if table["series"].nunique() > 1 else table.drop(columns="series")


#: Why a measure of the noise ablation has no value at a (noise, ε): its denominator is empty.
MISSING_REASONS = {
    "accuracy": "no bound",
    "tpr": "no truly sufficient step",
    "fpr": "no truly insufficient step",
}


def missing_point_note(measure: str, values: pd.Series) -> str | None:
    """The note a noise-ablation panel carries when some of its points are missing (NaN), saying
    why; None when every point is there."""
    return f"missing points: {MISSING_REASONS[measure]}" if values.isna().any() else None


def noise_ablation(cells: list[ReportCell], path: Path) -> Path | None:
    """Accuracy, TPR and FPR of the nEVD rule vs. the share of poor demos: one colour per ε, one
    line style per series (the cells' other labels)."""
    table = noise_table(cells)
    if table.empty or table["noise"].nunique() < 2:
        return None
    if "series" not in table:
        table = table.assign(series="")
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.2), sharex=True)
    cmap = plt.get_cmap("viridis")
    epsilons = sorted(table["epsilon"].unique())
    styles = dict(zip(sorted(table["series"].unique()), itertools.cycle(("-", "--", ":", "-."))))
    for ax, measure, title in zip(
        axes,
        ("accuracy", "tpr", "fpr"),
        ("Bound accuracy", "True-positive rate", "False-positive rate"),
        strict=True,
    ):
        for (series, style), (i, eps) in itertools.product(styles.items(), enumerate(epsilons)):
            line = table[(table["epsilon"] == eps) & (table["series"] == series)]
            ax.plot(
                line["noise"],
                line[measure],
                marker="o",
                markersize=3,
                linestyle=style,
                color=cmap(i / max(1, len(epsilons) - 1)),
                label=", ".join(filter(None, (f"ε = {eps:g}", series))),
            )
        ax.set(xlabel="share of poor demos", title=title, ylim=(-0.02, 1.05))
        note = missing_point_note(measure, table[measure])
        if note:
            ax.annotate(note, (0.02, 0.95), fontsize=7, xycoords="axes fraction", color="grey", va="top")
    # Long handles: in a short one the marker covers the gap that tells a dashed series apart.
    axes[-1].legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5), handlelength=4)
    fig.tight_layout()
    _save(fig, path)
    return path


def _save(fig: Any, path: Path) -> None:
    """Write ``fig`` to ``path`` (the format its suffix names) whole or not at all, and close it."""
    try:
        atomic_write(path, lambda handle: fig.savefig(handle, format=path.suffix[1:], bbox_inches="tight"))
    finally:
        plt.close(fig)
