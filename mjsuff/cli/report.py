"""``mjsuff report``: figures, rule comparisons and a markdown summary of finished runs."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from mjsuff.cli.console import say


def add_parser(commands: Any) -> None:
    report = commands.add_parser(
        "report",
        help="figures, rule comparisons and a markdown summary of finished runs",
        description="Write the paper's figures (F1 and demos needed vs. ε, bound and true nEVD vs. "
        "demos, the noise ablation), Kruskal-Wallis and Dunn-Bonferroni tests between rules, and "
        "report.md linking them. Give one run or sweep directory, or several runs (labelled by the "
        "scenario keys in which they differ).",
    )
    report.add_argument("directories", nargs="+", metavar="DIR", help="run or sweep directories")
    report.add_argument("--out", help="where to write (default: DIR/report of the first DIR)")
    report.set_defaults(func=cmd_report)


def cmd_report(args: argparse.Namespace) -> int:
    from mjsuff.report import write_report  # matplotlib only when asked for

    directories = [Path(d) for d in args.directories]
    out_dir = Path(args.out) if args.out else directories[0] / "report"
    path = write_report(directories, out_dir)
    figures = sorted(p.name for p in out_dir.glob("*.png"))
    say(f"report: {path} (figures: {', '.join(figures)})")
    return 0
