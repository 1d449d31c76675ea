"""Markdown tables of measured results beside the paper's, from `mjsuff run` output directories.

    python benchmarks/paper_tables.py --gridworld DIR --gridworld-active DIR \
        --driving DIR --driving-active DIR [--alpha 0.9=DIR --alpha 0.99=DIR]

Each DIR is a finished run of scenarios/gridworld.toml or scenarios/driving.toml (the active ones
with --set demos.selection=active; the --alpha ones with --set sufficiency.alpha=A).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd

PAPER_PIOB_F1 = {0.2: "1.00", 0.4: "0.97", 0.6: "0.95"}


def load(directory: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    summary = json.loads((Path(directory) / "summary.json").read_text())
    return pd.DataFrame(summary["entries"]), pd.DataFrame(summary["nevd_bound_by_step"])


def fmt(x: float, digits: int = 2) -> str:
    return "–" if x is None or pd.isna(x) else f"{x:.{digits}f}"


def figure_2(curves: dict[str, pd.DataFrame], max_step: int = 10) -> str:
    lines = ["| demos | " + " | ".join(f"α={a}: mean bound / true nEVD / accuracy" for a in curves)
             + " |", "|" + "---|" * (len(curves) + 1)]
    for step in range(1, max_step + 1):
        cells = []
        for curve in curves.values():
            row = curve[curve["step"] == step].iloc[0]
            cells.append(f"{fmt(row['mean_bound'])} / {fmt(row['mean_true_nevd'], 3)} / "
                         f"{fmt(row['bound_accuracy'])}")
        lines.append(f"| {step} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def figure_4(entries: pd.DataFrame) -> str:
    lines = ["| rule | param | F1 | accuracy | bound error | demos needed (± s.e.) | share of states "
             "| TPR | FPR |", "|---|---|---|---|---|---|---|---|---|"]
    for _, e in entries.iterrows():
        if e["rule"] in ("patience", "validation") and e["epsilon"] != 0.3:
            continue
        lines.append(
            f"| {e['rule']}{' (ε=0.3)' if e['rule'] in ('patience', 'validation') else ''} | "
            f"{e['param']:g} | {fmt(e['f1'])} | {fmt(e['accuracy'])} | {fmt(e['bound_error'], 3)} | "
            f"{fmt(e['demos_needed'], 1)} ± {fmt(e['demos_needed_sem'], 1)} | "
            f"{fmt(e['fraction_of_states'])} | {fmt(e['tpr'])} | {fmt(e['fpr'])} |")
    return "\n".join(lines)


def baselines_over_thresholds(entries: pd.DataFrame) -> str:
    lines = ["| rule | param | " + " | ".join(f"F1 @ ε={t:g}" for t in (0.1, 0.2, 0.3, 0.4, 0.5))
             + " | demos needed |", "|---|---|---|---|---|---|---|---|"]
    for (r, p), g in entries[entries["rule"].isin(["patience", "validation"])].groupby(
            ["rule", "param"], sort=False):
        lines.append(f"| {r} | {p:g} | " + " | ".join(fmt(x) for x in g["f1"]) +
                     f" | {fmt(g['demos_needed'].iloc[0], 1)} |")
    return "\n".join(lines)


def table_2(domains: dict[str, pd.DataFrame]) -> str:
    lines = ["| PIOB threshold | paper (discrete) | " + " | ".join(
        f"{d}: F1 / accuracy / demos" for d in domains) + " |", "|" + "---|" * (len(domains) + 2)]
    for t in (0.2, 0.4, 0.6):
        cells = []
        for entries in domains.values():
            e = entries[(entries["rule"] == "piob") & (entries["param"] == t)].iloc[0]
            cells.append(f"{fmt(e['f1'])} / {fmt(e['accuracy'])} / {fmt(e['demos_needed'], 1)}")
        lines.append(f"| {t:.0%} | {PAPER_PIOB_F1[t]} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def table_3(pairs: dict[str, tuple[pd.DataFrame, pd.DataFrame]]) -> str:
    lines = ["| domain | rule | share of states, passive | active | reduction | F1 passive "
             "| F1 active | paper reduction |", "|---|---|---|---|---|---|---|---|"]
    paper = {"nevd": "12.95% ± 1.62%", "piob": "13.24% ± 0.65%"}
    for name, (passive, active) in pairs.items():
        for r in ("nevd", "piob"):
            p, a = passive[passive["rule"] == r], active[active["rule"] == r]
            sp, sa = p["fraction_of_states"].mean(), a["fraction_of_states"].mean()
            lines.append(f"| {name} | {r} | {fmt(sp)} | {fmt(sa)} | {(sp - sa) / sp:.0%} | "
                         f"{fmt(p['f1'].mean())} | {fmt(a['f1'].mean())} | {paper[r]} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gridworld", required=True)
    parser.add_argument("--gridworld-active", required=True)
    parser.add_argument("--driving", required=True)
    parser.add_argument("--driving-active", required=True)
    parser.add_argument("--alpha", action="append", default=[], metavar="A=DIR")
    args = parser.parse_args()
    grid, grid_curve = load(args.gridworld)
    drive, _ = load(args.driving)
    curves = {float(a.split("=")[0]): load(a.split("=", 1)[1])[1] for a in args.alpha}
    curves[0.95] = grid_curve
    curves = dict(sorted(curves.items()))
    print("### Figure 2 (gridworld): nEVD bound vs. demos\n")
    print(figure_2(curves))
    for name, entries in (("Gridworld", grid), ("Driving", drive)):
        print(f"\n### Figure 4 / Appendix E ({name}, passive)\n")
        print(figure_4(entries))
        print(f"\n{name}: baselines scored at every nEVD threshold\n")
        print(baselines_over_thresholds(entries))
    print("\n### Table 2: PIOB rule\n")
    print(table_2({"Gridworld": grid, "Driving": drive}))
    print("\n### Table 3: active vs. passive selection\n")
    print(table_3({"Gridworld": (grid, load(args.gridworld_active)[0]),
                   "Driving": (drive, load(args.driving_active)[0])}))


if __name__ == "__main__":
    main()
