"""``mjsuff report``: figures, the rule comparisons and a markdown summary linking them."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from mjsuff.atomic import atomic_write_text
from mjsuff.experiment.measures import measure_group, sampler_diagnostics
from mjsuff.report.figures import (
    NAMES,
    bound_curve,
    bound_vs_demos,
    f1_and_demos,
    noise_ablation,
    noise_table,
    rule_curves,
)
from mjsuff.report.results import ReportCell, ReportError, load_cells
from mjsuff.report.statistics import RuleComparison, compare_rules, observations

H1 = (
    "**H1, decision quality between rules** (per replicate: the share of its stop decisions, over "
    "the rule's parameters × ε, that were correct)"
)
H2 = "**H2, demos needed between rules** (per replicate: averaged over the rule's parameters)"


def _num(x: float, digits: int = 2) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def _p(p: float) -> str:
    return "< 0.001" if p < 0.001 else f"= {p:.3f}"


def rule_table(cell: ReportCell) -> str:
    """Rows: rule (param); columns: ε; cells: F1 / demos needed."""
    curves = rule_curves(cell)
    if curves.empty:
        return "_no nEVD rule or baseline in this run_\n"
    eps = sorted(curves["epsilon"].unique())
    lines = ["| rule | " + " | ".join(f"ε = {e:g}" for e in eps) + " |", "| --- |" + " --- |" * len(eps)]
    nevd = curves[curves["rule"] == "nevd"].set_index("epsilon")
    lines.append(
        f"| {NAMES['nevd']} | "
        + " | ".join(
            f"{_num(nevd.loc[e, 'f1'])} / {_num(nevd.loc[e, 'demos'], 1)}" if e in nevd.index else "–"
            for e in eps
        )
        + " |"
    )
    for (rule, param), sub in curves[curves["rule"] != "nevd"].groupby(["rule", "param"], sort=False):
        sub = sub.set_index("epsilon")
        lines.append(
            f"| {NAMES[rule]} ({param:g}) | "
            + " | ".join(f"{_num(sub.loc[e, 'f1'])} / {_num(sub.loc[e, 'demos'], 1)}" for e in eps)
            + " |"
        )
    return "\n".join(lines) + "\n"


def accuracy_table(cell: ReportCell) -> str:
    """The nEVD rule per ε: F1, bound accuracy and error at the evaluated step, demos, TPR, FPR."""
    nevd = cell.steps[cell.steps["rule"] == "nevd"]
    lines = [
        "| ε | F1 | accuracy | bound error | demos needed | TPR | FPR |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for eps, group in nevd.groupby("param"):
        m = measure_group(group, False, float(eps))
        lines.append(
            f"| {eps:g} | {_num(m['f1'])} | {_num(m['accuracy'])} | "
            f"{_num(m['bound_error'], 3)} | {_num(m['demos_needed'], 1)} ± "
            f"{_num(m['demos_needed_sem'], 1)} | {_num(m['tpr'])} | {_num(m['fpr'])} |"
        )
    curve = bound_curve(cell)
    every = cell.steps[cell.steps["rule"] == "nevd"]
    every = every[every["param"] == every["param"].min()]
    overall = float((every["bound"] >= every["true_nevd"]).mean()) if len(every) else math.nan
    lines.append("")
    lines.append(
        f"Bound ≥ true nEVD over every replicate and demo count: {_num(overall)} "
        f"({len(every)} checks; by demo count: "
        + ", ".join(
            f"{int(s)}: {_num(float(a))}"
            for s, a in zip(
                curve["step"],
                every.groupby("step").apply(
                    lambda g: (g["bound"] >= g["true_nevd"]).mean(), include_groups=False
                ),
                strict=True,
            )
        )
        + ")."
    )
    return "\n".join(lines) + "\n"


def paper_table(cell: ReportCell) -> str:
    """The bound rules per threshold, scored as the paper's code scores them (every demo step a
    decision; ``mjsuff.experiment.measures``), beside our per-replicate F1."""
    bound_rules = cell.steps[cell.steps["rule"].isin(["nevd", "piob"])]
    if bound_rules.empty:
        return "_no bound rule in this run_\n"
    lines = [
        "| rule | threshold | F1 (ours, per replicate) | F1 (notebook, FN = 1) | F1 (per step) "
        "| demos (every sufficient step) | share of states |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for (rule, param), group in bound_rules.groupby(["rule", "param"], sort=False):
        m = measure_group(group, rule == "piob", float(param))
        lines.append(
            f"| {rule} | {param:g} | {_num(m['f1'])} | {_num(m['paper_f1_notebook'])} | "
            f"{_num(m['paper_f1_per_step'])} | {_num(m['paper_demos'], 1)} | "
            f"{_num(m['paper_pct_states'])} |"
        )
    return "\n".join(lines) + "\n"


def sampler_table(cell: ReportCell) -> str:
    """MCMC diagnostics per demo step (the posterior each step's bounds came from)."""
    steps = cell.steps
    if "converged" not in steps:
        return "(no sampler diagnostics: a run from before mjsuff recorded them)\n"
    lines = [
        "| demos | mean R̂ | max R̂ | mean ESS | min ESS | converged | bound ESS | MCMC steps |",
        "|---|---|---|---|---|---|---|---|",
    ]
    per_step = steps.drop_duplicates(["replicate", "step"])
    for step, g in per_step.groupby("step", sort=True):
        d = sampler_diagnostics(g)
        lines.append(
            f"| {step} | {d['mean_rhat']:.3f} | {d['max_rhat']:.3f} | {d['mean_ess']:.0f} | "
            f"{d['min_ess']:.0f} | {d['converged']:.2f} | {d['mean_bound_ess']:.0f} | "
            f"{d['mean_mcmc_steps']:.0f} |"
        )
    return "\n".join(lines) + "\n"


def comparison_text(comparison: RuleComparison | None, what: str) -> str:
    """Kruskal-Wallis, the medians and Dunn's adjusted p-values, as markdown."""
    if comparison is None:
        return f"{what}: not enough variation between rules for a test.\n"
    medians = ", ".join(f"{NAMES[r]} {m:.3g}" for r, m in comparison.medians().items())
    counts = ", ".join(f"{NAMES[r]} n = {v.size}" for r, v in comparison.groups.items())
    lines = [
        f"{what}: Kruskal-Wallis H = {comparison.h:.1f}, p {_p(comparison.p)} "
        f"({counts}); medians: {medians}.",
        "",
        "Dunn post-hoc, Bonferroni-adjusted p:",
        "",
        "| | " + " | ".join(NAMES[c] for c in comparison.dunn.columns) + " |",
        "| --- |" + " --- |" * len(comparison.dunn.columns),
    ]
    for r, row in comparison.dunn.iterrows():
        lines.append(f"| {NAMES[r]} | " + " | ".join(_p(float(v)).removeprefix("= ") for v in row) + " |")
    return "\n".join(lines) + "\n"


def write_report(directories: list[Path], out: Path) -> Path:
    """Write figures and ``report.md`` for the runs in ``directories`` into ``out``."""
    cells = load_cells(directories)
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / ".write-probe").write_text("ok")
        (out / ".write-probe").unlink()
    except OSError as exc:
        raise ReportError(f"{out}: --out is not writable ({exc.strerror or exc})") from None
    parts = ["# mjsuff report", "", "Sources: " + ", ".join(f"`{d}`" for d in directories), ""]
    bound_fig = bound_vs_demos(cells, out / "bound_vs_demos.png")
    for i, cell in enumerate(cells):
        replicates = cell.steps["replicate"].nunique()
        figure = f1_and_demos(cell, out / f"f1_and_demos_{i:02d}.png")
        quality_obs, demo_obs = observations(cell.steps, cell.thresholds)
        parts += [
            f"## {cell.title} ({replicates} replicates)",
            "",
            f"![F1 and demos needed vs. ε]({figure.name})",
            "",
            "F1 / demos needed per rule and threshold (baselines scored at every ε):",
            "",
            rule_table(cell),
            "The nEVD rule:",
            "",
            accuracy_table(cell),
            "The bound rules scored as the paper's code scores them (every demo step a decision, no stop):",
            "",
            paper_table(cell),
            "Tests between rules: one observation per replicate and rule (a rule's "
            "parameters averaged within the replicate).",
            "",
            comparison_text(compare_rules(quality_obs, "correct"), H1),
            comparison_text(compare_rules(demo_obs, "demos"), H2),
            "The posteriors (R̂: rank-normalized split-R̂ of the final window; ESS: the "
            "smaller of bulk and tail of the kept draws; bound ESS: the effective size the "
            "nEVD bound's index used; a posterior that did not converge is never used to "
            "stop):",
            "",
            sampler_table(cell),
        ]
    parts += ["## nEVD bound and true nEVD vs. demos", "", f"![bound vs demos]({bound_fig.name})", ""]
    noise_fig = noise_ablation(cells, out / "noise_ablation.png")
    if noise_fig is not None:
        table = noise_table(cells)
        parts += [
            "## Noise ablation (nEVD rule)",
            "",
            f"![noise ablation]({noise_fig.name})",
            "",
            _frame_markdown(table),
            "",
        ]
    path = out / "report.md"
    atomic_write_text(path, "\n".join(parts))
    return path


def _frame_markdown(frame: pd.DataFrame) -> str:
    cols = list(frame.columns)
    lines = ["| " + " | ".join(cols) + " |", "|" + " --- |" * len(cols)]
    for _, row in frame.iterrows():
        lines.append("| " + " | ".join(_num(v) if isinstance(v, float) else str(v) for v in row) + " |")
    return "\n".join(lines)
