"""``mjsuff hoeffding``: the paper's Table 1, demos a Hoeffding bound needs."""

from __future__ import annotations

import argparse
from typing import Any

from rich.table import Table

from mjsuff.bounds.hoeffding import abbeel_ng_demos, syed_schapire_demos
from mjsuff.cli.console import out


def add_parser(commands: Any) -> None:
    hoeffding = commands.add_parser(
        "hoeffding", help="print the paper's Table 1 (Hoeffding-based demo counts)"
    )
    hoeffding.add_argument("--gamma", type=float, default=0.95, help="discount factor γ (default 0.95)")
    hoeffding.add_argument("--k", type=int, default=4, help="number of reward features (default 4)")
    hoeffding.add_argument("--delta", type=float, default=0.05, help="1 − confidence (default 0.05)")
    hoeffding.add_argument(
        "--thresholds", type=float, nargs="+", default=[0.1, 0.2, 0.3, 0.4, 0.5], help="the table's rows"
    )
    hoeffding.set_defaults(func=cmd_hoeffding)


def cmd_hoeffding(args: argparse.Namespace) -> int:
    confidence = f"{1 - args.delta:.0%}"
    table = Table(
        title=f"Demos for a {confidence}-confidence Hoeffding bound (γ = {args.gamma}, k = {args.k})"
    )
    for col in ("Threshold", "Abbeel and Ng", "Syed and Schapire"):
        table.add_column(col, justify="right")
    for eps in args.thresholds:
        table.add_row(
            f"{eps:g}",
            f"{abbeel_ng_demos(eps, args.gamma, args.k, args.delta):,}",
            f"{syed_schapire_demos(eps, args.gamma, args.k, args.delta):,}",
        )
    out.print(table)
    return 0
